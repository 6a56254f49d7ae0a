"""Task bookkeeping of the pymunk world (``sim.spatial.jobs.Jobs``), driven directly.

Each test builds a small world for its collaborators (fleet state, schedule, clock, follower,
planner), sets the fleet state by hand and calls one event handler of ``world.jobs`` the way a
control period would; then it checks every number the handler writes. Distances are exact: with
no obstacle in the way a planned path is the straight segment, so its length is the distance.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.scenario import (
    DriveSpec,
    JamSpec,
    MakeWaySpec,
    QueueSpec,
    RecoverySpec,
    RobotSpec,
    Scenario,
    SpatialSpec,
)
from sim.spatial.jobs import Jobs
from sim.spatial.world import PymunkWorld
from sim.states import DRIVING, IDLE, WORKING
from sim.tasks import Batch
from sim.world import Completion

# the settings' defaults (sim.scenario), under the names these tests use
DEADLOCK_M = JamSpec().deadlock_m
BACKOFF_S = RecoverySpec().backoff_s
SLOT_GAP_M = QueueSpec().slot_gap_m
YIELD_TIMEOUT_S = MakeWaySpec().timeout_s
PASS_S = JamSpec().pass_s


EXEC_S = (2.0, 5.0)  # execution time of task types 0 and 1, s
V_MAX = 1.5  # m/s, the default drive's top speed
OMEGA_MAX = 7.5  # rad/s, its top turn rate: rim speed / half the wheel base
TIMEOUT = 20.0  # s, the default stuck timeout
REACH = 0.6  # m, centres closer than two radii (0.25 m) + 0.1 m touch
ROOM = [  # a closed box round (15, 5): a site inside it has no path from outside
    ((13.0, 3.0), (17.0, 3.0), (17.0, 3.4), (13.0, 3.4)),
    ((13.0, 6.6), (17.0, 6.6), (17.0, 7.0), (13.0, 7.0)),
    ((13.0, 3.4), (13.4, 3.4), (13.4, 6.6), (13.0, 6.6)),
    ((16.6, 3.4), (17.0, 3.4), (17.0, 6.6), (16.6, 6.6)),
]


def make_world(
    starts, obstacles=(), control="scalar", seed=0, drive=None, **spatial
) -> PymunkWorld:
    """A 20 m x 10 m world with two task types (2 s and 5 s of work) every robot can do
    (``drive``: the default ``DriveSpec`` unless given)."""
    sites = (tuple(starts), tuple(starts))
    drive = DriveSpec() if drive is None else drive
    sp = SpatialSpec(20.0, 10.0, tuple(obstacles), sites, drive, **spatial)
    robots = tuple(RobotSpec(f"R{j + 1}", (0, 1), tuple(xy)) for j, xy in enumerate(starts))
    scn = Scenario("t", ("A", "B"), robots, ((1.0, 1.0),) * len(robots), EXEC_S, spatial=sp)
    world = PymunkWorld(scn, control=control, check_layout=False)  # sites where robots start
    world.reset(np.random.default_rng(seed))
    return world


def at(world: PymunkWorld, t_s: float) -> float:
    """Set the world's clock to t_s (a whole number of physics steps) and return it."""
    world.clock.steps = round(t_s / world.dt_s)
    return world.clock.time_s


def batch(ids, types, sites) -> Batch:
    k = len(ids)
    return Batch(0, 0, np.asarray(ids), np.asarray(types), np.zeros(k, bool), np.asarray(sites))


def give(world: PymunkWorld, robots, sites, types=None, ids=None, bids=None, xy=None) -> None:
    """Assign task k (id ids[k], type types[k], site sites[k]) to robot robots[k]."""
    k = len(robots)
    ids = list(range(k)) if ids is None else ids
    types = [0] * k if types is None else types
    bids = np.ones(k) if bids is None else np.asarray(bids, float)
    xy = world.poses()[0] if xy is None else np.asarray(xy, float)
    jobs = world.jobs
    jobs.assign(batch(ids, types, sites), np.asarray(robots), bids, np.arange(k), xy)


def waypoints(world: PymunkWorld, j: int) -> np.ndarray:
    """Robot j's planned path as complex points (empty: it has none)."""
    fol = world.follower
    return fol.points[j, : fol.last[j] + 1]


def done(world: PymunkWorld) -> list[Completion]:
    out, world.jobs.done = world.jobs.done, []
    return out


# ---- assign ------------------------------------------------------------------------------


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


# ---- busy_until_s, refresh ---------------------------------------------------------------


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


# ---- start_work, end_due, finish_work, finish --------------------------------------------


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


# ---- check_stuck, recover, recovered, replan ---------------------------------------------


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
    w = make_world([(2.0, 5.0), (2.0, 2.0)], seed=11)
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


