"""The metric columns of a sweep's ``runs.csv`` (after the key columns of each run)."""

from __future__ import annotations

from learning.episode import LOSS_CAUSES

SPATIAL_CONTACTS = tuple(
    f"contacts_{kind}_per_robot_h"
    for kind in ("robot_touch", "robot_impact", "wall_touch", "wall_impact")
)
# what the avoidance report and --against compare: tasks, arrival, failures and contacts
MOTION_METRICS = ("tasks_allocated", "time_to_start_s", "failed_tasks", *SPATIAL_CONTACTS)

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
    "time_to_start_s",  # spatial: allocation to arrival, per completed task
    "failed_tasks",  # spatial: tasks reported failed over the whole run, learning sets too
    # spatial: contacts begun per robot-hour, by kind, whole run (sim.spatial.contacts)
    *SPATIAL_CONTACTS,
    "scarce_types",  # the types with the fewest willing robots at the end, ";"-joined
    "completion_scarce_low",  # completion of those types (mean over them), low priority
    "completion_scarce_high",  # ... high priority
    "abandoned",  # faults: test-set tasks abandoned because their robot broke
    "requeued",  # faults: of those, re-announced
    "availability",  # faults: mean share of the run a robot was not broken
)
INT_COLUMNS = {"seed", "tasks_announced", "tasks_allocated", "space_initial", "space_final"}
INT_COLUMNS |= {
    "abandoned",
    "requeued",
    "kept_capabilities",
    "min_willing",
    "failed_tasks",
    *(f"lost_{c}" for c in LOSS_CAUSES),
}
