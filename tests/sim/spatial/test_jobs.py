"""Task bookkeeping of the pymunk world (``sim.spatial.jobs.Jobs``), driven directly.

Each test builds a small world for its collaborators (fleet state, schedule, clock, follower,
planner), sets the fleet state by hand and calls one event handler of ``world.jobs`` the way a
control period would; then it checks every number the handler writes. Distances are exact: with
no obstacle in the way a planned path is the straight segment, so its length is the distance.

Also here: where an idle robot steps off a stuck robot's way (``Jobs.step_off``) and waiting for
a repair (``Jobs.wait_for_repair``, ``retry_blocked``). The site queues and slots
(``sim.spatial.sites``) are in ``test_sites.py``, the jam rules (``sim.spatial.jams``) in
``test_jams.py``; the world's small scenes come from ``tests/worlds.py``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.scenario import JamSpec, MakeWaySpec, RecoverySpec
from sim.spatial.jobs import Jobs, _to_polyline
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.world import PymunkWorld
from sim.states import DRIVING, IDLE, WORKING
from sim.world import Completion
from tests.worlds import (
    AISLE,
    GAP,
    ROOM,
    SHELF,
    at,
    deadlock,
    done,
    give,
    make_world,
    orca_world,
    set_way,
    waypoints,
)

# the settings' defaults (sim.scenario), under the names these tests use
BACKOFF_S = RecoverySpec().backoff_s
YIELD_TIMEOUT_S = MakeWaySpec().timeout_s
V_MAX = 1.5  # m/s, the default drive's top speed
OMEGA_MAX = 7.5  # rad/s, its top turn rate: rim speed / half the wheel base
TIMEOUT = 20.0  # s, the default stuck timeout
REACH = 0.6  # m, centres closer than two radii (0.25 m) + 0.1 m touch


def test_assign_writes_every_field_of_the_task_and_plans_the_path_from_the_given_positions():
    w = make_world([(2.0, 5.0), (2.0, 2.0), (8.0, 8.0)])
    f, jobs = w.fleet, w.jobs
    t = at(w, 2.0)
    f.moved_m[:] = [1.0, 3.5, 7.0]
    f.recoveries[1], f.replan[1], f.stuck_left_m[1] = 2, True, 4.0  # left over from before
    f.backoff_until_s[1], f.yielding[1], jobs.sites.slotted[1] = 9.0, True, True
    xy = [(2.0, 5.0), (3.0, 2.0), (8.0, 8.0)]  # robot 1 has moved since its start
    give(w, [1, 0], [(12.0, 5.0), (2.0, 8.0)], types=[1, 0], ids=[7, 9], bids=[3.25, 4.5], xy=xy)
    assert f.task.tolist() == [9, 7, -1]
    assert f.task_type.tolist() == [0, 1, 0]
    assert f.state.tolist() == [DRIVING, DRIVING, IDLE]
    assert f.t_alloc_s[:2].tolist() == [t, t]
    assert f.bid[:2].tolist() == [4.5, 3.25]
    assert f.site.tolist() == [2 + 8j, 12 + 5j, 8 + 8j]
    assert f.odo0_m.tolist() == [1.0, 3.5, 0.0]
    assert f.recoveries.tolist() == [0, 0, 0]
    assert f.replan.tolist() == [False, False, False]
    assert f.stuck_left_m[:2].tolist() == [np.inf, np.inf]
    assert f.backoff_until_s[:2].tolist() == [-np.inf, -np.inf]
    assert f.yielding.tolist() == [False, False, False]
    assert jobs.sites.slotted.tolist() == [False, False, False]
    assert jobs.jams.origin.tolist() == [2 + 5j, 3 + 2j, 8 + 8j]
    d1 = np.hypot(9.0, 3.0)  # (3, 2) -> (12, 5)
    assert f.left_m[:2] == pytest.approx([3.0, d1], rel=1e-12)
    assert f.progress_m[:2].tolist() == [np.inf, np.inf]
    assert f.t_progress_s[:2].tolist() == [t, t]
    slack = (3 + 1) * (TIMEOUT + BACKOFF_S) + 30.0  # default max_recoveries 3
    expect = [t + 2.0 + 4 * 3.0 / V_MAX + slack, t + 5.0 + 4 * d1 / V_MAX + slack]
    assert f.deadline_s[:2] == pytest.approx(expect, rel=1e-12)
    assert waypoints(w, 0).tolist() == [2 + 5j, 2 + 8j]
    assert waypoints(w, 1).tolist() == [3 + 2j, 12 + 5j]
    assert w.follower.last[2] == -1
    sch = w.schedule
    assert sch.site_check_s == -np.inf
    assert sch.next_deadline_s == pytest.approx(expect[0], rel=1e-12)
    assert (sch.n_steer, sch.n_backoff, sch.n_yield) == (2, 0, 0)
    assert sch.state_list == [DRIVING, DRIVING, IDLE]
    assert sch.steer_list == [0, 1]
    assert jobs.done == [] and jobs.failures == 0


def test_assign_deadline_slack_follows_the_stuck_timeout_and_the_tries():
    w = make_world([(2.0, 5.0)], stuck_timeout_s=4.0, max_recoveries=1)
    t = at(w, 1.0)
    give(w, [0], [(8.0, 5.0)], types=[1])
    slack = (1 + 1) * (4.0 + BACKOFF_S) + 30.0
    assert w.fleet.deadline_s[0] == pytest.approx(t + 5.0 + 4 * 6.0 / V_MAX + slack, rel=1e-12)


def test_assign_to_a_busy_robot_or_without_a_site_raises():
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    give(w, [0], [(8.0, 5.0)])
    with pytest.raises(
        RuntimeError, match=r"^invariant violated: robot 0 given a task while busy$"
    ):
        give(w, [0], [(8.0, 2.0)], ids=[3])
    with pytest.raises(ValueError, match=r"^task 12 has no site: a spatial world needs one$"):
        give(w, [1], [(np.nan, 2.0)], ids=[12])
    with pytest.raises(ValueError, match=r"^task 13 has no site"):
        give(w, [1], [(4.0, np.inf)], ids=[13])


def test_assign_fails_an_unreachable_task_at_once_and_starts_the_others():
    w = make_world([(2.0, 5.0), (2.0, 2.0)], obstacles=ROOM)
    f = w.fleet
    t = at(w, 3.0)
    f.moved_m[:] = [4.0, 6.5]
    give(w, [0, 1], [(15.0, 5.0), (8.0, 2.0)], ids=[5, 6], bids=[2.5, 1.5])
    reason = "unreachable: no path from (2.00, 5.00) to (15.00, 5.00)"
    assert done(w) == [Completion(5, 0, t, t, 2.5, 0.0, False, reason)]
    assert w.jobs.failures == 1
    assert f.task.tolist() == [-1, 6]
    assert f.state.tolist() == [IDLE, DRIVING]
    assert f.left_m[1] == pytest.approx(6.0, rel=1e-12)
    assert w.schedule.state_list == [IDLE, DRIVING]
    assert w.schedule.n_steer == 1


def test_busy_until_is_the_path_left_at_top_speed_plus_the_work_or_the_end_of_work():
    w = make_world([(2.0, 5.0), (2.0, 2.0), (8.0, 8.0), (8.0, 2.0), (5.0, 5.0)])
    f = w.fleet
    f.state[:] = [DRIVING, WORKING, WORKING, IDLE, DRIVING]
    f.task_type[:] = [1, 1, 0, 1, 0]
    f.left_m[:] = [3.0, 9.0, 9.0, 9.0, 0.75]
    f.work_end_s[:] = [50.0, 14.0, 7.0, 30.0, 50.0]
    busy = w.jobs.busy_until_s(10.0)
    assert busy.tolist() == [10.0 + 2.0 + 5.0, 14.0, 10.0, 10.0, 10.0 + 0.5 + 2.0]


def test_refresh_counts_and_next_times_read_only_the_robots_they_are_about():
    w = make_world([(x, 5.0) for x in (2.0, 4.0, 6.0, 8.0, 10.0, 12.0)])
    f, sch = w.fleet, w.schedule
    t = at(w, 10.0)
    f.state[:] = [WORKING, IDLE, DRIVING, WORKING, IDLE, DRIVING]
    f.task[:] = [1, -1, 2, 3, -1, 0]  # task ids count from 0
    f.work_end_s[:] = [15.0, 3.0, 4.0, 12.0, 1.0, 2.0]  # only 0 and 3 work
    f.deadline_s[:] = [90.0, 5.0, 70.0, 80.0, 6.0, 60.0]  # 1 and 4 hold no task
    f.replan[:] = [False, False, True, False, False, False]
    f.backoff_until_s[:] = [-np.inf, -np.inf, -np.inf, -np.inf, t, t + 0.5]  # 4: ends now
    f.yielding[:] = [False, True, False, False, True, False]
    sch.stuck_check_s = sch.prox_check_s = 99.0
    sch.resting = True
    w.jobs.refresh()
    assert sch.next_end_s == 12.0
    assert sch.next_deadline_s == 60.0
    assert sch.n_backoff == 2  # robot 2 replans, robot 5 backs off; robot 4's back-off is over
    assert sch.n_yield == 2
    assert sch.n_steer == 2 + 2
    assert sch.state_list == [WORKING, IDLE, DRIVING, WORKING, IDLE, DRIVING]
    assert sch.steer_list == [1, 2, 4, 5]
    assert sch.stuck_check_s == -np.inf and sch.prox_check_s == -np.inf
    assert sch.resting is False


def test_refresh_with_no_task_leaves_no_next_event():
    w = make_world([(2.0, 5.0), (4.0, 5.0)])
    f, sch = w.fleet, w.schedule
    f.work_end_s[:] = [3.0, 4.0]
    f.deadline_s[:] = [3.0, 4.0]
    sch.next_end_s = sch.next_deadline_s = 1.0
    w.jobs.refresh()
    assert (sch.next_end_s, sch.next_deadline_s) == (np.inf, np.inf)
    assert (sch.n_backoff, sch.n_yield, sch.n_steer) == (0, 0, 0)
    assert sch.steer_list == []


def test_refresh_of_the_array_control_keeps_no_lists():
    w = make_world([(2.0, 5.0), (4.0, 5.0)], control="array")
    sch = w.schedule
    sch.state_list, sch.steer_list = ["untouched"], ["untouched"]
    give(w, [1], [(8.0, 5.0)])
    assert w.jobs.keep_lists is False
    assert sch.n_steer == 1
    assert (sch.state_list, sch.steer_list) == (["untouched"], ["untouched"])


def test_start_work_stops_the_robots_and_sets_the_end_of_their_work():
    w = make_world([(2.0, 5.0), (2.0, 2.0), (8.0, 8.0)])
    f, sch = w.fleet, w.schedule
    give(w, [0, 1, 2], [(6.0, 5.0), (6.0, 2.0), (9.0, 8.0)], types=[0, 1, 1])
    v, wz = np.array([1.0, 1.2, 1.4]), np.array([0.1, 0.2, 0.3])
    sch.next_end_s = 100.0
    t = at(w, 4.0)
    w.jobs.jams.began[:] = False
    w.jobs.start_work([1], v, wz, t)
    assert f.state.tolist() == [DRIVING, WORKING, DRIVING]
    assert w.jobs.jams.began.tolist() == [False, True, False]  # ways may pass it (look_ahead)
    assert f.work_end_s[1] == t + 5.0
    assert f.t_progress_s[1] == np.inf and f.t_progress_s[0] == 0.0
    assert (v.tolist(), wz.tolist()) == ([1.0, 0.0, 1.4], [0.1, 0.0, 0.3])
    assert w.follower.last[1] == -1 and w.follower.last[0] == 1
    assert sch.next_end_s == t + 5.0
    assert sch.state_list == [DRIVING, WORKING, DRIVING] and sch.n_steer == 2
    sch.resting = True
    w.jobs.start_work([], v, wz, t)  # nobody arrived: no refresh
    assert sch.resting is True


def test_start_work_of_several_robots_in_one_call():
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    f, sch = w.fleet, w.schedule
    give(w, [0, 1], [(6.0, 5.0), (6.0, 2.0)], types=[1, 0])
    v, wz = np.ones(2), np.ones(2)
    t = at(w, 3.0)
    w.jobs.start_work([0, 1], v, wz, t)
    assert f.work_end_s.tolist() == [t + 5.0, t + 2.0]
    assert sch.next_end_s == t + 2.0
    assert sch.n_steer == 0 and sch.state_list == [WORKING, WORKING]


def working(w: PymunkWorld, ends, types=None) -> None:
    """Every robot holds a task (ids 0, 1, ...) and works until ends[j]."""
    f = w.fleet
    give(w, list(range(len(ends))), [(x + 3.0, y) for x, y in w.starts_], types=types)
    w.jobs.start_work(list(range(len(ends))), np.zeros(len(ends)), np.zeros(len(ends)), 0.0)
    f.work_end_s[:] = ends
    w.jobs.refresh()


def test_finish_work_reports_the_work_done_at_its_end_time_not_now():
    w = make_world([(2.0, 5.0), (2.0, 2.0), (8.0, 8.0)])
    f = w.fleet
    working(w, [10.0, 10.0 + 0.5e-9, 10.0 + 2e-9])
    f.moved_m[:] = [3.0, 4.0, 5.0]
    w.jobs.finish_work(10.0)
    out = done(w)
    assert [(c.task_id, c.robot, c.t_done_s, c.ok, c.reason) for c in out] == [
        (0, 0, 10.0, True, ""),
        (1, 1, 10.0 + 0.5e-9, True, ""),
    ]
    assert [c.distance_m for c in out] == [3.0, 4.0]
    assert f.task.tolist() == [-1, -1, 2]
    assert f.state.tolist() == [IDLE, IDLE, WORKING]
    assert w.schedule.next_end_s == 10.0 + 2e-9
    assert w.jobs.failures == 0


def test_end_due_ends_work_within_a_nanosecond_of_its_end():
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    working(w, [10.0, 12.0])
    w.jobs.end_due(10.0 - 2e-9)
    assert done(w) == []
    w.jobs.end_due(10.0 - 0.5e-9)
    assert [c.task_id for c in done(w)] == [0]
    assert w.schedule.next_end_s == 12.0
    w.fleet.work_end_s[1] = 11.0 + 1e-9
    w.jobs.refresh()
    w.jobs.end_due(11.0)  # exactly 1e-9 s before the end
    assert [c.task_id for c in done(w)] == [1]


def test_end_due_fails_the_tasks_past_their_deadline_and_only_those():
    w = make_world([(2.0, 5.0), (2.0, 2.0), (8.0, 8.0)])
    f, sch = w.fleet, w.schedule
    give(w, [0, 1, 2], [(6.0, 5.0), (6.0, 2.0), (9.0, 8.0)], ids=[0, 5, 6])
    f.deadline_s[:] = [30.0, 30.5, 30.0]
    f.moved_m[:] = [2.0, 0.0, 1.0]
    w.jobs.refresh()
    w.jobs.end_due(30.0)  # deadline reached, not passed
    assert done(w) == [] and f.task.tolist() == [0, 5, 6]
    sch.resting = True
    w.jobs.end_due(30.5)
    why = "timeout: not at work by its deadline"
    assert done(w) == [
        Completion(0, 0, 0.0, 30.5, 1.0, 2.0, False, why),
        Completion(6, 2, 0.0, 30.5, 1.0, 1.0, False, why),
    ]
    assert w.jobs.failures == 2
    assert f.task.tolist() == [-1, 5, -1]  # robot 1's deadline is now: not past yet
    assert sch.next_deadline_s == 30.5 and sch.resting is False
    assert sch.state_list == [IDLE, DRIVING, IDLE]


def test_work_begun_is_finished_past_the_deadline():
    # robot 0 reached its site and works past its deadline; robot 1 still drives: only it fails
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    f, sch = w.fleet, w.schedule
    give(w, [0, 1], [(6.0, 5.0), (6.0, 2.0)], ids=[3, 4])
    f.deadline_s[:] = [30.0, 31.0]
    w.jobs.start_work([0], np.zeros(2), np.zeros(2), 25.0)  # 2 s of work: ends at 27
    f.work_end_s[0] = 40.0  # (as if its work were long)
    w.jobs.refresh()
    assert sch.next_deadline_s == 31.0  # robot 0's deadline no longer counts
    w.jobs.end_due(35.0)
    assert [(c.task_id, c.ok) for c in done(w)] == [(4, False)]
    assert f.state.tolist() == [WORKING, IDLE]
    w.jobs.end_due(40.0)
    assert [(c.task_id, c.ok, c.t_done_s) for c in done(w)] == [(3, True, 40.0)]


def test_end_due_past_the_scheduled_deadline_with_nobody_late_refreshes_nothing():
    w = make_world([(2.0, 5.0)])
    give(w, [0], [(6.0, 5.0)])
    sch = w.schedule
    sch.next_deadline_s = 10.0  # stale: the task's deadline is later
    sch.resting = True
    w.jobs.end_due(11.0)
    assert done(w) == [] and sch.resting is True


def test_finish_reports_the_completion_and_frees_the_robot():
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    f, jobs = w.fleet, w.jobs
    at(w, 2.0)
    give(w, [0, 1], [(6.0, 5.0), (6.0, 2.0)], ids=[21, 22], bids=[3.0, 4.0])
    f.moved_m[:] = [5.5, 2.0]
    f.odo0_m[0] = 1.25
    f.stuck_left_m[0], f.replan[0], f.backoff_until_s[0] = 3.0, True, 12.0
    jobs.finish(0, 17.5, False, "why not")
    assert done(w) == [Completion(21, 0, 2.0, 17.5, 3.0, 4.25, False, "why not")]
    assert jobs.failures == 1
    assert f.task.tolist() == [-1, 22]
    assert f.state.tolist() == [IDLE, DRIVING]
    assert (f.stuck_left_m[0], f.replan[0], f.backoff_until_s[0]) == (np.inf, False, -np.inf)
    assert f.t_progress_s[0] == np.inf and f.t_progress_s[1] == 2.0
    assert w.follower.last.tolist() == [-1, 1]
    assert w.schedule.state_list == [IDLE, DRIVING] and w.schedule.n_steer == 1
    jobs.finish(1, 18.0, True)
    assert done(w) == [Completion(22, 1, 2.0, 18.0, 4.0, 2.0, True, "")]
    assert jobs.failures == 1


def test_finish_without_refresh_leaves_the_schedule_to_the_caller():
    w = make_world([(2.0, 5.0)])
    give(w, [0], [(6.0, 5.0)])
    w.schedule.resting = True
    w.jobs.finish(0, 5.0, True, refresh=False)
    assert w.schedule.resting is True and w.schedule.state_list == [DRIVING]
    assert w.fleet.task[0] == -1


def test_check_stuck_recovers_only_the_robots_stuck_longer_than_the_timeout():
    w = make_world([(2.0, 5.0), (2.0, 2.0), (8.0, 8.0), (8.0, 2.0)], seed=3)
    f, sch = w.fleet, w.schedule
    give(w, [0, 1, 2, 3], [(12.0, 5.0), (12.0, 2.0), (16.0, 8.0), (16.0, 2.0)])
    t = at(w, 50.0)
    f.t_progress_s[:] = [29.0, 30.0, 35.0, 29.5]
    go = np.array([True, True, True, False])  # robot 3 does not steer now
    w.jobs.check_stuck(go, t)
    assert f.recoveries.tolist() == [1, 0, 0, 0]  # 20 s without progress is not yet stuck
    assert f.replan.tolist() == [True, False, False, False]
    assert sch.stuck_check_s == 29.5 + TIMEOUT  # the stalest robot left, 3
    f.t_progress_s[:] = [np.inf, 31.0, 35.0, 32.0]
    w.jobs.check_stuck(go, t)  # nobody stuck: only the next check moves
    assert f.recoveries.tolist() == [1, 0, 0, 0]
    assert sch.stuck_check_s == 31.0 + TIMEOUT


def test_stuck_robot_backs_off_on_a_random_arc_then_replans():
    # without avoidance the arc turns at up to half the top turn rate (with it: the test below)
    w = make_world([(2.0, 5.0), (2.0, 2.0)], seed=11, avoidance="none")
    assert w.jobs.avoid is False
    f, sch = w.fleet, w.schedule
    give(w, [0, 1], [(12.0, 5.0), (12.0, 2.0)])
    t = at(w, 30.0)
    f.left_m[0] = 7.25
    w.jobs.recover(0, t)
    turn = np.random.default_rng(11).uniform(-0.5, 0.5) * OMEGA_MAX
    assert f.backoff_cmd[0] == pytest.approx([-0.3 * V_MAX, turn], rel=1e-12)
    assert f.backoff_until_s[0] == t + BACKOFF_S
    assert (f.t_progress_s[0], f.replan[0], f.recoveries[0]) == (np.inf, True, 1)
    assert f.stuck_left_m.tolist() == [7.25, np.inf]
    assert w.follower.last.tolist() == [-1, 1]
    assert sch.recovering is True
    assert (sch.n_backoff, sch.n_steer) == (1, 2)
    assert f.task.tolist() == [0, 1] and done(w) == []


@pytest.mark.parametrize("turn_radps", [1.0, 0.25, 0.0, 5.0])
def test_under_avoidance_the_back_off_arc_turns_at_most_avoid_turn(turn_radps):
    # nobody to ask aside, go round or give way to: the lone robot backs off, on the same draw
    # as without avoidance but scaled to +-avoid_turn_radps (at most half the top turn rate)
    w = orca_world([(2.0, 5.0)], seed=11, recovery=RecoverySpec(avoid_turn_radps=turn_radps))
    give(w, [0], [(12.0, 5.0)])
    w.jobs.recover(0, at(w, 30.0))
    u = np.random.default_rng(11).uniform(-0.5, 0.5)
    assert w.fleet.backoff_cmd[0] == pytest.approx(
        [-0.3 * V_MAX, u * min(2.0 * turn_radps, OMEGA_MAX)], rel=1e-12, abs=0.0
    )
    assert w.jobs.fired["backoff"] == 1 and w.fleet.recoveries[0] == 1


def test_robot_fails_after_max_recoveries_tries():
    w = make_world([(2.0, 5.0)], max_recoveries=2)
    f = w.fleet
    give(w, [0], [(12.0, 5.0)], ids=[8])
    f.recoveries[0] = 1
    w.jobs.recover(0, 40.0)
    assert f.recoveries[0] == 2 and f.task[0] == 8  # the second try: still going
    w.jobs.recover(0, 60.0)
    out = done(w)
    assert [(c.task_id, c.t_done_s, c.ok, c.reason) for c in out] == [
        (8, 60.0, False, "stuck: no progress for 20 s after 2 tries")
    ]
    assert f.task[0] == -1 and f.state[0] == IDLE and w.jobs.failures == 1
    assert w.schedule.state_list == [IDLE] and w.schedule.n_steer == 0


def blocked_pair(w: PymunkWorld, gap_m: float, state_b: int, work_end_b: float = 0.0) -> None:
    """Robot 0 drives toward robot 1, whose centre is gap_m away, the nearest in its way."""
    f = w.fleet
    f.blocker[0], f.near_m[0] = 1, gap_m
    f.state[1] = state_b
    f.work_end_s[1] = work_end_b


def test_robot_boxed_in_by_one_nearly_done_with_its_work_waits_for_it():
    w = make_world([(2.0, 5.0), (3.0, 5.0)])
    f = w.fleet
    give(w, [0], [(12.0, 5.0)])
    t = 40.0
    blocked_pair(w, REACH + 0.29, WORKING, t + TIMEOUT)  # done within the stuck timeout
    w.jobs.recover(0, t)
    assert f.t_progress_s[0] == t + TIMEOUT
    assert (f.recoveries[0], f.replan[0], w.schedule.recovering) == (0, False, False)


def test_robot_blocked_by_one_at_long_work_goes_round_it():
    w = make_world([(2.0, 5.0), (3.0, 5.0), (8.0, 9.0)], avoidance="none")  # the proximity law
    f = w.fleet
    give(w, [0], [(12.0, 5.0)])
    t = at(w, 40.0)
    blocked_pair(w, 0.85, WORKING, t + TIMEOUT + 0.5)  # not done within the timeout
    w.motors.bodies[0].angle = 0.0
    w.jobs.recover(0, t)
    assert (f.recoveries[0], f.t_progress_s[0], f.progress_m[0]) == (1, t, np.inf)
    assert f.replan[0] == False  # noqa: E712 (numpy bool)
    path = waypoints(w, 0)
    assert path[0] == 2 + 5j and path[-1] == 12 + 5j
    assert abs(path[1] - (3 + 6j)) < 1e-9  # DETOUR_M to the left of robot 1 (heading +x)


def test_the_way_round_a_standing_robot_passes_it_to_the_side_of_the_heading():
    """Heading 45 degrees (up and right) with robot 1 straight right of it: the detour point
    is DETOUR_M from robot 1 to the left of that heading, up and left of robot 1."""
    w = make_world([(2.0, 5.0), (3.0, 5.0), (8.0, 9.0)], avoidance="none")
    give(w, [0], [(12.0, 5.0)])
    t = at(w, 40.0)
    blocked_pair(w, 0.85, WORKING, t + TIMEOUT + 0.5)
    w.motors.bodies[0].angle = np.pi / 4
    w.jobs.recover(0, t)
    assert abs(waypoints(w, 0)[1] - (3 + 5j + 1j * np.exp(0.25j * np.pi))) < 1e-9


def test_under_avoidance_a_robot_in_a_single_lane_jam_waits_for_the_one_giving_way():
    """Head-on in the gap (no idle robot near, no way round): robot 1 (the higher index)
    is the one to give way, so robot 0's recovery is to wait for it: no try, no back-off."""
    w = orca_world([(4.0, 5.0), (16.0, 5.0), (18.0, 9.0)], obstacles=GAP)
    f = w.fleet
    give(w, [0, 1], [(16.0, 5.0), (4.0, 5.0)])
    f.last_z_m[:2] = [9.65 + 5j, 10.35 + 5j]
    t = at(w, 30.0)
    w.jobs.recover(0, t)
    assert (f.recoveries[0], f.replan[0], f.t_progress_s[0]) == (0, False, t)


