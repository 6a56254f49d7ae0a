"""``sim.spatial.jams.Jams`` rule by rule, on scenes set by hand: exact numbers of ``waits`` and
``way_left_m`` on a bent way, which robots ``standing_near``, ``pass_workers``,
``break_jams`` and ``look_ahead`` act on when several are listed, and the geometry of
``single_lane``, ``standoff`` and ``backed_in``. Written for the gaps mutation run H found
(README, "Testing"); the rules in whole runs are in ``test_jobs.py`` and ``test_hardcases.py``.

Robots of radius 0.25 m, top speed 1.5 m/s; the planner keeps centres 0.35 m from obstacles.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.scenario import JamSpec
from sim.states import DRIVING, IDLE, WORKING
from tests.sim.test_jobs import AISLE, GAP, at, give, lane, orca_world, waypoints

# the settings' defaults (sim.scenario), under the names these tests use
AROUND_M = JamSpec().around_m
DEADLOCK_M = JamSpec().deadlock_m
PASS_S = JamSpec().pass_s
AHEAD_GROW_M = JamSpec().ahead_grow_m
PASS_EXTRA_M = JamSpec().pass_extra_m


V_MAX = 1.5  # m/s


def set_way(w, j: int, pts) -> None:
    """Give robot j the way ``pts`` (x + iy), standing on its first point."""
    pts = np.asarray(pts, dtype=complex)
    w.follower.set_path(j, np.column_stack([pts.real, pts.imag]))
    w.fleet.last_z_m[j] = pts[0]


# ---- waits, way_left_m ---------------------------------------------------------------------


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


# ---- look_ahead ------------------------------------------------------------------------------

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


# ---- standing_near -------------------------------------------------------------------------


def test_standing_near_lists_only_robots_standing_pass_s_since_their_last_progress():
    w = orca_world([(4.0, 5.0), (4.8, 5.0), (12.0, 5.0), (12.8, 5.0)])
    f = w.fleet
    give(w, [0, 1, 2, 3], [(16.0, 5.0), (2.0, 5.0), (16.0, 2.0), (2.0, 2.0)])
    t = at(w, 30.0)
    f.v_cmd_mps[:] = 0.0
    f.t_progress_s[:] = [t - PASS_S - 1.0, t - PASS_S + 0.5, t - PASS_S, t - 10.0]
    assert w.jobs.jams.standing_near(t) == [(0, 1), (2, 3), (3, 2)]


# ---- pass_workers ----------------------------------------------------------------------------


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


# ---- break_jams ------------------------------------------------------------------------------


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


# ---- single_lane, standoff -------------------------------------------------------------------


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


# ---- backed_in ---------------------------------------------------------------------------


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
