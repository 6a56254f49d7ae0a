"""Waiting for a repair (``Jobs.wait_for_repair``, ``retry_blocked``, and the ways in:
``assign`` and ``replan``) with planners set by hand: the world's planner sees a plug in
the only gap (where broken robots stand), the scenario's planner does not. Written for the
gaps mutation run H found in ``sim/spatial/jobs.py`` (README, "Testing"); the whole story with a
robot that breaks down is in ``test_faults.py``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sim.scenario import RecoverySpec
from sim.spatial.navigation.planning import GridPlanner
from tests.sim.test_jobs import GAP, at, give, make_world, waypoints

# the settings' defaults (sim.scenario), under the names these tests use
REPAIR_WAIT_S = RecoverySpec().repair_wait_s


PLUG = ((9.8, 4.5), (10.2, 4.5), (10.2, 5.5), (9.8, 5.5))  # broken robots fill the gap
BOX = [  # walls round (16, 2): closed to the world's planner once the plug is gone
    ((14.6, 0.6), (17.4, 0.6), (17.4, 0.8), (14.6, 0.8)),
    ((14.6, 3.2), (17.4, 3.2), (17.4, 3.4), (14.6, 3.4)),
    ((14.6, 0.6), (14.8, 0.6), (14.8, 3.4), (14.6, 3.4)),
    ((17.2, 0.6), (17.4, 0.6), (17.4, 3.4), (17.2, 3.4)),
]


def planner(w, *extra) -> GridPlanner:
    """The world's arena with ``extra`` obstacles."""
    return GridPlanner(dataclasses.replace(w.spatial, obstacles=(*GAP, *extra)))


def length_m(path: np.ndarray) -> float:
    return float(np.abs(np.diff(path[:, 0] + 1j * path[:, 1])).sum())


def plugged():
    """Robots 0 (4, 2) and 3 (4, 6) are sent through the plugged gap to (16, 2) and (16, 8),
    robot 1 (4, 8) to (6, 8) on its own side; robot 2, far off, is broken."""
    w = make_world([(4.0, 2.0), (4.0, 8.0), (18.0, 9.0), (4.0, 6.0)], obstacles=GAP)
    w.jobs.use_planner(planner(w, PLUG))
    w.jobs.broken[2] = True
    t = at(w, 10.0)
    give(w, [0, 1, 3], [(16.0, 2.0), (6.0, 8.0), (16.0, 8.0)])
    return w, w.fleet, w.jobs, t


def test_a_task_whose_only_way_broken_robots_block_waits_where_the_robot_stands():
    """Robots 0 and 3 hold where they stand (drawn as waiting: no stuck clock), with the way
    the scenario's obstacles leave (round the wall's end, through the gap) as what is left
    to drive and REPAIR_WAIT_S more time; robot 1, given its task after robot 0, drives."""
    w, f, jobs, t = plugged()
    assert jobs.blocked.tolist() == [True, False, False, True]
    for j, start, site in ((0, 4 + 2j, (16.0, 2.0)), (3, 4 + 6j, (16.0, 8.0))):
        assert waypoints(w, j).tolist() == [start, start]
        way = jobs.base_planner.path((start.real, start.imag), site)
        assert len(way) > 2  # it bends through the gap
        assert f.left_m[j] == length_m(way)
        assert f.deadline_s[j] == jobs.deadline_s(j, length_m(way), t) + REPAIR_WAIT_S
        assert (f.progress_m[j], f.t_progress_s[j]) == (-np.inf, np.inf)
    assert waypoints(w, 1).tolist() == [4 + 8j, 6 + 8j]


def test_after_a_repair_each_robot_with_a_way_drives_on_and_the_others_wait():
    """The plug goes, but robot 0's site is walled in for the world's planner: robot 0 waits
    on, robot 3 drives on through the gap with its deadline counted from now; one refresh,
    and the sites are looked at next period. With nobody given a way, nothing is refreshed."""
    w, f, jobs, _ = plugged()
    jobs.use_planner(planner(w, *BOX))
    calls = []
    jobs.refresh = lambda: calls.append(1)
    w.schedule.site_check_s = 50.0
    t = at(w, 30.0)
    jobs.retry_blocked(t)
    assert jobs.blocked.tolist() == [True, False, False, False]
    path = waypoints(w, 3)
    assert path[0] == 4 + 6j and path[-1] == 16 + 8j and len(path) > 2
    length = float(np.abs(np.diff(path)).sum())
    assert f.left_m[3] == length and f.deadline_s[3] == jobs.deadline_s(3, length, t)
    assert (f.progress_m[3], f.t_progress_s[3]) == (np.inf, t)
    assert w.schedule.site_check_s == -np.inf and len(calls) == 1
    w.schedule.site_check_s = 50.0
    jobs.retry_blocked(at(w, 31.0))  # robot 0 still has no way
    assert w.schedule.site_check_s == 50.0 and len(calls) == 1


def test_a_robot_that_backed_off_into_a_blocked_way_waits_for_the_repair():
    w = make_world([(4.0, 2.0), (18.0, 9.0)], obstacles=GAP)
    f, jobs = w.fleet, w.jobs
    give(w, [0], [(16.0, 2.0)])  # through the gap, open when given
    jobs.use_planner(planner(w, PLUG))
    jobs.broken[1] = True
    f.replan[0] = True
    t = at(w, 20.0)
    jobs.replan(0, (5.0, 2.5), t)
    assert jobs.blocked[0] and not f.replan[0]
    assert waypoints(w, 0).tolist() == [5 + 2.5j, 5 + 2.5j]
    way = jobs.base_planner.path((5.0, 2.5), (16.0, 2.0))
    assert f.deadline_s[0] == jobs.deadline_s(0, length_m(way), t) + REPAIR_WAIT_S
