"""The array controller (``sim.spatial.controller.DiffDriveController``) for the default robot, each
number worked out by hand from ``DriveSpec()`` and a 0.1 s control period.

DriveSpec(): radius 0.25 m, wheel base 0.4 m, wheels 0.08 m at up to 18.75 rad/s and 25 rad/s^2.
So: top speed 1.5 m/s, top turn 1.5 / 0.2 = 7.5 rad/s, a rim changes by at most 25 x 0.08 x 0.1
= 0.2 m/s a period, brakes 1 m/s^2 when steering to a stop; around robots and walls it plans to
brake at a = 0.75 x 2 = 1.5 m/s^2 after one period T = 0.1 s (a T = 0.15 m/s, 2 a = 3 m/s^2).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.scenario import DriveSpec, LawSpec
from sim.spatial.controller import VERLET_SKIN_M, DiffDriveController
from sim.spatial.world import PymunkWorld
from tests.worlds import crowd_scenario

# the settings' defaults (sim.scenario), under the names these tests use
HEADING_GAIN = LawSpec().heading_gain
KEEP_RIGHT_GAIN = LawSpec().keep_right_gain
EXACT = {"rel": 1e-12, "abs": 1e-12}


@pytest.fixture()
def c() -> DiffDriveController:
    return DiffDriveController(DriveSpec(), 0.1)


def cap(share_m: float, tau: float = 1.0) -> float:
    """The approach cap worked by hand: sqrt(2 a s / tau + (a T)^2) - a T, at least creep."""
    return max(math.sqrt(3.0 * share_m / tau + 0.15**2) - 0.15, 0.15 / tau)


def test_the_limits_and_distances_of_the_default_robot(c):
    assert (c.half_base_m, c.rim_max_mps, c.v_max_mps) == pytest.approx((0.2, 1.5, 1.5), **EXACT)
    assert c.rim_step_mps == pytest.approx(0.2, **EXACT)
    assert c.omega_max_radps == pytest.approx(7.5, **EXACT)
    assert c.brake_mps2 == pytest.approx(1.0, **EXACT)
    assert (c.radius_m, c.contact_m) == (0.25, 0.5)
    assert (c.yield_mps2, c.react_s) == pytest.approx((1.5, 0.1), **EXACT)
    # farther apart than contact + 2 x (v T + v^2 / 2a) = 0.5 + 2 x (0.15 + 0.75) no cap binds
    assert c.look_m == pytest.approx(2.3, **EXACT)
    assert c.keep_right_m == pytest.approx(1.1, **EXACT)
    assert c.dense_max == 64 and DiffDriveController(DriveSpec(), 0.1, 5).dense_max == 5
    assert DiffDriveController(DriveSpec(), 0.05).rim_step_mps == pytest.approx(0.1, **EXACT)


@pytest.mark.parametrize(
    ("aim_deg", "v", "omega"),
    [
        (0.0, 1.5, 0.0),  # aligned: top speed
        (30.0, 3.0 * math.cos(math.radians(30.0)) - 1.5, HEADING_GAIN * math.pi / 6),
        (60.0, 0.0, HEADING_GAIN * math.pi / 3),  # at the turn-in-place angle: no speed left
        (90.0, 0.0, HEADING_GAIN * math.pi / 2),  # beyond it: turns in place
        (-135.0, 0.0, -HEADING_GAIN * 3 * math.pi / 4),
    ],
)
def test_steer_slows_with_the_heading_error_and_turns_toward_the_aim(c, aim_deg, v, omega):
    heading = np.exp(1j * np.array([0.0, 1.0, -2.5]))  # three robots, each aiming the same way
    aim = 10.0 * heading * np.exp(1j * math.radians(aim_deg))
    got_v, got_w = c.steer(heading.conj(), aim, np.full(3, 10.0), np.zeros(3))
    assert got_v.tolist() == pytest.approx([v] * 3, abs=1e-12)
    assert got_w.tolist() == pytest.approx([omega] * 3, abs=1e-12)


def test_steer_brakes_to_reach_the_waypoint_at_its_corner_speed(c):
    hc = np.ones(3, dtype=complex)
    gap = np.array([0.5, 0.1, 0.1])
    corner2 = np.array([0.0, 0.81, 4.0])
    v, w = c.steer(hc, gap + 0j, gap, corner2)
    # sqrt(2 x 1 m/s^2 x gap + corner^2), at most what the heading allows (1.5)
    assert v.tolist() == pytest.approx([1.0, math.sqrt(1.01), 1.5], **EXACT)
    assert w.tolist() == [0.0, 0.0, 0.0]


def test_wall_cap_lets_a_robot_stop_within_the_gap_to_the_wall(c):
    hc = np.ones(6, dtype=complex)  # all head +x
    to_wall = np.array([1.0, -1.0, -1.0, -1.0, 0.25, 1.0 + 1.0j])  # from the robot centre
    v = np.array([1.5, 1.5, -1.0, -1.5, 1.5, 1.5])
    got = c.wall_cap(hc, v, to_wall)
    expect = [
        cap(0.75),  # 1 m ahead, 0.75 m beyond the radius
        1.5,  # the wall is behind: free
        -1.0,  # backing toward it slower than the cap
        -cap(0.75),  # backing toward it faster
        0.15,  # touching: the creep speed
        min(1.5, cap(math.sqrt(2.0) - 0.25, 1.0 / math.sqrt(2.0))),  # 45 degrees off, 1.41 m
    ]
    assert got.tolist() == pytest.approx(expect, **EXACT)
    assert cap(0.75) == pytest.approx(math.sqrt(2.2725) - 0.15, **EXACT)


def test_proximity_shares_the_gap_between_two_robots_closing_head_on(c):
    # robot 0 at x = 0 heading +x had 1 m/s; robot 1 at x = 1 heading -x stood; robot 2 far off
    z = np.array([0.0, 1.0, 10.0 + 10.0j])
    hc = np.array([1.0, -1.0, 1.0], dtype=complex)
    v = np.array([1.5, 1.5, 1.5])
    v_prev = np.array([1.0, 0.0, 1.5])
    got, blocker, near, apart = c.proximity(z, hc, v, v_prev)
    # gap 0.5 m; robot 0 needs (T + v / 2a) x 1 m/s = 0.1 + 1/3 s x 1 m/s to stop toward 1
    need = 0.1 + 1.0 / 3.0
    first = (0.5 + need) / 2.0  # robot 1 needs nothing: 0 gets half the room left with its own
    second = (0.5 - need) / 2.0  # robot 1 leaves 0 its need and half of what is left
    assert got.tolist() == pytest.approx([cap(first), cap(second), 1.5], **EXACT)
    assert cap(second) == pytest.approx(0.2, **EXACT) and cap(first) < 1.5
    assert blocker.tolist() == [1, 0, -1]
    assert near.tolist() == [1.0, 1.0, math.inf]
    assert apart == 1.0


def test_proximity_leaves_robots_moving_apart_or_sideways_alone(c):
    z = np.array([0.0, 1.0, 1.0 + 1.2j])
    hc = np.array([1.0, 1.0, 1.0], dtype=complex)  # all head +x
    v = np.array([-1.0, 1.5, 1.5])  # 0 backs away from 1; 1 drives away from 0; 2 is abeam
    got, blocker, near, _ = c.proximity(z, hc, v, np.array([1.0, 1.0, 1.0]))
    assert got.tolist() == [-1.0, 1.5, 1.5]
    assert blocker.tolist() == [-1, -1, -1] and np.isinf(near).all()


def test_proximity_is_skipped_when_every_pair_is_farther_than_look_m(c):
    z = np.array([0.0, 2.3 + 1e-9, 10.0j])
    out = c.proximity(z, np.ones(3, dtype=complex), np.ones(3), np.ones(3))
    assert out[:3] == (None, None, None) and out[3] == pytest.approx(2.3)
    assert c.proximity(z[:1], np.ones(1), np.ones(1), np.ones(1)) == (None, None, None, np.inf)


def test_proximity_from_the_neighbour_list_equals_the_dense_one(c):
    listed = DiffDriveController(DriveSpec(), 0.1, dense_max=0)
    z = np.array([0.0, 1.0, 10.0 + 10.0j, 1.5j])
    hc = np.array([1.0, -1.0, 1.0, 1j], dtype=complex)
    v, v_prev = np.array([1.5, 1.5, 1.5, 0.0]), np.array([1.0, 0.0, 1.5, 0.0])
    dense = c.proximity(z, hc, v, v_prev)
    pairs = listed.proximity(z, hc, v, v_prev)
    for a, b in zip(dense[:3], pairs[:3], strict=True):
        assert np.array_equal(a, b)
    assert pairs[3] == 0.0  # the least distance is not known from the list
    far = listed.proximity(z * 10.0, hc, v, v_prev)  # no pair within look_m + skin
    assert far == (None, None, None, listed.look_m)


def test_keep_right_turns_right_round_a_robot_not_going_our_way(c):
    th = np.array([0.0, math.pi, 0.0, 0.2, 0.0, 0.3])
    w = np.array([0.3, 0.0, 0.0, 0.0, 0.1, 0.0])
    blocker = np.array([1, 0, 3, -1, 5, 4])
    near = np.array([1.0, 1.0, 1.0, np.inf, 1.2, 1.2])
    moving = np.array([True, True, True, True, True, False])
    got = c.keep_right(th, w, blocker, near, moving)
    turn = KEEP_RIGHT_GAIN * 7.5
    # 0 and 1 head-on within 1.1 m: both veer; 2 follows 3, which goes its way: no;
    # 4 and 5 are 1.2 m apart, beyond the 1.1 m: no
    assert got.tolist() == pytest.approx([0.3 - turn, -turn, 0.0, 0.0, 0.1, 0.0], **EXACT)
    moving[3] = False  # 3 stands: 2 goes round it
    assert c.keep_right(th, w, blocker, near, moving)[2] == pytest.approx(-turn, **EXACT)


def test_limit_changes_each_rim_by_at_most_a_step_a_period(c):
    z = np.zeros(3)
    # from rest at top speed; a twist over the top speed is scaled down as a whole; turning
    v, w, q = c.limit(np.array([1.5, 3.0, 1.5]), np.array([0.0, 0.0, 7.5]), z, z)
    assert v.tolist() == pytest.approx([0.2, 0.2, 0.1], **EXACT)
    assert q.tolist() == pytest.approx([0.0, 0.0, 0.1], **EXACT)
    assert w.tolist() == pytest.approx([0.0, 0.0, 0.5], **EXACT)
    v, w, q = c.limit(np.array([3.0]), np.array([0.0]), np.array([1.5]), np.zeros(1))
    assert v.tolist() == [1.5] and q.tolist() == [0.0]  # at top speed already


def test_limit_brakes_first_and_turns_with_what_is_left(c):
    v0, q0 = np.array([1.5]), np.zeros(1)
    v, _, q = c.limit(np.array([0.0]), np.array([7.5]), v0, q0)
    assert v.tolist() == pytest.approx([1.3], **EXACT) and q.tolist() == [0.0]


def test_limit_under_avoidance_slows_a_fast_turn_first_unless_orca_set_it(c):
    v0, q0 = np.array([0.5, 0.5]), np.array([0.6, 0.6])  # turning at 3 rad/s
    want_v, want_w = np.array([1.5, 1.5]), np.zeros(2)
    v, _, q = c.limit(want_v, want_w, v0, q0, turn_first=True)
    assert v.tolist() == pytest.approx([0.5, 0.5], **EXACT)
    assert q.tolist() == pytest.approx([0.4, 0.4], **EXACT)
    v, _, q = c.limit(want_v, want_w, v0, q0, turn_first=True, orca=np.array([1]))
    assert v.tolist() == pytest.approx([0.5, 0.7], **EXACT)
    assert q.tolist() == pytest.approx([0.4, 0.6], **EXACT)
    v, _, q = c.limit(want_v, want_w, v0, q0)
    assert v.tolist() == pytest.approx([0.7, 0.7], **EXACT)
    slow = c.limit(want_v, want_w, v0, np.array([0.19, 0.19]), turn_first=True)  # < 1 rad/s
    assert slow[0].tolist() == pytest.approx([0.7, 0.7], **EXACT)


def test_neighbour_pairs_are_rebuilt_once_a_robot_moved_half_the_skin(c):
    reach = c.look_m + VERLET_SKIN_M
    z = np.array([0.0, reach - 0.01, 3.0 * reach])
    i, k = c.neighbour_pairs(z)
    assert sorted(zip(i.tolist(), k.tolist(), strict=True)) == [(0, 1), (1, 0)]
    kept = c.neighbour_pairs(z + np.array([0.0, 0.0, 0.5 * VERLET_SKIN_M - 0.01]))
    assert kept[0] is i  # reused
    moved = z + np.array([0.0, 0.0, -(2.0 * reach - 0.02)])  # 2 now within reach of 1
    fresh = c.neighbour_pairs(moved)
    assert fresh[0] is not i
    assert sorted(zip(*(a.tolist() for a in fresh), strict=True)) == [
        (0, 1),
        (1, 0),
        (1, 2),
        (2, 1),
    ]
    c.forget_neighbours()
    assert len(c.verlet_z_) == 0 and c.neighbour_pairs(moved)[0] is not fresh[0]


def test_diag_inf_is_inf_on_the_diagonal_and_kept_for_the_same_size(c):
    d = c.diag_inf(3)
    assert np.isinf(np.diag(d)).all() and (d[~np.eye(3, dtype=bool)] == 0).all()
    assert c.diag_inf(3) is d and c.diag_inf(4).shape == (4, 4)


# -- the cases the first tests left open (a mutation screen found them) ----------------------
def test_proximity_of_two_robots_at_any_angle_when_the_other_drives_away(c):
    """Robot 0 drives at robot 1 (1.5 m off, up and right); robot 1 drives away from it at
    1 m/s, heading +y: it would brake over (1 x 0.8)^2 / (2 x 2 m/s^2) = 0.16 m more."""
    off = 5.0 - 3.0j  # away from the origin: a sum of positions is not their difference
    rel = 0.9 + 1.2j
    z = np.array([off, off + rel])
    hc = np.array([abs(rel) / rel, -1j])  # 0 heads at 1, 1 heads +y
    got, blocker, near, apart = c.proximity(z, hc, np.array([1.5, 1.5]), np.array([1.0, 1.0]))
    away = 0.8  # robot 1's speed away from robot 0 along the line between them
    mine = 1.0 * (0.1 + 1.0 / 3.0)
    share = min(1.0 + away**2 / 4.0, (1.0 + away**2 / 4.0 + mine) / 2.0)  # gap 1.5 - 0.5
    assert got.tolist() == pytest.approx([cap(share), 1.5], **EXACT)
    assert blocker.tolist() == [1, -1] and near[0] == pytest.approx(1.5, **EXACT)
    assert apart == pytest.approx(1.5, **EXACT)
    two = DiffDriveController(DriveSpec(), 0.1, dense_max=2)  # two robots: still all pairs
    assert two.proximity(z, hc, np.array([1.5, 1.5]), np.array([1.0, 1.0]))[3] == apart


def test_proximity_gives_an_overlapping_pair_the_room_the_other_leaves(c):
    z = np.array([2.0, 2.4])  # 0.1 m into each other
    hc = np.ones(2, dtype=complex)  # both head +x: 0 follows 1, which drives away at 1 m/s
    got, *_ = c.proximity(z, hc, np.array([1.5, 1.5]), np.array([1.0, 1.0]))
    mine = 0.1 + 1.0 / 3.0
    assert got[0] == pytest.approx(cap(min(0.25, (0.25 + mine) / 2.0)), **EXACT)


def test_proximity_of_a_robot_closing_faster_than_the_gap_allows_is_the_creep_speed(c):
    z = np.array([1.0, 2.0])
    hc = np.array([1.0, -1.0], dtype=complex)
    got, *_ = c.proximity(z, hc, np.array([1.5, 1.5]), np.array([0.0, 1.5]))
    assert got[0] == pytest.approx(0.15, **EXACT)  # robot 1 needs 0.9 m of the 0.5 m gap


def test_proximity_ignores_a_committed_speed_away_from_the_other(c):
    z = np.array([1.0, 2.0])
    hc = np.array([1.0, -1.0], dtype=complex)
    backed = c.proximity(z, hc, np.array([1.5, 0.0]), np.array([-0.5, 0.0]))[0]
    stood = c.proximity(z, hc, np.array([1.5, 0.0]), np.array([0.0, 0.0]))[0]
    assert backed[0] == stood[0] == pytest.approx(cap(0.25), **EXACT)  # half the 0.5 m gap


def test_the_robot_in_the_way_is_the_nearest_ahead(c):
    z = np.array([0.0, 1.5, 0.8, 0.5 + 1.2j])
    hc = np.ones(4, dtype=complex)
    _, blocker, near, _ = c.proximity(z, hc, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(4))
    assert blocker.tolist() == [2, -1, -1, -1] and near[0] == 0.8


def test_exactly_look_m_apart_no_pair_is_looked_at(c):
    z = np.array([0.0, c.look_m])
    hc = np.array([1.0, -1.0], dtype=complex)
    v = np.array([1.5, 1.5])
    assert c.proximity(z, hc, v, v)[:3] == (None, None, None)
    listed = DiffDriveController(DriveSpec(), 0.1, dense_max=0)
    for gap in (c.look_m, c.look_m + 0.5):  # in the neighbour list, beyond look_m
        got, blocker, near, _ = listed.proximity(np.array([0.0, gap]), hc, v, v)
        assert got.tolist() == [1.5, 1.5] and blocker.tolist() == [-1, -1]
        assert np.isinf(near).all()


def test_the_neighbour_list_keeps_robots_at_exactly_1_m_per_s(c):
    listed = DiffDriveController(DriveSpec(), 0.1, dense_max=0)
    z = np.array([1.0, 2.0])
    hc = np.array([1.0, -1.0], dtype=complex)
    v = np.array([1.0, 0.0])
    assert listed.proximity(z, hc, v, v)[1].tolist() == [1, -1]


def test_wall_cap_is_the_same_in_any_frame_and_leaves_a_standing_robot_standing(c):
    h = np.exp(0.7j)  # the first wall test turned by 0.7 rad
    to_wall = np.array([1.0, -1.0, 0.25, 1.0 + 1.0j, 1.0]) * h
    v = np.array([1.5, -1.5, 1.5, 1.5, 0.0])
    got = c.wall_cap(np.full(5, h.conjugate()), v, to_wall)
    expect = [cap(0.75), -cap(0.75), 0.15, min(1.5, cap(math.sqrt(2.0) - 0.25, 0.5**0.5)), 0.0]
    assert got.tolist() == pytest.approx(expect, rel=1e-12, abs=1e-12)


def test_steer_brakes_at_the_robot_s_own_deceleration():
    quick = DiffDriveController(DriveSpec(max_wheel_accel_radps2=50.0), 0.1)  # brakes 2 m/s^2
    v, _ = quick.steer(
        np.ones(1, dtype=complex), np.array([0.5 + 0j]), np.array([0.5]), np.zeros(1)
    )
    assert v.tolist() == pytest.approx([math.sqrt(2.0)], **EXACT)


def test_keep_right_only_inside_keep_right_m(c):
    th, w = np.array([0.0, math.pi]), np.zeros(2)
    got = c.keep_right(th, w, np.array([1, 0]), np.full(2, c.keep_right_m), np.ones(2, bool))
    assert got.tolist() == [0.0, 0.0]


def test_limit_does_not_speed_a_slow_command_up(c):
    z = np.zeros(2)
    v, w, _ = c.limit(np.array([0.1, 0.05]), np.array([0.0, 0.25]), z, z)
    assert v.tolist() == pytest.approx([0.1, 0.05], **EXACT)
    assert w.tolist() == pytest.approx([0.0, 0.25], **EXACT)


def test_limit_brakes_first_backing_up_and_turning_and_leaves_the_others_alone(c):
    v0 = np.array([-1.5, 1.0, 0.2])
    q0 = np.array([0.0, 0.0, 0.0])
    want_v = np.array([0.0, 0.9, 1.5])  # 0 stops backing, 1 slows a little and turns, 2 speeds up
    want_w = np.array([0.0, -0.75, 2.5])
    v, _, q = c.limit(want_v, want_w, v0, q0)
    # 0: +0.2 m/s; 1: -0.1 m/s leaves 0.1 m/s of the rim step for the turn, q = -0.15 -> -0.1;
    # 2: right rim +0.2, left rim +0.2 - 0.5 clipped to -0.2 + ... each on its own
    assert v.tolist() == pytest.approx([-1.3, 0.9, 0.4], **EXACT)
    assert q.tolist() == pytest.approx([0.0, -0.1, 0.0], **EXACT)


def test_turn_first_takes_the_turn_s_slowing_against_the_ceiling_of_the_rims(c):
    # q0 = 0.6 (3 rad/s); v 1.5 and 4.5 rad/s want rims 2.4 m/s: scaled by 1.6 the turn slows
    v, _, q = c.limit(np.array([1.5]), np.array([4.5]), np.array([0.5]), np.array([0.6]), True)
    assert v.tolist() == pytest.approx([0.5 + 0.2 - 0.0375], **EXACT)
    assert q.tolist() == pytest.approx([0.5625], **EXACT)


def test_turn_first_is_for_slowing_a_turn_not_for_speeding_it_up(c):
    fast = c.limit(np.array([1.0]), np.array([5.0]), np.array([0.5]), np.array([0.6]), True)
    free = c.limit(np.array([1.0]), np.array([5.0]), np.array([0.5]), np.array([0.6]))
    assert fast[0].tolist() == free[0].tolist() and fast[2].tolist() == free[2].tolist()
    assert fast[2].tolist() == pytest.approx([0.65], **EXACT)  # right +0.2, left +0.1


def test_turn_first_holding_speed_slows_the_turn_only(c):
    v, _, q = c.limit(np.array([0.5]), np.array([2.5]), np.array([0.5]), np.array([0.6]), True)
    assert v.tolist() == pytest.approx([0.5], **EXACT) and q.tolist() == pytest.approx([0.5])


def test_turn_first_for_some_robots_leaves_the_others_wheels_alone(c):
    v0, q0 = np.array([0.5, 0.5]), np.array([0.6, 0.0])
    v, _, q = c.limit(np.array([0.5, 0.5]), np.array([2.5, 0.5]), v0, q0, turn_first=True)
    assert v.tolist() == pytest.approx([0.5, 0.5], **EXACT)
    assert q.tolist() == pytest.approx([0.5, 0.1], **EXACT)


def test_neighbour_pairs_are_rebuilt_at_exactly_half_the_skin(c):
    z = np.array([0.0, 1.0])
    first = c.neighbour_pairs(z)
    assert c.neighbour_pairs(np.array([0.0, 1.0 + 0.5 * VERLET_SKIN_M]))[0] is not first[0]


def test_turn_first_and_braking_write_only_their_own_robots_wheels(c):
    # 0 slows a fast turn (q0 = -0.6 -> -0.5) while speeding up: turn first takes 0.1 of the
    # rim step for the turn and leaves 0.1 for the speed; 1 and 2 start turning from rest
    v0, q0 = np.array([0.5, 0.0, 0.0]), np.array([-0.6, 0.0, 0.0])
    want_v, want_w = np.array([0.7, 0.1, 0.1]), np.array([-2.5, 1.0, -1.0])
    v, _, q = c.limit(want_v, want_w, v0, q0, turn_first=True)
    assert v.tolist() == pytest.approx([0.6, 0.05, 0.05], **EXACT)
    assert q.tolist() == pytest.approx([-0.5, 0.15, -0.15], **EXACT)
    # 0 brakes (1.0 -> 0.9), 1 and 2 as above: each rim of 1 and 2 on its own
    v0[0], q0[0] = 1.0, 0.0
    want_v[0], want_w[0] = 0.9, 0.0
    v, _, q = c.limit(want_v, want_w, v0, q0)
    assert v.tolist() == pytest.approx([0.9, 0.05, 0.05], **EXACT)
    assert q.tolist() == pytest.approx([0.0, 0.15, -0.15], **EXACT)


def test_turn_first_only_above_1_rad_per_s(c):
    at = c.limit(np.array([1.5]), np.zeros(1), np.array([0.5]), np.array([0.2]), True)
    assert at[0].tolist() == pytest.approx([0.7], **EXACT)  # q0 = 0.2 m/s is exactly 1 rad/s


def test_wall_cap_of_a_standing_robot_beside_a_wall(c):
    got = c.wall_cap(np.ones(1, dtype=complex), np.zeros(1), np.array([0.5j]))  # exactly abeam
    assert got.tolist() == [0.0]


def test_the_controller_keeps_the_robot_it_drives(c):
    assert c.drive == DriveSpec()


def test_a_reversal_at_the_same_speed_is_not_braking(c):
    """|v| does not fall from 0.5 m/s forward to 0.5 m/s back: each rim goes on its own."""
    v, _, q = c.limit(np.array([-0.5]), np.array([2.5]), np.array([0.5]), np.array([-0.5]))
    assert v.tolist() == pytest.approx([0.4], **EXACT) and q.tolist() == pytest.approx([-0.4])


def test_under_avoidance_a_fast_turn_that_must_slow_takes_the_wheels_first():
    """DiffDriveController.limit with ``turn_first``: a robot turning faster than
    ``turn_first_radps`` that is told to stop turning while speeding up slows its turn by the full
    rim step and keeps its speed; a slower turn, a turn that grows, a robot ORCA steers, or the
    law without avoidance share the step between the wheels as before."""
    c = PymunkWorld(crowd_scenario()).controller
    s, hb = c.rim_step_mps, c.half_base_m
    q_fast, q_slow = 2.5 * hb, 0.99 * c.turn_first_radps * hb
    v0 = np.array([0.5, 0.5, 0.5, 0.5])
    q0 = np.array([q_fast, q_slow, q_fast, q_fast])
    want_v = np.full(4, 1.0)
    want_w = np.array([0.0, 0.0, 3.0, 0.0])  # robot 2's turn grows
    v, _, q = c.limit(want_v, want_w, v0, q0, True, np.array([3]))
    assert v[0] == 0.5 and q[0] == pytest.approx(q_fast - s, abs=1e-12)
    old_v, _, old_q = c.limit(want_v, want_w, v0, q0)
    assert old_v[0] > 0.5 and old_q[0] > q_fast - s  # without: speed first, turn lingers
    np.testing.assert_array_equal(v[1:], old_v[1:])
    np.testing.assert_array_equal(q[1:], old_q[1:])