def test_assigning_a_task_leaves_the_paths_of_the_other_robots():
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    give(w, [0], [(8.0, 5.0)])
    give(w, [1], [(8.0, 2.0)], ids=[1])
    assert waypoints(w, 0).tolist() == [2 + 5j, 8 + 5j]
    assert waypoints(w, 1).tolist() == [2 + 2j, 8 + 2j]


def test_robot_blocked_by_a_driving_one_backs_off_instead_of_going_round():
    w = make_world([(2.0, 5.0), (3.0, 5.0)], seed=2, avoidance="none")
    f = w.fleet
    give(w, [0], [(12.0, 5.0)])
    blocked_pair(w, 0.9 - 1e-6, DRIVING)
    w.jobs.recover(0, 40.0)
    assert (f.replan[0], f.recoveries[0], w.follower.last[0]) == (True, 1, -1)


def test_a_robot_farther_than_reach_plus_the_trigger_does_not_block():
    w = make_world([(2.0, 5.0), (3.0, 5.0)], seed=2, avoidance="none")
    f = w.fleet
    give(w, [0], [(12.0, 5.0)])
    blocked_pair(w, REACH + 0.3, IDLE)  # exactly reach + YIELD_TRIGGER_M: not blocking
    w.jobs.recover(0, 40.0)
    assert (f.replan[0], w.follower.last[0]) == (True, -1)  # backs off, no detour
    f.replan[0] = False
    blocked_pair(w, REACH + 0.3, WORKING, 40.0 + 1.0)  # nearly done, but not in the way
    w.jobs.recover(0, 41.0)
    assert f.replan[0] == True and f.recoveries[0] == 2  # noqa: E712


