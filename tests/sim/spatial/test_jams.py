"""``sim.spatial.jams.Jams`` rule by rule, on scenes set by hand: exact numbers of ``waits`` and
``way_left_m`` on a bent way, which robots ``standing_near``, ``pass_workers``,
``break_jams`` and ``look_ahead`` act on when several are listed, and the geometry of
``single_lane``, ``standoff`` and ``backed_in``. Written for the gaps mutation run H found
(README, "Testing"); and giving way (``give_way``) and going round (``go_round``) when a
robot is stuck. The rules in whole runs are in ``tests/behaviour/test_jams.py`` and
``tests/behaviour/test_hardcases.py``.

Robots of radius 0.25 m, top speed 1.5 m/s; the planner keeps centres 0.35 m from obstacles.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.scenario import JamSpec, QueueSpec
from sim.states import DRIVING, IDLE, WORKING
from tests.worlds import AISLE, GAP, ROOM, at, deadlock, give, lane, orca_world, set_way, waypoints

# the settings' defaults (sim.scenario), under the names these tests use
AROUND_M = JamSpec().around_m
DEADLOCK_M = JamSpec().deadlock_m
PASS_S = JamSpec().pass_s
AHEAD_GROW_M = JamSpec().ahead_grow_m
PASS_EXTRA_M = JamSpec().pass_extra_m
V_MAX = 1.5  # m/s


def test_waits_measures_along_the_rest_of_a_bent_way_from_where_the_robot_is():
    """Robot 0's way (2, 2) -> (6, 2) -> (6, 6) -> (10, 6); it stands at (5.6, 2), 0.4 m short
    of the first corner: 8.4 m of way left. Robots 1-5 at work:
    1 at (6.3, 4), 0.3 m beside the second leg, 2.4 m along: it waits 20 - 2.4 / 1.5 s;
    2 at (5.2, 2.3), 0.5 m behind the robot: nearest at the robot, 0 m along;
    3 at (10.5, 6), 0.5 m beyond the way's end, whose work ends 5 s from now, before the
    robot gets there (8.4 / 1.5 = 5.6 s): no wait;
    4 at (8, 6.2), at work for robot 0's own site: no gap, no wait;
    5 at (5.8, 1.7), beside the 0.4 m piece left of the first leg: 0.2 m along, beside it
    already (not ahead)."""
    starts = [(2.0, 2.0), (6.3, 4.0), (5.2, 2.3), (10.5, 6.0), (8.0, 6.2), (5.8, 1.7)]
    w = orca_world(starts)
    f, jams = w.fleet, w.jobs.jams
    assert w.follower.v_max_mps == V_MAX
    give(w, [0], [(10.0, 6.0)])
    set_way(w, 0, [2 + 2j, 6 + 2j, 6 + 6j, 10 + 6j])
    f.last_z_m[0] = 5.6 + 2j
    t = at(w, 10.0)
    f.state[1:] = WORKING
    f.work_end_s[1:] = [t + 20.0, t + 50.0, t + 5.0, t + 50.0, t + 50.0]
    w.jobs.sites.service[1:] = [6.3 + 4j, 5.2 + 2.3j, 10.5 + 6j, 10 + 6j, 5.8 + 1.7j]
    assert jams.way_left_m(0) == pytest.approx(8.4, abs=1e-12)
    wait, along, gap = jams.waits(np.array([0]), np.arange(1, 6), t)
    assert along[0] == pytest.approx([2.4, 0.0, 8.4, 6.4, 0.2], abs=1e-9)
    assert gap[0] == pytest.approx([0.3, 0.5, 0.5, np.inf, 0.3], abs=1e-9)
    assert wait[0] == pytest.approx([20.0 - 2.4 / V_MAX, 0.0, 0.0, 0.0, 0.0], abs=1e-9)


WALL_GAPS = [  # a wall across x = 10 with a 1 m gap at y = 4.5..5.5 and a 1.5 m one at the top
    ((9.8, 0.0), (10.2, 0.0), (10.2, 4.5), (9.8, 4.5)),
    ((9.8, 5.5), (10.2, 5.5), (10.2, 8.5), (9.8, 8.5)),
]


ONE_GAP = [WALL_GAPS[0], ((9.8, 5.5), (10.2, 5.5), (10.2, 10.0), (9.8, 10.0))]


def ahead_scene(obstacles, wait_s: float = 1000.0, idle: bool = False):
    """Robot 0 drives (8, 2) -> (12, 2) through the gap at y = 5, where robot 1 works and
    would keep it waiting ``wait_s``; robot 2 drives (2, 8) -> (6, 8) on open floor through
    robot 3 at work (1000 s) at (4, 8). Both were just given their tasks. With ``idle``,
    robot 4 stands idle at (9, 5), stepping aside along a way through robot 1."""
    starts = [(8.0, 2.0), (10.0, 5.0), (2.0, 8.0), (4.0, 8.0)] + [(9.0, 5.0)] * idle
    w = orca_world(starts, obstacles=obstacles)
    f, jams = w.fleet, w.jobs.jams
    give(w, [0, 2], [(12.0, 2.0), (6.0, 8.0)])
    t = at(w, 5.0)
    f.state[[1, 3]] = WORKING
    w.jobs.sites.service[[1, 3]] = [10 + 5j, 4 + 8j]
    f.work_end_s[3] = t + 1000.0
    along = jams.waits(np.array([0]), np.array([1]), t)[1][0, 0]
    f.work_end_s[1] = t + along / V_MAX + wait_s
    assert jams.due[[0, 2]].all()
    if idle:
        set_way(w, 4, [9 + 5j, 11 + 5j])
        f.yielding[4] = True
        assert f.state[4] == IDLE
    return w, f, t


def extra_s(w, j: int, work) -> float:
    """How much longer robot j's way round the robots ``work`` (grown by AHEAD_GROW_M) is
    than its way, at top speed, s."""

    z = w.fleet.last_z_m
    site = (w.fleet.site[j].real, w.fleet.site[j].imag)
    way = w.planner.path_around((z[j].real, z[j].imag), site, z[work], 0.25 + AHEAD_GROW_M)
    return (np.abs(np.diff(way[:, 0] + 1j * way[:, 1])).sum() - w.jobs.jams.way_left_m(j)) / V_MAX


@pytest.mark.parametrize("case", ["no way round", "waiting is quicker", "round is quicker"])
def test_look_ahead_decides_for_each_robot_on_its_own(case):
    """Robot 0's way round robot 1 is through the top gap, about 7.7 m (5.1 s) longer, or
    none without that gap; robot 2's round robot 3 is short. Robot 0 keeps its way where
    there is none round or waiting (4 s) is quicker, and takes the way round when waiting
    (8 s) is not; robot 2 takes its way round every time."""
    obstacles = ONE_GAP if case == "no way round" else WALL_GAPS
    wait_s = {"no way round": 1000.0, "waiting is quicker": 4.0, "round is quicker": 8.0}[case]
    w, _, t = ahead_scene(obstacles, wait_s)
    if case != "no way round":
        assert 4.0 < extra_s(w, 0, [1]) < 8.0
    before = waypoints(w, 0).copy()
    w.jobs.jams.look_ahead(t)
    changed = not np.array_equal(waypoints(w, 0), before)
    assert changed == (case == "round is quicker")
    assert waypoints(w, 2).imag.max() > 8.5 or waypoints(w, 2).imag.min() < 7.5


@pytest.mark.parametrize("why", ["backing off", "replanning", "holding", "let in", "not due"])
def test_look_ahead_looks_only_at_robots_just_given_a_task_and_driving_to_their_place(why):
    w, f, t = ahead_scene(WALL_GAPS)
    s, jams = w.jobs.sites, w.jobs.jams
    if why == "backing off":
        f.backoff_until_s[2] = t + 1.0
    elif why == "replanning":
        f.replan[2] = True
    elif why == "holding":
        s.holding[2] = True
    elif why == "let in":
        s.admitted[2] = True
    else:
        jams.due[2] = False
    before = waypoints(w, 2).copy()
    jams.look_ahead(t)
    assert np.array_equal(waypoints(w, 2), before)
    assert not (jams.due.any() or jams.began.any())  # the marks are cleared


def test_a_robot_that_begins_work_has_the_robots_whose_way_it_blocks_looked_at_only():
    """Nobody was just given a task; robot 1 begins work in robot 0's way: robot 0 plans
    round it. Robot 2, whose way robot 3 has blocked since before, and robot 4, idle and
    yielding along a way through robot 1, keep theirs."""
    w, _, t = ahead_scene(WALL_GAPS, idle=True)
    jams = w.jobs.jams
    jams.due[:] = False
    jams.began[1] = True
    before = [waypoints(w, j).copy() for j in (0, 2, 4)]
    jams.look_ahead(t)
    assert not np.array_equal(waypoints(w, 0), before[0])
    assert np.array_equal(waypoints(w, 2), before[1])
    assert np.array_equal(waypoints(w, 4), before[2])


def test_standing_near_lists_only_robots_standing_pass_s_since_their_last_progress():
    w = orca_world([(4.0, 5.0), (4.8, 5.0), (12.0, 5.0), (12.8, 5.0)])
    f = w.fleet
    give(w, [0, 1, 2, 3], [(16.0, 5.0), (2.0, 5.0), (16.0, 2.0), (2.0, 2.0)])
    t = at(w, 30.0)
    f.v_cmd_mps[:] = 0.0
    f.t_progress_s[:] = [t - PASS_S - 1.0, t - PASS_S + 0.5, t - PASS_S, t - 10.0]
    assert w.jobs.jams.standing_near(t) == [(0, 1), (2, 3), (3, 2)]


def worker_scene():
    """Robot 0 drives (8, 5) -> (14, 5) with robot 1 at work (1000 s, another site) 0.7 m
    ahead on its way; robot 2 drives (8, 2) -> (14, 2) with robot 3 0.7 m ahead, at
    (8.7, 2)."""
    w = orca_world([(8.0, 5.0), (8.7, 5.0), (8.0, 2.0), (8.7, 2.0)])
    f = w.fleet
    give(w, [0, 2], [(14.0, 5.0), (14.0, 2.0)])
    t = at(w, 40.0)
    f.state[[1, 3]] = WORKING
    f.work_end_s[[1, 3]] = t + 1000.0
    w.jobs.sites.service[[1, 3]] = [8.7 + 5j, 8.7 + 2j]
    f.v_cmd_mps[:] = 0.0
    f.t_progress_s[[0, 2]] = t - PASS_S
    return w, f, t


@pytest.mark.parametrize(
    "why", ["driving", "same site", "little work left", "not in the way", "no way round"]
)
def test_pass_workers_goes_on_to_the_next_pair_after_one_it_leaves(why, monkeypatch):
    """The pair (2, 3) comes first and is left alone (robot 3 drives; works for robot 2's
    site; has 1.5 s of work left; stands beside the way, not in it; or there is no way round
    it): robot 2 keeps its way, and robot 0 still goes round robot 1, on exactly the path
    planned round the robots within AROUND_M of it (robot 1, and robot 3 where it stands
    beside robot 2's way)."""
    w, f, t = worker_scene()
    s = w.jobs.sites
    if why == "driving":
        f.state[3] = DRIVING
    elif why == "same site":
        s.service[3] = s.service[2]
    elif why == "little work left":
        f.work_end_s[3] = t + 1.5
    elif why == "not in the way":
        f.last_z_m[3] = 8.7 + 2.8j
    else:  # no path round robot 3 (as in a gap it fills)
        plan = w.planner.path_around

        def path_around(start, *rest):
            return np.zeros((0, 2)) if start == (8.0, 2.0) else plan(start, *rest)

        monkeypatch.setattr(w.planner, "path_around", path_around)
    before = waypoints(w, 2).copy()
    w.jobs.jams.pass_workers(t, [(2, 3), (0, 1)])
    assert np.array_equal(waypoints(w, 2), before) and f.t_progress_s[2] == t - PASS_S
    close = np.abs(f.last_z_m - f.last_z_m[0]) < AROUND_M
    close[0] = False  # robot 1; robot 3 too when it stands beside robot 2's way
    want = w.planner.path_around((8.0, 5.0), (14.0, 5.0), f.last_z_m[close], 0.25)
    assert len(want) > 2 and np.array_equal(waypoints(w, 0), want[:, 0] + 1j * want[:, 1])
    assert f.t_progress_s[0] == t and f.recoveries[0] == 0


TWO_GAPS = [  # a wall across x = 10 with 1 m gaps at y = 4.5..5.5 and y = 6.5..7.5
    ((9.8, 0.0), (10.2, 0.0), (10.2, 4.5), (9.8, 4.5)),
    ((9.8, 5.5), (10.2, 5.5), (10.2, 6.5), (9.8, 6.5)),
    ((9.8, 7.5), (10.2, 7.5), (10.2, 10.0), (9.8, 10.0)),
]


def slow_world(starts, obstacles, v_max_mps: float):
    """``orca_world`` with robots whose top speed is ``v_max_mps``."""
    from sim.scenario import DriveSpec

    drive = DriveSpec(max_wheel_speed_radps=v_max_mps / DriveSpec().wheel_radius_m)
    return orca_world(starts, obstacles=obstacles, drive=drive)


@pytest.mark.parametrize("spare_s", [0.05, -0.05])
def test_pass_workers_goes_round_only_if_the_extra_drive_is_quicker_than_the_work_left(spare_s):
    """Robots with a top speed of 0.9 m/s. Robot 1 works in the lower gap, in robot 0's way
    from (9.2, 5) to (12, 5); the way round, through the upper gap, is a little over 2 m
    longer (about 2.3 s): robot 0 takes it when robot 1 has 0.05 s more than that to work,
    and waits when it has 0.05 s less. (At the default 1.5 m/s, PASS_EXTRA_M already keeps
    the extra drive within PASS_S.)"""

    v = 0.9
    w = slow_world([(9.2, 5.0), (10.0, 5.0)], TWO_GAPS, v)
    f = w.fleet
    assert w.follower.v_max_mps == pytest.approx(v)
    give(w, [0], [(12.0, 5.0)])
    t = at(w, 40.0)
    f.state[1] = WORKING
    w.jobs.sites.service[1] = 10 + 5j
    way = w.planner.path_around((9.2, 5.0), (12.0, 5.0), f.last_z_m[[1]], 0.25)
    extra = float(np.abs(np.diff(way[:, 0] + 1j * way[:, 1])).sum()) - f.left_m[0]
    assert 2.0 < extra < PASS_EXTRA_M and extra / v - 0.05 > PASS_S
    f.work_end_s[1] = t + extra / w.follower.v_max_mps + spare_s
    before = waypoints(w, 0).copy()
    w.jobs.jams.pass_workers(t, [(0, 1)])
    assert (not np.array_equal(waypoints(w, 0), before)) == (spare_s > 0)


def head_on(obstacles=GAP, extra=()):
    """Robots 0 and 1 face each other 0.7 m apart across x = 10 (in the gap), both standing
    since their last progress at 20 s; robots 2.. (``extra``: (start, goal) pairs) drive."""
    starts = [(4.0, 5.0), (16.0, 5.0)] + [s for s, _ in extra]
    w = orca_world(starts, obstacles=obstacles)
    f = w.fleet
    give(w, list(range(len(starts))), [(16.0, 5.0), (4.0, 5.0)] + [g for _, g in extra])
    f.last_z_m[:2] = [9.65 + 5j, 10.35 + 5j]
    f.v_cmd_mps[:] = 0.0
    f.t_progress_s[:] = 20.0
    return w, f, at(w, 20.0 + PASS_S)


def acted(f, j: int, t: float) -> bool:
    return bool(f.t_progress_s[j] == t)


@pytest.mark.parametrize("first", ["no clock", "open floor"])
def test_break_jams_goes_on_to_the_next_pair_after_one_it_leaves(first):
    """The pair (2, 3) comes first and is left alone (robot 2 idles: no stuck clock; or the
    two meet on open floor with robot 3 moving): the jam of robots 0 and 1 in the gap is
    still acted on."""
    w, f, t = head_on(extra=[((4.0, 1.0), (8.0, 1.0)), ((4.8, 1.0), (1.0, 1.0))])
    if first == "no clock":
        f.state[2], f.t_progress_s[2] = IDLE, np.inf
    else:
        f.v_cmd_mps[3] = 0.5
    w.jobs.jams.break_jams(t, [(2, 3), (0, 1)])
    assert not acted(f, 2, t) and acted(f, 0, t)


def test_break_jams_leaves_a_robot_that_made_progress_within_pass_s():
    w, f, t = head_on()
    f.t_progress_s[0] = t - PASS_S + 0.5  # pass_workers gave it a path half a second ago
    w.jobs.jams.break_jams(t, [(0, 1)])
    assert f.t_progress_s[0] == t - PASS_S + 0.5 and f.recoveries.sum() == 0


def test_a_place_single_lane_for_the_other_robot_only_is_a_jam_in_a_crowd_too():
    """Robot 0 stands on open floor before the gap (room beside it), robot 1 in the gap;
    robot 2 drives past within DEADLOCK_M of robot 0, so the two do not stand alone: the
    gap, single-lane for robot 1, makes it a jam."""
    w, f, t = head_on(extra=[((8.5, 5.8), (2.0, 8.0))])
    f.last_z_m[:2] = [9.2 + 5j, 10 + 5j]
    f.v_cmd_mps[2] = 0.5
    jams = w.jobs.jams
    assert not jams.single_lane(0, 1) and jams.single_lane(1, 0)
    assert abs(f.last_z_m[2] - f.last_z_m[0]) < DEADLOCK_M
    jams.break_jams(t, [(0, 1)])
    assert acted(f, 0, t)


def test_robots_driving_beside_a_jam_on_open_floor_do_not_make_it_single_lane():
    """Robots 2 and 3 drive past 0.6 m either side of robot 0: a lane is narrowed only by
    robots that stand, and with them near robots 0 and 1 do not stand alone: no jam."""
    w, f, t = head_on(obstacles=(), extra=[((9.65, 5.6), (9.65, 9.0)), ((9.65, 4.4), (9.65, 1.0))])
    f.last_z_m[2:4] = [9.65 + 5.6j, 9.65 + 4.4j]
    f.v_cmd_mps[2:4] = 0.5
    w.jobs.jams.break_jams(t, [(0, 1)])
    assert not acted(f, 0, t) and f.recoveries.sum() == 0


def test_the_side_points_are_two_radii_and_the_gap_beside_the_robot_however_close_the_other():
    """Robot 1 only 0.65 m ahead: the side points are still 0.6 m to either side (the lower
    one in the aisle's wall); a robot standing at (10, 5.55) is 0.4 m from the upper one."""
    assert lane(AISLE, 10 + 4.55j, 10.65 + 4.55j, standing=[10 + 5.55j])
    assert not lane(AISLE, 10 + 4.55j, 10.65 + 4.55j, standing=[10 + 5.75j])


def test_the_side_points_are_square_to_a_diagonal_meeting():
    z, k = 10 + 5j, 10.5 + 5.5j
    side = 0.6 * 1j * (k - z) / abs(k - z)
    assert lane((), z, k, standing=[z + side, z - side])


@pytest.mark.parametrize("blocked", ["left", "right"])
def test_one_side_free_is_enough_and_both_sides_are_looked_at_each_at_its_distance(blocked):
    """Robots 0 and 1 meet along +x on open floor; a robot standing on one side point
    (0.6 m left or right) leaves the other free; with robots on both it is single-lane, and
    a robot 1.2 m to the side does not make it so."""
    z, k = 10 + 5j, 10.8 + 5j
    left, right = z + 0.6j, z - 0.6j
    one = left if blocked == "left" else right
    assert not lane((), z, k, standing=[one])
    assert lane((), z, k, standing=[left, right])
    far = z + (1.2j if blocked == "left" else -1.2j)
    assert not lane((), z, k, standing=[left if blocked == "right" else right, far])


def test_standoff_counts_the_driving_robots_near_j_when_the_caller_has_none():
    w = orca_world([(10.0, 5.0), (10.7, 5.0), (10.0, 6.0), (12.0, 8.0)])
    f = w.fleet
    give(w, [0, 1], [(16.0, 5.0), (4.0, 5.0)])
    f.v_cmd_mps[:2] = 0.0
    f.last_z_m[2] = 10 + 6j  # idle, 1 m from robot 0: it does not drive
    assert w.jobs.jams.standoff(0, 1) is True
    give(w, [2], [(2.0, 8.0)])  # now it drives: three near robot 0
    assert w.jobs.jams.standoff(0, 1) is False
    f.v_cmd_mps[1] = 0.2
    f.state[2] = IDLE
    assert w.jobs.jams.standoff(0, 1) is False  # robot 1 moves


def test_a_robot_in_a_short_way_back_is_in_the_way():
    """Robot 0 was given its task at (1, 5), 0.9 m behind it: 1.5 m beyond is off the map, so
    it backs out to (1, 5) itself, a way of 0.9 m; robot 1 stands on it 0.4 m along."""
    w = orca_world([(1.0, 5.0), (1.5, 5.1)])
    f, jams = w.fleet, w.jobs.jams
    give(w, [0], [(8.0, 5.0)])
    f.last_z_m[:2] = [1.9 + 5j, 1.5 + 5.1j]
    assert jams.refuge(0) == 1 + 5j
    assert jams.backed_in(0) is True
    f.last_z_m[1] = 1.5 + 6.0j  # 0.9 m beside it: not in the way
    assert jams.backed_in(0) is False


def test_with_no_path_back_the_straight_line_is_the_way():
    """Robot 0 was given its task at (5, 5) inside a walled box (cell 3..7 square) and stands
    outside it at (8.5, 5): its refuge (3.5, 5) has no path; the straight line back is
    looked at, and robot 1 stands on it 0.9 m along."""
    box = [
        ((2.6, 2.6), (7.4, 2.6), (7.4, 2.8), (2.6, 2.8)),
        ((2.6, 7.2), (7.4, 7.2), (7.4, 7.4), (2.6, 7.4)),
        ((2.6, 2.6), (2.8, 2.6), (2.8, 7.4), (2.6, 7.4)),
        ((7.2, 2.6), (7.4, 2.6), (7.4, 7.4), (7.2, 7.4)),
    ]
    w = orca_world([(5.0, 5.0), (7.6, 5.1)], obstacles=box)
    f, jams = w.fleet, w.jobs.jams
    jams.origin[0] = 5 + 5j
    f.last_z_m[:2] = [8.5 + 5j, 7.6 + 5.1j]
    refuge = jams.refuge(0)
    assert refuge == 3.5 + 5j and not len(w.planner.path((8.5, 5.0), (3.5, 5.0)))
    assert jams.backed_in(0) is True


def test_a_robot_beside_the_start_of_a_bent_way_back_is_judged_by_its_nearest_leg():
    """Robot 0 backs out round the end of a wall: its way goes up-left 0.76 m to the wall's
    corner, then left. Robot 1 stands 0.56 m to its right, nearest to the first leg only
    0.15 m along it (beside robot 0, not in its way), though 0.82 m from the second leg."""
    wall = [((4.9, 0.0), (5.1, 0.0), (5.1, 5.0), (4.9, 5.0))]
    w = orca_world([(5.6, 4.6), (6.1, 4.85)], obstacles=wall)
    jams = w.jobs.jams
    jams.origin[0] = 4.2 + 4.6j
    assert jams.refuge(0) == 2.7 + 4.6j
    way = w.planner.path((5.6, 4.6), (2.7, 4.6)) @ np.array([1.0, 1j])
    assert len(way) == 4 and abs(way[1] - way[0]) < 0.8  # the corner within DEADLOCK_M
    assert jams.backed_in(0) is False
    w.fleet.last_z_m[1] = 5.3 + 5.4j  # at the corner, 0.9 m along: in the way
    assert jams.backed_in(0) is True


# the settings' defaults (sim.scenario), under the names these tests use
DEADLOCK_M = JamSpec().deadlock_m
SLOT_GAP_M = QueueSpec().slot_gap_m
PASS_S = JamSpec().pass_s


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


def test_holders_never_give_way_and_a_stuck_robot_goes_round_them():
    starts = [(6.0, 5.0), (8.0, 5.0)]
    w = orca_world(starts)
    f, jobs = w.fleet, w.jobs
    give(w, [0, 1], [(14.0, 5.0), (2.0, 5.0)])
    jobs.sites.holding[1] = True
    f.last_z_m[:2] = [7.4 + 5j, 8 + 5j]
    t = at(w, 30.0)
    assert jobs.jams.give_way(0, t) is False  # the only driving robot near holds: no deadlock
    jobs.recover(0, t)
    path = waypoints(w, 0)
    assert f.recoveries[0] == 1 and len(path) > 2
    seg_a, seg_b = path[:-1], path[1:]
    # every segment of the new path keeps the grown robot (an octagon round its disc) clear
    u = np.clip(((8 + 5j - seg_a) * (seg_b - seg_a).conj()).real / np.abs(seg_b - seg_a) ** 2, 0, 1)
    gap = np.abs(seg_a + u * (seg_b - seg_a) - (8 + 5j))
    assert gap[1:].min() >= 0.25 + 0.25 + 0.1 - 1e-9  # the first leaves from inside it


def test_going_round_needs_a_robot_near_a_try_left_and_a_short_enough_path(monkeypatch):
    w = orca_world([(6.0, 5.0), (6.0 + AROUND_M, 5.0)])
    f, jobs = w.fleet, w.jobs
    give(w, [0, 1], [(14.0, 5.0), (2.0, 5.0)])
    f.last_z_m[:2] = [6 + 5j, 6 + AROUND_M + 5j]  # exactly AROUND_M apart: not near
    assert jobs.jams.go_round(0, 3.0) is False
    f.last_z_m[1] = 8 + 5j
    f.recoveries[0] = w.spatial.max_recoveries
    assert jobs.jams.go_round(0, 3.0) is False
    f.recoveries[0] = 0
    f.left_m[0] = 4.0
    long = np.array([[6.0, 5.0], [6.0, 5.0 + 11.0], [6.0, 5.0]])  # 22 m = 3 x 4 + 10
    monkeypatch.setattr(w.planner, "path_around", lambda *a: long)
    assert jobs.jams.go_round(0, 3.0) is True  # exactly the limit: taken
    f.recoveries[0], jobs.jams.around_s[0] = 0, -np.inf
    long[1, 1] += 1e-6
    assert jobs.jams.go_round(0, 4.0) is False  # a hair longer: not taken
    assert f.recoveries[0] == 0


def test_no_path_round_a_robot_that_fills_the_only_lane():
    lane = [
        ((1.3, 4.5), (9.0, 4.5), (9.0, 9.0), (1.3, 9.0)),
        ((0.0, 4.3), (9.0, 4.3), (9.0, 4.5), (0.0, 4.5)),
    ]
    w = orca_world([(0.65, 5.0), (0.65, 5.7)], obstacles=lane)
    give(w, [0], [(0.65, 9.5)])
    w.fleet.last_z_m[:2] = [0.65 + 5j, 0.65 + 5.7j]
    assert w.jobs.jams.go_round(0, 3.0) is False
    assert w.fleet.recoveries[0] == 0 and waypoints(w, 0)[-1] == 0.65 + 9.5j


def test_going_round_again_counts_one_more_try():
    w = orca_world([(6.0, 5.0), (8.0, 5.0)])
    f, jobs = w.fleet, w.jobs
    give(w, [0, 1], [(14.0, 5.0), (2.0, 5.0)])
    f.last_z_m[:2] = [7.4 + 5j, 8 + 5j]
    f.recoveries[0] = 1
    assert jobs.jams.go_round(0, 30.0) is True
    assert f.recoveries[0] == 2 and jobs.jams.around_s[0] == 30.0


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(allow_nan=False, allow_infinity=True, width=64), min_size=1, max_size=130)
)
def test_the_least_entry_is_numpys_minimum_for_short_and_long_arrays(values):
    """``_least`` (plain Python below ``SMALL`` entries, numpy above) returns what
    ``float(a.min())`` does, infinities included."""
    from sim.spatial.jams import SMALL, _least

    a = np.array(values)
    assert _least(a) == float(a.min())
    assert _least(np.resize(a, SMALL + 1)) == float(np.resize(a, SMALL + 1).min())
