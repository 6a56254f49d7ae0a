"""The arrival check after the stuck check of the same period.

A control period takes the robots driving to a site (``go``) once, then runs the stuck check,
then the arrival check with that same ``go``. A robot that the stuck check fails (its last
recovery spent) has no task by the time the arrival check sees it; standing at its site it
must not start work (a robot at work on no task ends as a completion of task -1, which the
run's bookkeeping refuses: "task -1 completed while never announced").
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.spatial.control.arrival import arrive
from sim.states import DRIVING, IDLE, WORKING
from tests.worlds import SITE, at, give, make_world


@pytest.mark.parametrize("avoidance", ["orca", "none"])
@pytest.mark.parametrize("control", ["compiled", "array", "scalar"])
def test_a_robot_failed_as_stuck_at_its_site_does_not_start_work(control, avoidance):
    w = make_world([(2.0, 5.0), (16.0, 8.0)], control=control, avoidance=avoidance)
    give(w, [0, 1], [(10.0, 5.0), (16.0, 2.0)], ids=[7, 8])
    f, jobs = w.fleet, w.jobs
    t = at(w, 30.0)
    f.last_z_m[0] = SITE - 0.01  # within arrive_tol_m of its site: it would start work
    f.last_z_m[1] = 16 + 2.01j  # robot 1 at its site as well, not stuck
    f.recoveries[0] = w.spatial.max_recoveries  # its last try is spent
    f.t_progress_s[:] = t
    f.t_progress_s[0] = t - 2.0 * w.spatial.stuck_timeout_s
    go = f.state == DRIVING  # as the period took it, before the stuck check
    jobs.check_stuck(go.copy(), t)
    assert f.task[0] == -1 and f.state[0] == IDLE
    assert [(c.task_id, c.ok) for c in jobs.done] == [(7, False)]
    m, z = 2, f.last_z_m.copy()
    if control == "scalar":
        w.control._arrive(z.tolist(), go.tolist(), [0.0] * m, [0.0] * m, t)
    else:
        arrive(w.control.parts, z, go, np.zeros(m), np.zeros(m), t)
    assert f.state.tolist() == [IDLE, WORKING]  # robot 1 arrived; robot 0 has nothing to do
    jobs.finish_work(t + 60.0)
    assert [(c.task_id, c.ok) for c in jobs.done] == [(7, False), (8, True)]