def test_recovered_robots_start_their_tries_again():
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    f, sch = w.fleet, w.schedule
    f.recoveries[:] = [2, 1]
    f.stuck_left_m[:] = [3.0, 4.0]
    sch.recovering = True
    w.jobs.recovered([0])
    assert f.recoveries.tolist() == [0, 1]
    assert f.stuck_left_m.tolist() == [np.inf, 4.0]
    assert sch.recovering is True
    w.jobs.recovered([1])
    assert f.recoveries.tolist() == [0, 0] and sch.recovering is False


def test_replan_after_a_back_off_plans_from_where_the_robot_is():
    w = make_world([(2.0, 5.0), (2.0, 2.0)])
    f, sch = w.fleet, w.schedule
    give(w, [0], [(12.0, 5.0)])
    f.replan[0] = True
    w.jobs.refresh()
    sch.site_check_s = 50.0
    assert sch.n_backoff == 1
    w.jobs.replan(0, (4.0, 6.0), 33.0)
    assert waypoints(w, 0).tolist() == [4 + 6j, 12 + 5j]
    assert (f.replan[0], f.progress_m[0], f.t_progress_s[0]) == (False, np.inf, 33.0)
    assert sch.site_check_s == -np.inf and sch.n_backoff == 0


def test_replan_to_a_site_without_a_path_fails_the_task():
    w = make_world([(2.0, 5.0)], obstacles=ROOM)
    f = w.fleet
    give(w, [0], [(8.0, 5.0)], ids=[4])
    f.site[0] = 15 + 5j  # (as if) walled in since
    f.replan[0] = True
    w.jobs.replan(0, (3.0, 4.5), 20.0)
    why = "unreachable: no path from (3.00, 4.50) after a recovery"
    assert [(c.task_id, c.t_done_s, c.ok, c.reason) for c in done(w)] == [(4, 20.0, False, why)]
    assert (f.task[0], f.replan[0]) == (-1, False)
    assert w.schedule.state_list == [IDLE] and w.schedule.n_steer == 0


