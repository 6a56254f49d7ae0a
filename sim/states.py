"""What a robot is doing: the states the fleet keeps and the trajectory records.

``IDLE`` (no task), ``DRIVING`` (to its task's site, or stepping aside), ``WORKING`` (at the
site, for the task's execution time). ``WAITING`` is recorded only, never kept: a driving robot
that decided to wait (holding in a site's queue, or for a robot at work to finish), whose stuck
clock is stopped.
"""

from __future__ import annotations

import numpy as np

IDLE, DRIVING, WORKING = 0, 1, 2
WAITING = 3  # recorded only (never in the fleet state): driving, but decided to wait (holding
# in a site's queue, for a robot at work to finish): its stuck clock is stopped


def shown_states(state: np.ndarray, t_progress_s: np.ndarray, t_s: float) -> np.ndarray:
    """The states to record: ``WAITING`` for a driving robot whose stuck clock is set after
    ``t_s`` (progress sets it to now; only a decision to wait sets it later), else ``state``.
    The pymunk world records the same compiled (``sim.spatial.fleet.shown_now``); this is its
    reference in the tests."""
    return np.where((state == DRIVING) & (t_progress_s > t_s), WAITING, state)
