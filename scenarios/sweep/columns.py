"""The metric columns of a sweep's ``runs.csv`` (after the key columns of each run)."""

from __future__ import annotations

from learning.episode import LOSS_CAUSES

METRIC_COLUMNS = (
    "completion_low",
    "completion_high",
    "completion_all",
    "tasks_announced",
    "tasks_allocated",
    "space_initial",
    "space_final",
    "space_joint_log10",
    "kept_capabilities",  # (robot, type) pairs still willing at the end (ExpT refusals shrink it)
    "min_willing",  # fewest willing robots of any type at the end
    "offered_load",  # mean batch x mean execution time / (announce interval x robots)
    *(f"lost_{cause}" for cause in LOSS_CAUSES),  # test-set tasks lost, by cause
    "specialisation_bits",  # mean over robots of the entropy of the types each was given
    "distance_per_task_m",  # spatial: metres driven per completed task (test sets)
    "time_per_task_s",  # spatial: allocation to done, per completed task
)
INT_COLUMNS = {"seed", "tasks_announced", "tasks_allocated", "space_initial", "space_final"}
INT_COLUMNS |= {"kept_capabilities", "min_willing", *(f"lost_{c}" for c in LOSS_CAUSES)}