def test_idle_robot_steps_aside_of_the_driving_robot_that_asked():
    w = make_world([(5.0, 5.0), (5.5, 5.2), (12.0, 8.0)])
    f, sch = w.fleet, w.schedule
    give(w, [0], [(12.0, 5.0)])
    z = np.array([5 + 5j, 5.5 + 5.2j, 12 + 8j])
    h = np.array([1 + 0j, 1j, 1j])
    v = np.array([1.0, 0.0, 0.0])
    f.blocker[:] = [1, -1, -1]
    w.jobs.make_way(np.array([0]), f.blocker, z, h, v, 7.0)
    assert f.yielding.tolist() == [False, True, False]
    assert f.yield_until_s[1] == 7.0 + YIELD_TIMEOUT_S
    assert waypoints(w, 1).tolist() == [5.5 + 5.2j, 5.5 + 6.2j]  # away from robot 0's line
    assert (sch.n_yield, sch.n_steer, sch.steer_list) == (1, 2, [0, 1])


def test_side_step_avoids_robots_near_its_end_and_goes_ahead_along_the_travel():
    """Without collision avoidance an idle robot steps sideways of the asking robot's heading
    (``GridPlanner.side_step``); with it, off its way (``Jobs.step_off``; tests/behaviour)."""
    w = make_world([(5.0, 5.0), (6.0, 5.0), (6.0, 6.0), (6.0, 4.0), (5.0, 2.0)], avoidance="none")
    f = w.fleet
    give(w, [0, 4], [(12.0, 5.0), (12.0, 2.0)])
    z = np.array([5 + 5j, 6 + 5j, 6 + 6j, 6 + 4j, 5 + 2j])  # 2, 3 stand where 1 would step
    h = np.array([1 + 0j, 1j, 1j, 1j, 1 + 0j])
    f.blocker[:] = [1, -1, -1, -1, -1]
    w.jobs.make_way(np.array([0]), f.blocker, z, h, np.array([0.0, 0, 0, 0, 0]), 1.0)
    assert waypoints(w, 1).tolist() == [6 + 5j, 7 + 5j]  # v = 0 counts as forward
    w.jobs.stop_yield(1)
    assert f.yielding[1] == False and w.follower.last[1] == -1  # noqa: E712
    w.jobs.make_way(np.array([0]), f.blocker, z, -h, np.array([-1.0, 0, 0, 0, 0]), 2.0)
    assert waypoints(w, 1).tolist() == [6 + 5j, 7 + 5j]  # reversing along -h: the same way