# ---- make_way, stop_yield ----------------------------------------------------------------


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
    (``GridPlanner.side_step``); with it, off its way (``Jobs.step_off``, test_orca.py)."""
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


# ---- under collision avoidance: site taken, give_way, take_slots, step_clear -------------


def orca_world(starts, **kw) -> PymunkWorld:
    w = make_world(starts, avoidance="orca", **kw)
    assert w.jobs.avoid is True
    return w


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


def deadlock(w: PymunkWorld, z) -> None:
    """Robots 0 and 1 drive toward each other (given their tasks at their starts), now at z."""
    give(w, [0, 1], [(2.0, 5.0), (14.0, 5.0)])
    w.fleet.last_z_m[:2] = z


def test_of_two_deadlocked_robots_the_higher_index_backs_out_past_its_start():
    w = orca_world([(10.0, 5.0), (4.0, 5.0)])
    f = w.fleet
    deadlock(w, [9.9 + 5j, 9 + 5j])
    t = at(w, 30.0)
    assert w.jobs.jams.give_way(0, t) is True  # robot 1 gives way: robot 0 waits
    assert (f.t_progress_s[0], f.recoveries[0], w.follower.last[0]) == (t, 0, 1)
    w.schedule.resting = True
    assert w.jobs.jams.give_way(1, t) is True
    assert f.recoveries.tolist() == [0, 1]
    assert waypoints(w, 1).tolist() == [9 + 5j, 2.5 + 5j, 14 + 5j]  # 1.5 m past (4, 5)
    assert (f.progress_m[1], f.t_progress_s[1]) == (np.inf, t)
    assert w.schedule.resting is False


def test_deadlock_needs_a_driving_robot_closer_than_the_deadlock_distance():
    w = orca_world([(10.0, 5.0), (4.0, 5.0), (7.6, 6.0)])
    f = w.fleet
    deadlock(w, [10.5 + 5j, 9 + 5j])  # exactly DEADLOCK_M apart
    f.last_z_m[2] = 9 + 5.5j  # close, but standing
    assert w.jobs.jams.give_way(1, 30.0) is False
    assert w.jobs.jams.give_way(0, 30.0) is False
    assert f.recoveries.tolist() == [0, 0, 0] and f.t_progress_s[:2].tolist() == [0.0, 0.0]


def test_refuge_off_the_free_space_falls_back_to_the_start():
    w = orca_world([(10.0, 5.0), (1.0, 5.0)])
    f = w.fleet
    deadlock(w, [9.9 + 5j, 9 + 5j])
    assert w.jobs.jams.give_way(1, 30.0) is True
    assert waypoints(w, 1).tolist() == [9 + 5j, 1 + 5j, 14 + 5j]  # x = -0.5 is off the arena
    assert f.recoveries[1] == 1


def test_no_give_way_while_at_the_refuge_already_or_without_a_way_on():
    w = orca_world([(10.0, 5.0), (1.0, 5.0)])
    f = w.fleet
    deadlock(w, [2.2 + 5j, 1.5 + 5j])  # 0.5 m from its start, which is its refuge
    assert w.jobs.jams.give_way(1, 30.0) is False
    f.last_z_m[:2] = [1.7 + 5j, 1.0 + 5j]  # at its start: no direction to back out in
    assert w.jobs.jams.give_way(1, 30.0) is False
    assert f.recoveries[1] == 0 and w.follower.last[1] == 1


def test_no_give_way_without_a_path_on_to_the_site():
    w = orca_world([(10.0, 5.0), (4.0, 5.0)], obstacles=ROOM)
    f = w.fleet
    deadlock(w, [9.9 + 5j, 9 + 5j])
    f.site[1] = 15 + 5j  # walled in
    assert w.jobs.jams.give_way(1, 30.0) is False
    assert f.recoveries[1] == 0


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


SHELF = [((8.0, 6.0), (12.0, 6.0), (12.0, 7.0), (8.0, 7.0))]  # a shelf face along y = 6


def test_an_idle_robot_in_a_narrow_place_pulls_over_to_the_nearest_obstacle():
    """Body 0.65 m from the shelf face (< PULL_ROOM_M): it drives toward it and stops with
    PULL_GAP_M of air (centre at 6 - 0.25 - 0.15 = 5.6 m), yielding meanwhile; one in the
    open and one whose end point another robot stands near stay."""
    w = orca_world([(10.0, 5.1), (3.0, 3.0)], obstacles=SHELF)
    f = w.fleet
    t = at(w, 10.0)
    assert w.jobs.sites.pull_over(0, t)
    assert abs(waypoints(w, 0)[-1] - (10.0 + 5.6j)) < 1e-9
    assert f.yielding[0] and f.yield_until_s[0] == t + YIELD_TIMEOUT_S
    assert not w.jobs.sites.pull_over(1, t) and not f.yielding[1]
    w2 = orca_world([(10.0, 5.1), (10.6, 5.6)], obstacles=SHELF)
    assert not w2.jobs.sites.pull_over(0, t) and w2.follower.last[0] == -1


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


SLOT_RING = 2 * 0.25 + 0.35  # m, radius of the ring of the 4 service slots


def slot(site: complex, k: int) -> complex:
    return site + SLOT_RING * np.exp(2j * np.pi * k / 4)


def service(w: PymunkWorld, z_newcomer: complex, on_site_state: int = WORKING) -> None:
    """Robot 1 stands on the service point (10, 5); robot 0 drives there, now at z_newcomer."""
    f = w.fleet
    give(w, [0], [(10.0, 5.0)])
    f.state[1] = on_site_state
    f.last_z_m[:2] = [z_newcomer, 10 + 5j]


def test_newcomer_takes_the_nearest_free_service_slot_beside_a_robot_at_work():
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    f, jobs = w.fleet, w.jobs
    service(w, 8.5 + 5.2j)
    w.schedule.resting = True
    t = at(w, 12.0)
    jobs.sites.take_slots([0], f.last_z_m, t)
    k3 = slot(10 + 5j, 2)
    assert abs(k3 - (9.15 + 5j)) < 1e-12
    assert f.site[0] == k3
    assert jobs.sites.slotted.tolist() == [True, False]
    assert waypoints(w, 0).tolist() == [8.5 + 5.2j, k3]
    assert (f.progress_m[0], f.t_progress_s[0]) == (np.inf, t)
    assert w.schedule.resting is False
    w.schedule.resting = True
    jobs.sites.take_slots([0], f.last_z_m, t)  # a slot already: nothing changes
    assert f.site[0] == k3 and w.schedule.resting is True


def test_a_robot_waiting_for_a_repair_that_gets_a_slot_waits_no_more():
    """Robot 0 waits near its site for a repair (``Jobs.wait_for_repair``: broken robots
    close its way) while robot 1 works on the service point: given a free slot it drives
    there, and is no longer waiting."""
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    f, jobs = w.fleet, w.jobs
    service(w, 8.5 + 5.2j)
    jobs.blocked[0] = True
    jobs.sites.take_slots([0], f.last_z_m, at(w, 12.0))
    assert f.site[0] == slot(10 + 5j, 2) and jobs.sites.slotted[0]
    assert jobs.blocked.tolist() == [False, False]


def test_slots_in_an_obstacle_near_a_standing_robot_or_another_robots_goal_are_not_taken():
    post = [((8.7, 4.8), (9.1, 4.8), (9.1, 5.2), (8.7, 5.2))]  # grown by 0.35 m: covers slot 2
    w = orca_world([(4.0, 5.6), (10.0, 5.0), (12.0, 8.0), (14.0, 8.0)], obstacles=post)
    f = w.fleet
    site = 10 + 5j
    service(w, 8.5 + 5.6j)
    f.last_z_m[3] = slot(site, 1) + 0.674j  # just too close to slot 1
    give(w, [2], [(12.0, 2.0)])
    f.site[2] = slot(site, 3)  # robot 2 drives to slot 3
    w.jobs.sites.take_slots([0], f.last_z_m, 5.0)
    assert f.site[0] == slot(site, 0)  # nearest to (8.5, 5.6): 2, 1, 3, then 0
    assert waypoints(w, 0)[-1] == slot(site, 0)


def test_with_no_free_slot_the_newcomer_waits_where_it_is():
    ring = [slot(10 + 5j, k) for k in range(4)]
    starts = [(4.0, 5.0), (10.0, 5.0)] + [(p.real, p.imag) for p in ring]
    w = orca_world(starts)
    f = w.fleet
    service(w, 8.5 + 5.2j)
    f.last_z_m[2:] = ring
    w.schedule.resting = True
    w.jobs.sites.take_slots([0], f.last_z_m, 5.0)
    assert f.site[0] == 10 + 5j and w.jobs.sites.slotted[0] == False  # noqa: E712
    assert waypoints(w, 0).tolist() == [4 + 5j, 10 + 5j]
    assert w.schedule.resting is True


def test_newcomer_keeps_its_site_while_the_service_point_is_free():
    w = orca_world([(4.0, 1.0), (10.0, 1.675), (10.0, 0.6)])
    f = w.fleet
    give(w, [0, 2], [(10.0, 1.0), (16.0, 0.6)])
    f.state[1] = WORKING  # 2 radii + SLOT_GAP_M / 2 from the site: not on it
    f.last_z_m[:3] = [8.5 + 1j, 10 + 1.675j, 10 + 0.6j]  # robot 2 drives: not standing
    assert abs(f.last_z_m[1] - f.site[0]) == 2 * 0.25 + 0.5 * 0.35
    w.schedule.resting = True
    w.jobs.sites.take_slots([0], f.last_z_m, 5.0)
    assert f.site[0] == 10 + 1j and w.jobs.sites.slotted[0] == False  # noqa: E712
    assert w.schedule.resting is True


def test_idle_robot_on_the_service_point_steps_clear_of_the_newcomer():
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    f = w.fleet
    service(w, 8.5 + 5.0j, on_site_state=IDLE)
    w.motors.bodies[1].angle = np.pi / 2  # it faces +y: steps to its left, -x
    t = at(w, 6.0)
    w.jobs.sites.take_slots([0], f.last_z_m, t)
    assert f.yielding.tolist() == [False, True]
    assert f.yield_until_s[1] == t + YIELD_TIMEOUT_S
    path = waypoints(w, 1)
    assert path[0] == 10 + 5j and abs(path[1] - (9 + 5j)) < 1e-12
    assert f.site[0] == 10 + 5j and w.jobs.sites.slotted[0] == False  # noqa: E712
    assert (w.schedule.n_yield, w.schedule.steer_list) == (1, [0, 1])


def test_step_clear_takes_the_free_side_and_a_robot_with_none_stays():
    w = orca_world([(10.0, 5.0), (10.0, 6.0), (14.0, 5.0), (14.0, 6.0), (14.0, 4.0), (15.0, 5.0)])
    f = w.fleet
    for b in w.motors.bodies:
        b.angle = 0.0
    w.jobs.sites.step_clear([0, 2], 3.0)  # robot 1 stands on 0's left; 3, 4, 5 round robot 2
    assert f.yielding.tolist() == [True, False, False, False, False, False]
    assert f.yield_until_s[0] == 3.0 + YIELD_TIMEOUT_S
    assert waypoints(w, 0).tolist() == [10 + 5j, 10 + 4j]
    assert w.follower.last[2] == -1


def test_robot_boxed_in_by_robot_0_at_work_waits_for_it_too():
    w = make_world([(3.0, 5.0), (2.0, 5.0)])
    f = w.fleet
    give(w, [1], [(12.0, 5.0)])
    f.state[0], f.work_end_s[0] = WORKING, 45.0
    f.blocker[1], f.near_m[1] = 0, 0.85
    w.jobs.recover(1, 40.0)
    assert (f.t_progress_s[1], f.recoveries[1], f.replan[1]) == (45.0, 0, False)


def test_a_robot_near_its_start_backs_out_the_full_deadlock_distance_past_it():
    w = orca_world([(10.0, 5.0), (4.0, 5.0)])
    deadlock(w, [5.5 + 5j, 4.5 + 5j])  # half a metre from where it was given its task
    assert w.jobs.jams.give_way(1, 30.0) is True
    assert waypoints(w, 1).tolist() == [4.5 + 5j, 2.5 + 5j, 14 + 5j]


def test_giving_way_counts_a_try_and_needs_half_the_deadlock_distance_to_the_refuge():
    w = orca_world([(10.0, 5.0), (1.0, 5.0)])
    f = w.fleet
    deadlock(w, [3.0 + 5j, 1.75 + 5j])  # refuge: its start (1, 5), 0.75 m back
    f.recoveries[1] = 1
    assert w.jobs.jams.give_way(1, 30.0) is True
    assert f.recoveries[1] == 2
    assert waypoints(w, 1).tolist() == [1.75 + 5j, 1 + 5j, 14 + 5j]
    f.last_z_m[:2] = [3.2 + 5j, 2.0 + 5j]  # 1 m back
    assert w.jobs.jams.give_way(1, 31.0) is True
    assert f.recoveries[1] == 3


def test_a_robot_that_used_its_tries_giving_way_passes_the_choice_to_the_other():
    w = orca_world([(10.0, 5.0), (4.0, 5.0)])
    f = w.fleet
    deadlock(w, [9.9 + 5j, 9 + 5j])
    assert w.spatial.max_recoveries == 3
    f.recoveries[1] = 3  # chosen three times and never got out: not chosen again
    assert w.jobs.jams.give_way(1, 30.0) is True  # robot 1 waits for robot 0
    assert (f.recoveries[1], f.t_progress_s[1], w.follower.last[1]) == (3, 30.0, 1)
    assert w.jobs.jams.give_way(0, 30.0) is True  # robot 0 backs out past its start
    assert f.recoveries.tolist()[:2] == [1, 3]
    assert waypoints(w, 0).tolist() == [9.9 + 5j, 11.5 + 5j, 2 + 5j]
    f.recoveries[0] = 3  # both used up: the higher index is chosen, and gives up
    assert w.jobs.jams.give_way(0, 31.0) is True
    assert w.jobs.jams.give_way(1, 31.0) is False
    assert f.recoveries.tolist()[:2] == [3, 3]


def test_the_way_back_is_the_planned_path_not_the_straight_line():
    # robot 1 came up a 1 m gap (x 9.5-10.5, y 6-9) from (4, 2) and stands deep in it; robot
    # 0 came from (14, 5) and stands at its east side, lower down: beside the straight line
    # back from robot 1 toward (4, 2), but on the way out of the gap that robot 1 would drive
    wall = [
        [[0.0, 6.0], [9.5, 6.0], [9.5, 9.0], [0.0, 9.0]],
        [[10.5, 6.0], [20.0, 6.0], [20.0, 9.0], [10.5, 9.0]],
    ]
    w = orca_world([(14.0, 5.0), (4.0, 2.0)], obstacles=wall)
    f = w.fleet
    give(w, [0, 1], [(10.0, 12.0), (10.0, 12.0)])
    f.last_z_m[:2] = [10.25 + 7.6j, 9.75 + 8.0j]
    back = w.jobs.jams.origin[1] - f.last_z_m[1]
    rel = (f.last_z_m[0] - f.last_z_m[1]) * (back / abs(back)).conjugate()
    assert rel.real < 0.0  # robot 0 is not behind robot 1 on the straight line ...
    assert w.jobs.jams.backed_in(1) is True  # ... but it is on robot 1's way out of the gap
    assert w.jobs.jams.backed_in(0) is False
    assert w.jobs.jams.give_way(1, 30.0) is True  # robot 1 has the higher index, but waits
    assert (f.recoveries.tolist()[:2], f.t_progress_s[1]) == ([0, 0], 30.0)
    assert w.jobs.jams.give_way(0, 30.0) is True  # robot 0 backs out toward (14, 5)
    assert f.recoveries.tolist()[:2] == [1, 0]
    assert waypoints(w, 0)[0] == 10.25 + 7.6j and waypoints(w, 0)[-1] == 10 + 12j


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(4.0, 16.0), st.floats(3.0, 7.0)), min_size=2, max_size=5).filter(
        lambda pts: len({(round(x, 3), round(y, 3)) for x, y in pts}) == len(pts)
    ),
    st.data(),
)
def test_on_open_floor_the_way_back_is_the_straight_line(starts, data):
    # no obstacle: the planned way back is the straight line to the refuge, and a robot is in
    # it exactly when, in that line's frame, it is more than a radius and less than
    # DEADLOCK_M along and less than two radii + SLOT_GAP_M to the side (brute force)
    w = orca_world(starts)
    f = w.fleet
    m = len(starts)
    give(w, list(range(m)), [(10.0, 5.0)] * m)
    moved = [complex(*p) for p in data.draw(st.permutations(starts))]
    f.last_z_m[:m] = moved
    r = w.controller.radius_m
    for j in range(m):
        back = w.jobs.jams.refuge(j) - moved[j]
        if abs(back) < 1e-6:
            continue
        unit = back / abs(back)
        want = False
        for k in range(m):
            if k != j:
                rel = (moved[k] - moved[j]) * unit.conjugate()
                along_ok = r + 1e-9 < rel.real < DEADLOCK_M - 1e-9
                side = abs(rel.imag)
                if abs(rel.real - r) < 1e-6 or abs(rel.real - DEADLOCK_M) < 1e-6:
                    want = None  # on an edge: rounding decides
                    break
                if abs(side - (2 * r + SLOT_GAP_M)) < 1e-6:
                    want = None
                    break
                want = want or (along_ok and side < 2 * r + SLOT_GAP_M)
        if want is not None:
            assert w.jobs.jams.backed_in(j) is bool(want)


def test_an_idle_robot_on_the_point_steps_clear_even_beside_one_at_work_at_the_slot_ring():
    # the service point (10, 1); robot 2 works exactly 2 radii + SLOT_GAP_M / 2 from it
    w = orca_world([(6.0, 1.0), (10.0, 1.0), (10.0, 1.675)])
    f = w.fleet
    give(w, [0], [(10.0, 1.0)])
    f.state[1:] = [IDLE, WORKING]
    f.last_z_m[:] = [8.8 + 1j, 10 + 1j, 10 + 1.675j]
    assert abs(f.last_z_m[2] - f.site[0]) == 2 * 0.25 + 0.5 * 0.35
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.yielding.tolist() == [False, True, False]  # the idle one steps clear
    assert f.site[0] == 10 + 1j and w.jobs.sites.slotted[0] == False  # noqa: E712


def test_every_newcomer_in_one_call_is_answered():
    # robots 0, 1, 2 come for (4, 8), (10, 8), (16, 8): idle 3, idle 4 and working 5 stand there
    starts = [(4.0, 2.0), (10.0, 2.0), (16.0, 2.0), (4.0, 8.0), (10.0, 8.0), (16.0, 8.0)]
    w = orca_world(starts)
    f = w.fleet
    give(w, [0, 1, 2], starts[3:])
    f.state[5] = WORKING
    f.last_z_m[:3] = [4 + 7j, 10 + 7j, 15.8 + 7j]
    w.jobs.sites.take_slots([0, 1, 2], f.last_z_m, 4.0)
    assert f.yielding.tolist() == [False, False, False, True, True, False]
    assert w.jobs.sites.slotted.tolist() == [False, False, True, False, False, False]
    assert f.site[2] == slot(16 + 8j, 3)


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


def test_a_newcomer_without_a_free_slot_or_a_path_to_one_does_not_stop_the_next():
    pocket = [  # a 0.8 m square hole round (4, 5): its service point fits a robot, no slot does
        ((3.0, 3.0), (5.0, 3.0), (5.0, 4.6), (3.0, 4.6)),
        ((3.0, 5.4), (5.0, 5.4), (5.0, 7.0), (3.0, 7.0)),
        ((3.0, 4.6), (3.6, 4.6), (3.6, 5.4), (3.0, 5.4)),
        ((4.4, 4.6), (5.0, 4.6), (5.0, 5.4), (4.4, 5.4)),
    ]
    starts = [(2.0, 8.0), (15.0, 5.0), (15.8, 1.0), (4.0, 5.0), (10.0, 2.0), (16.0, 2.0)]
    w = orca_world(starts, obstacles=pocket + ROOM)
    f = w.fleet
    f.site[:3] = [4 + 5j, 10 + 2j, 16 + 2j]  # robots 0, 1, 2 come for the points of 3, 4, 5
    f.state[:3] = DRIVING
    f.task[:3] = [0, 1, 2]
    f.state[3:] = WORKING
    f.last_z_m[:] = [2 + 8j, 15 + 5j, 15.8 + 1j, 4 + 5j, 10 + 2j, 16 + 2j]  # 1 is walled in
    w.jobs.sites.take_slots([0, 1, 2], f.last_z_m, 4.0)
    assert w.jobs.sites.slotted.tolist() == [False, False, True, False, False, False]
    assert f.site[2] == slot(16 + 2j, 3)  # the nearest slot to (15.8, 1) ...
    assert f.site[:2].tolist() == [4 + 5j, 10 + 2j]  # ... the others keep their points


def test_a_slot_exactly_its_room_from_a_standing_robot_is_free():
    # service point (10, 1); robot 2 stands 2 radii + SLOT_GAP_M / 2 above slot 0
    w = orca_world([(12.0, 1.0), (10.0, 1.0), (10.85, 1.675)])
    f = w.fleet
    give(w, [0], [(10.0, 1.0)])
    f.state[1:] = [WORKING, IDLE]
    f.last_z_m[0] = 11.2 + 1j
    k0 = slot(10 + 1j, 0)
    assert abs(f.last_z_m[2] - k0) == 2 * 0.25 + 0.5 * 0.35
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.site[0] == k0


def test_a_slot_counts_as_another_robots_goal_up_to_a_micrometre_from_it():
    # service point (1, 1.5): slot 0 is (1.85, 1.5); robot 2 drives to a point exactly
    # 1e-6 m from it (offsets in units of 2^-52 m, so every difference is exact)
    w = orca_world([(3.0, 1.6), (1.0, 1.5), (4.0, 4.0)])
    f = w.fleet
    give(w, [0, 2], [(1.0, 1.5), (6.0, 4.0)])
    f.state[1] = WORKING
    k0 = slot(1.0 + 1.5j, 0)
    f.site[2] = complex(k0.real + 3979479812 * 2.0**-52, k0.imag + 2108589583 * 2.0**-52)
    assert abs(f.site[2] - k0) == 1e-6
    f.last_z_m[0] = 2.5 + 1.6j
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.site[0] == slot(1.0 + 1.5j, 1)  # slot 0 is robot 2's: the next nearest
    w.jobs.sites.slotted[0] = False
    f.site[0] = 1.0 + 1.5j
    f.site[2] = k0 + 2e-6  # farther: another point, slot 0 is free
    w.jobs.sites.take_slots([0], f.last_z_m, 4.0)
    assert f.site[0] == k0


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


def test_step_clear_skips_a_broken_robot_and_serves_the_next():
    w = orca_world([(4.0, 5.0), (10.0, 5.0)])
    for b in w.motors.bodies:
        b.angle = 0.0
    w.jobs.broken[:] = [True, False]
    w.jobs.sites.step_clear([0, 1], 3.0)  # robot 0 cannot move; robot 1 still steps clear
    assert w.fleet.yielding.tolist() == [False, True]
    assert w.follower.last[0] == -1 and len(waypoints(w, 1)) == 2


def _gap_world(second_gap_y: float, look_ahead: str = "off", pass_s: float = JamSpec().pass_s):
    """A wall across a 12 x 8 m arena at x = 6 with a 1.4 m gap at y = 3, where a robot works
    (1000 s), and a second gap centred at ``second_gap_y``; robot 0 drives from (3, 3) to
    (9, 3), straight through the first gap (the planner ignores robots; ``[spatial]
    look_ahead`` as given)."""
    from scenarios.experiments.hardcases import swap_world

    lo, hi = second_gap_y - 0.7, second_gap_y + 0.7
    walls = [((5.9, a), (6.1, a), (6.1, b), (5.9, b)) for a, b in [(0, 2.3), (3.7, lo), (hi, 8)]]
    starts, goals = [(3.0, 3.0), (6.0, 3.0)], [(9.0, 3.0), (6.0, 3.0)]
    jams = JamSpec(pass_s=pass_s)
    return swap_world(
        starts,
        goals,
        (12.0, 8.0),
        "auto",
        "orca",
        walls,
        look_ahead=look_ahead,
        settings={"jams": jams},
    )


def _arrive(world) -> tuple[float, float]:
    """When robot 0 starts work at its site (inf: not within 60 s), and the highest it went."""
    from scenarios.experiments.hardcases import time_to_all_arrive

    top = [0.0]

    def watch(w):
        top[0] = max(top[0], float(w.fleet.last_z_m[0].imag))

    t = time_to_all_arrive(world, 60.0, lambda w: w.fleet.state[0] == WORKING, watch)
    return t, top[0]


def test_a_robot_beside_one_at_work_at_another_site_goes_round_it_without_a_try():
    """The worker fills the gap (0.45 m either side, a robot needs 0.7): robot 0 stands
    beside it, and ``pass_s`` later (not the stuck timeout) takes the way through the other
    gap, 2.3 m longer, without spending a recovery try; with the rule off it waits for the
    stuck timeout and then goes round, spending one. Where the only way round is more than
    ``pass_extra_m`` longer the rule leaves every robot exactly as it was."""
    runs = {}
    for rule in (True, False):
        for gap_y in (5.0, 6.9):
            world = _gap_world(gap_y, pass_s=PASS_S if rule else 3600.0)
            runs[rule, gap_y] = world, *_arrive(world)
    (on, t_on, top_on), (off, t_off, top_off) = runs[True, 5.0], runs[False, 5.0]
    assert top_on > 4.3 and top_off > 4.3  # both through the second gap in the end
    assert on.fleet.recoveries[0] == 0 and off.fleet.recoveries[0] == 1
    stuck_s = on.spatial.stuck_timeout_s
    assert t_off - t_on > stuck_s - PASS_S - 2.0  # the wait it saves, less the turns
    (far, t_far, _), (far_off, t_far_off, _) = runs[True, 6.9], runs[False, 6.9]
    assert np.isfinite(t_far) and t_far == t_far_off
    assert np.array_equal(far.fleet.last_z_m, far_off.fleet.last_z_m)
    assert far.fleet.recoveries.tolist() == far_off.fleet.recoveries.tolist() == [1, 0]


def test_going_round_skips_a_robot_at_work_for_the_same_site():
    """The rule leaves a robot alone whose neighbour at work works for the robot's own site
    (the site's queue and slots decide who goes where), and re-plans it, through the second
    gap, when that robot works for another site: the same moment, called directly."""
    world = _gap_world(5.0, pass_s=3600.0)  # the rule off while the robot comes up
    while world.time_s < 10.0:
        world.advance(0.1)
    f, jobs, t = world.fleet, world.jobs, world.time_s
    assert f.state[0] == DRIVING and f.state[1] == WORKING
    assert abs(f.v_cmd_mps[0]) < 0.1 and t - f.t_progress_s[0] >= 2.0
    jobs.jams.rules = JamSpec(pass_s=2.0)  # the rule on from now
    before, clock = waypoints(world, 0).copy(), f.t_progress_s[0]
    own = jobs.sites.service[0]
    jobs.sites.service[0] = jobs.sites.service[1]  # as if both worked for one site
    jobs.jams.pass_workers(t)
    assert np.array_equal(waypoints(world, 0), before) and f.t_progress_s[0] == clock
    jobs.sites.service[0] = own
    jobs.jams.pass_workers(t)
    after = waypoints(world, 0)
    assert f.t_progress_s[0] == t and after.imag.max() > 4.3  # through the second gap
    assert f.recoveries[0] == 0


# ---- jams in single-lane places (break_jams) --------------------------------------------

GAP = [  # a wall across x = 10 with a 1 m gap at y = 4.5..5.5 (single-lane for 0.25 m robots)
    ((9.8, 0.0), (10.2, 0.0), (10.2, 4.5), (9.8, 4.5)),
    ((9.8, 5.5), (10.2, 5.5), (10.2, 10.0), (9.8, 10.0)),
]
AISLE = [  # a corridor 2 m wide along y = 4..6 (two robots pass in it)
    ((2.0, 3.6), (18.0, 3.6), (18.0, 4.0), (2.0, 4.0)),
    ((2.0, 6.0), (18.0, 6.0), (18.0, 6.4), (2.0, 6.4)),
]


def lane(obstacles, j: complex, k: complex, standing=()) -> bool:
    """Is robot 0 at j single-lane toward robot 1 at k (robots 2.. stand, idle, at standing)?"""
    starts = [(4.0, 2.0), (16.0, 2.0)] + [(p.real, p.imag) for p in standing]
    w = orca_world(starts, obstacles=obstacles)
    w.fleet.state[:2] = DRIVING
    w.fleet.last_z_m[:2] = [j, k]
    return w.jobs.jams.single_lane(0, 1)


def test_a_gap_is_single_lane_and_open_floor_or_a_two_metre_aisle_is_not():
    assert lane(GAP, 10 + 5j, 11 + 5j) and lane(GAP, 10 + 5j, 9 + 5j)
    assert not lane(GAP, 8 + 5j, 9 + 5j)  # before the wall: room either side
    assert not lane(GAP, 10 + 5j, 10 + 6j)  # the line along the wall: room ahead
    assert not lane(AISLE, 10 + 5j, 11 + 5j)  # 0.6 m either side is free
    assert not lane(AISLE, 10 + 4.4j, 11 + 4.4j)  # one side free is enough
    assert not lane((), 10 + 5j, 11 + 5j)
    # a robot standing 0.6 m to one side of the aisle's middle narrows it to one lane ...
    assert lane(AISLE, 10 + 4.55j, 11 + 4.55j, standing=[10 + 5.3j])
    # ... but not one 0.5 m (two radii) from that side point, or a driving one
    assert not lane(AISLE, 10 + 4.55j, 11 + 4.55j, standing=[10 + 5.65j])
    assert lane(AISLE, 10 + 4.55j, 11 + 4.55j, standing=[10 + 5.64j])


def _head_on(obstacles, t_s: float):
    """Robots 0 and 1 face each other, 0.7 m apart across x = 10 (in the gap, if any), both
    commanded to stand since their last progress at 20 s; robot 2 idles out of the way;
    returns the world and the time."""
    w = orca_world([(4.0, 5.0), (16.0, 5.0), (18.0, 9.0)], obstacles=obstacles)
    f = w.fleet
    give(w, [0, 1], [(16.0, 5.0), (4.0, 5.0)])
    f.last_z_m[:2] = [9.65 + 5j, 10.35 + 5j]
    f.v_cmd_mps[:2] = 0.0
    f.t_progress_s[:2] = 20.0
    return w, at(w, t_s)


def test_a_jam_in_a_gap_is_acted_on_after_pass_s_not_the_stuck_timeout():
    """Head-on in the gap, both standing 2 s: robot 1 (the higher index, its way back free)
    backs out past where it was given its task and robot 0 waits for it, without waiting for
    the 20 s stuck timeout. Before ``PASS_S`` nothing happens."""

    w, t = _head_on(GAP, 20.0 + PASS_S - 0.1)
    w.jobs.jams.break_jams(t)
    assert w.fleet.recoveries[:2].tolist() == [0, 0] and w.fleet.t_progress_s[:2].tolist() == [
        20,
        20,
    ]
    w, t = _head_on(GAP, 20.0 + PASS_S)
    w.jobs.jams.break_jams(t)
    f = w.fleet
    assert f.recoveries[:2].tolist() == [0, 1] and f.t_progress_s[:2].tolist() == [t, t]
    back = waypoints(w, 1)
    assert back[0] == 10.35 + 5j and back[-1] == 4 + 5j  # out, then on to its site
    assert max(back.real) >= 16.0 + DEADLOCK_M - 1e-9  # past its start (16, 5)


def test_on_open_floor_only_a_pair_standing_alone_is_a_jam():
    """On open floor (or in a 2 m aisle) a robot standing 2 s beside a driving one acts only
    if that one stands too and no third driving robot is within ``DEADLOCK_M`` (a standoff
    of two); beside a moving one, or in a crowd, it is left to ORCA and the stuck timeout.
    In a single-lane gap it acts in the crowd too."""

    for floor in ((), AISLE):
        w, t = _head_on(floor, 20.0 + PASS_S)
        w.jobs.jams.break_jams(t)  # open floor, both standing alone: robot 0 goes round robot 1,
        assert w.fleet.recoveries[:2].tolist() == [1, 0], floor  # and 1 waits for it
        assert w.fleet.t_progress_s[:2].tolist() == [t, t]
        for change in ("moving", "crowd"):
            w, t = _head_on(floor, 20.0 + PASS_S)
            f = w.fleet
            if change == "moving":
                f.v_cmd_mps[1] = 0.2  # robot 1 moves: robot 0 waits for ORCA
            else:  # a third driving robot 1.35 m from both
                give(w, [2], [(4.0, 8.0)])
                f.last_z_m[2], f.v_cmd_mps[2] = 10 + 6.3j, 0.5
            w.jobs.jams.break_jams(t)
            assert f.recoveries[:2].tolist() == [0, 0], (floor, change)
            assert np.all(f.t_progress_s[:2] == 20.0), (floor, change)
    w, t = _head_on(GAP, 20.0 + PASS_S)
    f = w.fleet
    give(w, [2], [(4.0, 8.0)])  # a third robot of the jam, 1.0 m behind robot 1, driving
    f.last_z_m[2], f.v_cmd_mps[2] = 11.2 + 5.6j, 0.0
    w.jobs.jams.break_jams(t)
    assert f.recoveries.sum() == 1  # one of them goes round or backs out
    assert f.t_progress_s.tolist() == [t, t, t]  # and the others wait for it


def test_break_jams_leaves_a_robot_alone_beside_one_at_work_holding_or_backing_off():

    for change in ("working", "holding", "backoff", "moving"):
        w, t = _head_on(GAP, 20.0 + PASS_S)
        f = w.fleet
        if change == "working":
            f.state[1], f.work_end_s[1] = WORKING, t + 1.0  # robot 0's neighbour works
        elif change == "holding":
            w.jobs.sites.holding[:2] = True
        elif change == "backoff":
            f.backoff_until_s[:2] = t + 1.0
        else:
            f.v_cmd_mps[:2] = 0.2
        w.jobs.jams.break_jams(t)
        assert f.recoveries[:2].tolist() == [0, 0], change
        assert np.all(f.t_progress_s[:2] == 20.0), change


# ---- robot-aware planning: looking ahead past robots at work (look_ahead) ----------------


def _first_look(world):
    """Advance ``world`` (``_gap_world``) until robot 1 is at work and robot 0 has been looked
    at (the period after robot 1 began work); the time."""
    jams = world.jobs.jams
    while not (world.fleet.state[1] == WORKING and not (jams.due.any() or jams.began.any())):
        world.advance(0.1)
        assert world.time_s < 5.0
    return world.time_s


def test_a_robot_plans_round_one_at_work_in_its_way_before_it_gets_there():
    """Robot 1 works (1000 s) in the gap robot 0's way runs through: as soon as robot 1 is
    at work robot 0 plans its way through the second gap (2.3 m longer, far quicker than
    waiting), without a try and before it has come near; it reaches its site sooner than
    with ``[spatial] look_ahead = "off"`` (the default: it drives up, stands ``PASS_S``
    beside the robot at work and goes round, ``pass_workers``), whose way is still the
    straight one then."""

    off = _gap_world(5.0)
    while off.fleet.state[1] != WORKING:
        off.advance(0.1)
    off.advance(0.2)
    assert waypoints(off, 0).imag.max() < 3.1  # the way it was given: through robot 1
    world = _gap_world(5.0, look_ahead="on")
    t0 = _first_look(world)
    f = world.fleet
    assert t0 < 1.0 and waypoints(world, 0).imag.max() > 4.3  # through the second gap
    assert abs(f.last_z_m[0] - (3 + 3j)) < 0.3 and f.recoveries[0] == 0
    t_on, top_on = _arrive(world)
    t_off, top_off = _arrive(off)
    assert top_on > 4.3 and top_off > 4.3
    assert np.isfinite(t_on) and t_on < t_off - PASS_S


def test_looking_ahead_keeps_the_way_when_waiting_is_quicker_or_the_site_is_shared():
    """Robot 0's way passes robot 1 at work about 3 m ahead; the other gap is far (the way
    round it several metres longer). Robot 0 keeps its way, unchanged and its clock
    untouched, when robot 1's work ends before robot 0 would wait ``AHEAD_WAIT_S`` there,
    when the way round takes 0.1 s longer at top speed than the wait, and when robot 1 works
    for robot 0's own site (the site's queue and slots decide); with the wait 0.1 s longer
    than the way round it goes round. Called directly, at one moment."""

    wait_s = JamSpec().ahead_wait_s
    world = _gap_world(6.9)  # look_ahead "off": only the direct calls below look
    f, jobs = world.fleet, world.jobs
    while f.state[1] != WORKING:
        world.advance(0.1)
    t = world.time_s
    before, clock = waypoints(world, 0).copy(), f.t_progress_s[0]
    wait, along, gap = jobs.jams.waits(np.array([0]), np.array([1]), t)
    assert gap[0, 0] < 0.1  # the way runs through robot 1's gap
    assert 2.5 < along[0, 0] < 3.2  # the way to the point passing robot 1
    arrive = t + along[0, 0] / world.follower.v_max_mps
    assert wait[0, 0] == pytest.approx(f.work_end_s[1] - arrive)
    z0 = f.last_z_m[0]
    for x, waits in ((5.0, True), (5.3, False)):  # the point nearest robot 1: 1.0 / 0.7 m on
        f.last_z_m[0] = complex(x, 3.0)
        assert (jobs.jams.waits(np.array([0]), np.array([1]), t)[0][0, 0] > 0) == waits
    f.last_z_m[0] = z0  # beside it already (within AHEAD_BLOCK_M along its way): pass_workers
    grown = world.controller.radius_m + JamSpec().ahead_grow_m
    z = f.last_z_m
    way = world.planner.path_around((z[0].real, z[0].imag), (9.0, 3.0), z[[1]], grown)
    extra_s = float(np.abs(np.diff(way[:, 0] + 1j * way[:, 1])).sum()) - jobs.jams.way_left_m(0)
    extra_s /= world.follower.v_max_mps
    assert wait_s + 1.0 < extra_s < 10.0

    def look(work_left_s: float, service=None) -> bool:
        f.work_end_s[1] = arrive + work_left_s
        own = jobs.sites.service[0]
        if service is not None:
            jobs.sites.service[0] = service
        jobs.jams.due[0] = True
        jobs.jams.look_ahead(t)
        jobs.sites.service[0] = own
        assert not (jobs.jams.due.any() or jobs.jams.began.any())
        return not np.array_equal(waypoints(world, 0), before)

    assert not look(wait_s - 0.1)  # it ends before the robot would wait long
    assert not look(extra_s - 0.1)  # waiting is quicker than the way round
    assert not look(1000.0, service=jobs.sites.service[1])  # the same site
    assert f.t_progress_s[0] == clock and f.recoveries[0] == 0
    assert look(extra_s + 0.1)  # the way round is quicker: round it
    assert waypoints(world, 0).imag.max() > 6.0 and f.t_progress_s[0] == t