def test_robot_with_no_free_side_step_stays_and_one_asked_twice_moves_once():
    starts = [(5.0, 5.0), (6.0, 5.0), (6.0, 6.0), (6.0, 4.0), (7.0, 5.0), (7.0, 3.0), (14.0, 8.0)]
    w = make_world([*starts, (15.0, 8.0)], avoidance="none")  # the sideways step
    f = w.fleet
    give(w, [0, 5, 6], [(12.0, 5.0), (12.0, 3.0), (18.0, 8.0)])
    z = np.array([5 + 5j, 6 + 5j, 6 + 6j, 6 + 4j, 7 + 5j, 7 + 3j, 14 + 8j, 15 + 8j])
    h = np.array([1 + 0j, 1j, 1j, 1j, 1j, -1j, 1 + 0j, 1j])
    f.blocker[:] = [1, -1, -1, -1, -1, 3, 7, -1]
    w.jobs.make_way(np.array([0]), f.blocker, z, h, np.ones(8), 1.0)
    assert f.yielding.tolist() == [False] * 8  # left, right and ahead are all taken
    assert w.follower.last[1] == -1 and w.schedule.n_yield == 0
    f.blocker[0] = 3  # robots 0 and 5 both ask robot 3, then robot 6 asks robot 7
    w.jobs.make_way(np.array([0, 5, 6]), f.blocker, z, h, np.ones(8), 1.0)
    assert f.yielding.tolist() == [False, False, False, True, False, False, False, True]
    # robot 0 asked first: robot 3 steps away from its line (down), not from robot 5's
    assert waypoints(w, 3).tolist() == [6 + 4j, 6 + 3j]
    assert waypoints(w, 7).tolist() == [15 + 8j, 15 + 9j]


def test_robot_whose_site_is_taken_by_a_robot_at_work_waits_for_the_first_to_end():
    w = orca_world([(4.0, 5.0), (10.3, 5.0), (10.0, 5.45), (10.5, 5.0), (10.0, 4.7)])
    f = w.fleet
    give(w, [0], [(10.0, 5.0)])
    f.state[1:] = [WORKING, WORKING, WORKING, DRIVING]
    f.work_end_s[1:] = [50.0, 45.0, 30.0, 10.0]  # 3 is just 2 radii away; 4 does not work
    w.jobs.recover(0, 25.0)
    assert f.t_progress_s[0] == 45.0
    assert (f.recoveries[0], f.replan[0]) == (0, False)


def test_without_avoidance_a_taken_site_does_not_make_a_robot_wait():
    w = make_world([(4.0, 5.0), (10.3, 5.0)], seed=1, avoidance="none")
    f = w.fleet
    give(w, [0], [(10.0, 5.0)])
    f.state[1], f.work_end_s[1] = WORKING, 50.0
    w.jobs.recover(0, 25.0)
    assert (f.recoveries[0], f.replan[0], f.t_progress_s[0]) == (1, True, np.inf)


def test_a_stuck_robot_asks_aside_an_idle_robot_that_stands_while_driving_out():
    """Warehouse, QL-MRTA, seed 0 (at b773752): robot 3 finished at a site and drove out
    (``Sites.leave``, yielding) through the service slot robot 9 was sent to; the two stood
    0.60 m apart for 12 s, and robot 9's tries went by (``ask_idle`` passed over robot 3 as
    'stepping aside already') until its task failed. A robot that yields but stands in the
    way is asked again: it steps off the stuck robot's way, and the stuck robot spends a try;
    one that yields and moves is left to go on."""
    w = orca_world([(4.0, 5.0), (6.0, 5.0)])
    f = w.fleet
    give(w, [0], [(8.0, 5.0)])  # robot 0's way runs straight through robot 1
    f.last_z_m[:2] = [5.4 + 5.0j, 6.0 + 5.0j]
    t = at(w, 30.0)
    f.yielding[1], f.yield_until_s[1] = True, t + 10.0  # driving out ...
    f.v_cmd_mps[1] = 0.5  # ... and moving: not asked, nothing changes
    assert not w.jobs.ask_idle(0, t)
    assert f.recoveries[0] == 0 and f.yield_until_s[1] == t + 10.0
    f.v_cmd_mps[1] = 0.05  # ... standing
    f.recoveries[0] = 1  # one try spent before
    assert w.jobs.ask_idle(0, t)
    assert f.recoveries[0] == 2 and f.t_progress_s[0] == t
    assert f.yield_until_s[1] == t + YIELD_TIMEOUT_S
    end = waypoints(w, 1)[-1]
    assert abs(end.imag - 5.0) >= 1.0 - 1e-9  # off the way along y = 5, a step or two aside


def test_a_robot_that_finishes_in_a_narrow_place_pulls_over_when_nobody_comes():
    w = orca_world([(10.0, 5.1), (3.0, 3.0)], obstacles=SHELF)
    f = w.fleet
    give(w, [0], [(10.0, 5.1)])
    f.state[0] = WORKING
    w.jobs.finish(0, at(w, 12.0), True)
    assert f.state[0] == IDLE and f.yielding[0]
    assert abs(waypoints(w, 0)[-1] - (10.0 + 5.6j)) < 1e-9
    off = make_world([(10.0, 5.1), (3.0, 3.0)], obstacles=SHELF, avoidance="none")
    give(off, [0], [(10.0, 5.1)])
    off.fleet.state[0] = WORKING
    off.jobs.finish(0, at(off, 12.0), True)  # without avoidance robots push: no pulling over
    assert not off.fleet.yielding[0]


def test_recover_under_avoidance_goes_round_before_giving_way():
    w = orca_world([(10.0, 5.0), (4.0, 5.0)])
    f = w.fleet
    deadlock(w, [9.9 + 5j, 9 + 5j])
    w.jobs.recover(0, 30.0)  # open floor: a path round robot 1, one try
    assert (f.recoveries[0], f.replan[0], f.t_progress_s[0]) == (1, False, 30.0)
    path = waypoints(w, 0)
    assert path[0] == 9.9 + 5j and path[-1] == 2 + 5j and len(path) > 2
    w.jobs.recover(1, 30.0)  # robot 0 has just gone round: robot 1 waits for it
    assert (f.recoveries[1], f.replan[1], f.t_progress_s[1]) == (0, False, 30.0)
    assert w.schedule.recovering is False


def test_robot_boxed_in_by_robot_0_at_work_waits_for_it_too():
    w = make_world([(3.0, 5.0), (2.0, 5.0)])
    f = w.fleet
    give(w, [1], [(12.0, 5.0)])
    f.state[0], f.work_end_s[0] = WORKING, 45.0
    f.blocker[1], f.near_m[1] = 0, 0.85
    w.jobs.recover(1, 40.0)
    assert (f.t_progress_s[1], f.recoveries[1], f.replan[1]) == (45.0, 0, False)


def test_jobs_built_without_avoidance_never_queue_at_sites_and_track_slots_as_flags():
    w = make_world([(2.0, 5.0), (4.0, 5.0)])
    jobs = Jobs(
        fleet=w.fleet,
        schedule=w.schedule,
        clock=w.clock,
        follower=w.follower,
        planner=w.planner,
        controller=w.controller,
        spatial=w.spatial,
        exec_time_s=w.exec_time_s_,
        reach_m=w.reach_m_,
        bodies=w.motors.bodies,
        rng=np.random.default_rng(0),
        keep_lists=True,
    )
    assert jobs.avoid is False
    assert jobs.sites.slotted.dtype == bool and jobs.sites.slotted.tolist() == [False, False]
    assert (jobs.done, jobs.failures) == ([], 0)


def test_state_arrays_round_trip_between_sets():
    world = make_world([(2.0, 2.0), (5.0, 2.0), (8.0, 2.0)], control="scalar")
    jobs = world.jobs
    jobs.sites.slotted[:] = [False, True, False]
    jobs.jams.origin[:] = [1 + 2j, 3 + 4j, 5 + 6j]
    jobs.failures = 7
    state = jobs.state_arrays()
    assert state["slotted"].tolist() == [False, True, False]
    assert state["origin"].tolist() == [1 + 2j, 3 + 4j, 5 + 6j]
    assert int(state["failures"]) == 7 and state["failures"].dtype == np.int64
    state["slotted"][0] = True  # a copy: the jobs keep theirs
    assert not jobs.sites.slotted[0]
    fresh = make_world([(2.0, 2.0), (5.0, 2.0), (8.0, 2.0)], control="scalar").jobs
    fresh.restore_arrays(state)
    assert fresh.sites.slotted.tolist() == [True, True, False] and fresh.sites.slotted.dtype == bool
    assert (
        fresh.jams.origin.tolist() == [1 + 2j, 3 + 4j, 5 + 6j]
        and fresh.jams.origin.dtype == complex
    )
    assert fresh.failures == 7 and type(fresh.failures) is int
    jobs.done.append(Completion(1, 0, 0.0, 1.0, 1.0))
    with pytest.raises(
        RuntimeError, match=r"^jobs state requested with completions not handed out$"
    ):
        jobs.state_arrays()
    # restored arrays take the jobs' dtypes whatever they come as
    fresh.restore_arrays(
        {
            "slotted": np.array([1, 0, 0]),
            "origin": np.array([1.0, 2.0, 3.0]),
            "failures": np.array(2.0),
        }
    )
    assert fresh.sites.slotted.dtype == bool and fresh.sites.slotted.tolist() == [
        True,
        False,
        False,
    ]
    assert fresh.jams.origin.dtype == complex and fresh.jams.origin.tolist() == [1, 2, 3]
    assert fresh.failures == 2 and type(fresh.failures) is int


@pytest.mark.parametrize("control", ["scalar", "array"])
def test_refresh_lists_follows_the_fleet_state(control):
    world = make_world([(2.0, 2.0), (5.0, 2.0), (8.0, 2.0), (11.0, 2.0)], control=control)
    f, sch = world.fleet, world.schedule
    f.state[:] = [IDLE, DRIVING, WORKING, IDLE]
    f.yielding[:] = [False, False, False, True]
    sch.state_list, sch.steer_list = ["stale"], ["stale"]
    world.jobs.refresh_lists()
    if control == "scalar":  # the scalar control reads the lists
        assert sch.state_list == [IDLE, DRIVING, WORKING, IDLE]
        assert sch.steer_list == [1, 3]
    else:  # the array control keeps none
        assert sch.state_list == ["stale"] and sch.steer_list == ["stale"]


def test_abandon_gives_up_the_task_where_the_robot_stands():
    world = make_world([(2.0, 2.0), (5.0, 2.0)])
    at(world, 12.5)
    give(world, [0, 1], [(10.0, 2.0), (12.0, 8.0)], ids=[41, 42], bids=[3.5, 4.5])
    f = world.fleet
    f.stuck_left_m[1], f.replan[1], f.backoff_until_s[1] = 4.0, True, 30.0
    f.t_progress_s[1], f.yielding[1] = 13.0, True
    world.jobs.blocked[1] = True  # it was waiting for a repair
    world.jobs.sites.admitted[:2] = True
    t = at(world, 20.0)
    out = world.jobs.abandon(1, t)
    assert world.jobs.blocked.tolist()[:2] == [False, False]
    assert world.jobs.sites.admitted[:2].tolist() == [True, False]  # only its place went
    assert (out.task_id, out.robot, out.t_alloc_s, out.t_s, out.bid) == (42, 1, 12.5, t, 4.5)
    assert type(out.t_alloc_s) is float and type(out.bid) is float
    assert (f.task[1], f.state[1]) == (-1, IDLE)
    assert f.stuck_left_m[1] == np.inf and not f.replan[1] and f.backoff_until_s[1] == -np.inf
    assert f.t_progress_s[1] == np.inf and not f.yielding[1]
    assert world.follower.last[1] == -1 and len(waypoints(world, 0)) > 1  # only its path went
    assert world.schedule.n_steer == 1 and world.schedule.n_yield == 0  # refreshed
    assert (f.task[0], f.state[0]) == (41, DRIVING)


def step(starts, k: int, way=None, heading: float = 0.0, obstacles=()):
    """Where idle robot k steps to, off the way of robot 0 (at starts[0], along ``way`` (x + iy
    points from it), or with no path, facing ``heading``); None if nowhere."""
    w = orca_world(starts, obstacles=obstacles)
    if way is not None:
        set_way(w, 0, way)
    w.motors.bodies[0].angle = heading
    path = w.jobs.step_off(k, 0, w.fleet.last_z_m)
    assert path.shape[1:] == (2,)
    return complex(*path[-1]) if len(path) else None


def test_it_steps_to_the_side_of_the_way_away_from_the_stuck_robot():
    """Robot 0's way runs along +x from (8, 5) (it faces +y, which is not looked at): robot
    1 on the line or left of it steps left (+y), right of it steps right."""
    way = [8 + 5j, 14 + 5j]
    assert step([(8.0, 5.0), (9.0, 5.0)], 1, way, heading=np.pi / 2) == 9 + 6j
    assert step([(8.0, 5.0), (9.0, 4.7)], 1, way, heading=np.pi / 2) == 9 + 3.7j


def test_without_a_path_the_heading_is_the_way():
    """Robot 0 has no path and faces +y: robot 1, up and right of it, steps right."""
    assert step([(8.0, 5.0), (8.3, 6.0)], 1, heading=np.pi / 2) == pytest.approx(9.3 + 6j)


def test_the_way_is_the_first_waypoint_however_near():
    """Robot 0 is 0.5 m short of a corner of its way; it drives +x now: robot 1, below that
    line, steps down."""
    way = [8 + 5j, 8.5 + 5j, 8.5 + 9j]
    assert step([(8.0, 5.0), (9.0, 4.6)], 1, way) == pytest.approx(9 + 3.6j)


def test_an_end_near_another_robot_is_passed_over_for_the_other_side():
    way = [8 + 5j, 14 + 5j]
    assert step([(8.0, 5.0), (9.0, 5.0), (9.2, 6.2)], 1, way) == 9 + 4j


@pytest.mark.parametrize(("corner_x", "want"), [(9.5, 9 + 4.2j), (9.7, 9 + 6.2j)])
def test_an_end_closer_than_two_radii_and_lane_gap_to_the_rest_of_the_way_is_passed_over(
    corner_x, want
):
    """Robot 0's way turns up at x = 9.5 (0.5 m from robot 1's first end: passed over, it
    steps down) or at x = 9.7 (0.7 m: taken)."""
    way = [8 + 5j, corner_x + 5j, corner_x + 7j]
    assert step([(8.0, 5.0), (9.0, 5.2)], 1, way) == want


def test_with_both_one_metre_ends_taken_it_steps_two_metres():
    way = [8 + 5j, 14 + 5j]
    starts = [(8.0, 5.0), (9.0, 5.0), (9.2, 6.1), (9.2, 3.9)]
    assert step(starts, 1, way) == 9 + 7j


def test_a_robot_right_against_the_stuck_one_has_no_step_that_keeps_clear_of_it():
    """Robot 1 stands 0.45 m ahead of robot 0: every way off passes closer than two radii."""
    assert step([(8.0, 5.0), (8.45, 5.0)], 1, [8 + 5j, 14 + 5j]) is None


def test_in_an_aisle_idle_robots_at_both_walls_step_along_them_out_of_the_way():
    """The warehouse jam (market, seed 12), 10 m lower: robot 0 in the 2 m aisle (y 4..6)
    drives up-left past robot 2, pulled over to the top wall, and then left along the aisle;
    robot 1, pulled over to the bottom wall, stands half a metre from it, ahead. No step to
    either side of robot 0's way or along it is free for either robot (a wall, the other
    robot, or the way itself). Robot 1 steps 1 m at 45 degrees off the way on its own side
    (the way leaves at 134.5 degrees: almost straight left, along its wall). Robot 2, on the
    other side of the way, finds 45 degrees on its side (up) in the wall and 45 degrees on the
    other (left) on the way: it steps at 135 degrees on its side, right along the top wall."""
    starts = [(13.36, 4.93), (12.9, 4.56), (13.28, 5.53)]
    way = [13.36 + 4.93j, 12.75 + 5.55j, 6 + 5j]
    travel = (way[1] - way[0]) / abs(way[1] - way[0])
    turn = np.exp(0.25j * np.pi)
    assert abs(travel * turn + 1) < 0.01 and abs(-travel * turn - 1) < 0.01
    want1, want2 = 12.9 + 4.56j + travel * turn, 13.28 + 5.53j - travel * turn
    assert step(starts, 1, way, obstacles=AISLE) == pytest.approx(want1, abs=1e-9)
    assert step(starts, 2, way, obstacles=AISLE) == pytest.approx(want2, abs=1e-9)


def test_with_the_sides_and_the_way_closed_it_steps_straight_back():
    """Robot 0 stands at (8, 5) in the 2 m aisle, its way +x along the middle; idle robot 1
    stands 1.2 m behind it on the same line. Both sides and all four diagonals end in a wall
    (the planner keeps a radius and its clearance from them), straight on ends against robot
    0 or on its way: it steps 1 m straight back."""
    starts = [(8.0, 5.0), (6.8, 5.0)]
    assert step(starts, 1, [8 + 5j, 14 + 5j], obstacles=AISLE) == 5.8 + 5j


@pytest.mark.parametrize(("lane_gap", "want"), [(0.1, 4 + 5.75j), (0.0, None)])
def test_the_way_off_does_not_pass_closer_to_the_stuck_robot_than_the_lane(lane_gap, want):
    """Robot 1 stands 0.75 m left of robot 0's way along +x (robot 0 at (5, 5)); robots stand
    on its ends 1 and 2 m straight up and ahead, and 1 m at 45 degrees up either way (straight
    down runs through robot 0, 45 degrees down-right ends on the way). The first free end is
    1 m down-left, 0.71 m off the way, but the straight way there passes robot 0 at 0.53 m:
    with ``lane_gap_m`` 0.1 the way must keep 0.55 m (two radii and the gap, less half the
    gap), so it steps straight back, 1 m left. With no gap two radii are enough and it takes
    the diagonal (warehouse_wide, QL-MRTA, seed 25: an idle robot stepped past a stuck one
    at 0.52 m, and neither moved until the task failed)."""
    r2 = np.sqrt(0.5)
    blocks = [(5.0, 6.75), (6.0, 5.75), (5.0, 7.75), (7.0, 5.75), (5 + r2, 5.75 + r2)]
    starts = [(5.0, 5.0), (5.0, 5.75), *blocks, (5 - r2, 5.75 + r2)]
    w = orca_world(starts, jams=JamSpec(lane_gap_m=lane_gap))
    set_way(w, 0, [5 + 5j, 10 + 5j])
    path = w.jobs.step_off(1, 0, w.fleet.last_z_m) @ np.array([1.0, 1j])
    diagonal = 5 + 5.75j + np.exp(-0.75j * np.pi)
    passing = _to_polyline(np.array([5 + 5j]), np.array([5 + 5.75j, diagonal]))[0]
    assert passing == pytest.approx(0.75 * r2, abs=1e-12)  # 0.53 m
    assert path[-1] == pytest.approx(diagonal if want is None else want, abs=1e-9)


def test_a_stuck_robot_asks_the_nearest_idle_robot_that_has_a_step():
    """Robot 1 stands right against stuck robot 0 (every way off passes within two radii):
    it has no step. Robot 2, farther but within 1.2 m, has one: it steps aside, and robot 0
    spends a try waiting for it; robot 1 is left as it was."""
    w = orca_world([(8.0, 5.0), (8.45, 5.0), (8.9, 5.7)])
    f = w.fleet
    set_way(w, 0, [8 + 5j, 14 + 5j])
    t = at(w, 30.0)
    assert not len(w.jobs.step_off(1, 0, f.last_z_m))
    assert w.jobs.ask_idle(0, t)
    assert f.yielding.tolist() == [False, False, True]
    assert waypoints(w, 2)[-1] == 8.9 + 6.7j  # 1 m to its side of the way
    assert f.recoveries[0] == 1 and f.t_progress_s[0] == t
    assert w.jobs.fired["ask_idle"] == 1


def test_to_polyline_measures_to_the_nearest_point_of_each_segment():
    p = np.array([0.25 - 0.3j, 1.0 + 0.25j, -1.0 + 0j])
    way = np.array([0j, 0.5 + 0j, 0.5 + 0.5j])  # two legs of 0.5 m
    assert _to_polyline(p, way) == pytest.approx([0.3, 0.5, 1.0])
    two = np.array([0j, 4 + 0j])
    assert _to_polyline(np.array([2 + 1j, 5 + 0j]), two).tolist() == [1.0, 1.0]
    assert _to_polyline(np.array([4 + 5j]), np.array([1 + 1j])).tolist() == [5.0]
    empty = _to_polyline(np.array([1 + 1j, 2j]), np.zeros(0, dtype=complex))
    assert empty.dtype == float and empty.tolist() == [np.inf, np.inf]


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


def test_distance_to_a_polyline():
    from sim.spatial.jobs import _to_polyline

    way = np.array([0.0, 4.0, 4.0 + 3.0j])
    got = _to_polyline(np.array([2.0 + 1.0j, 5.0 + 1.0j, -3.0 + 4.0j, 4.0 + 5.0j]), way)
    assert np.allclose(got, [1.0, 1.0, 5.0, 2.0])
    assert np.allclose(_to_polyline(np.array([3.0 + 4.0j]), np.array([0.0])), [5.0])
