"""Path following (``sim.spatial.navigation.paths.PathFollower``): each number it keeps, against
geometry worked out another way.

Free widths against a brute-force distance between densely sampled segments and obstacle
outlines, path lengths and corner speeds against values worked by hand, the waypoint rules
against a robot put where each rule fires, and the batched computations against the
one-by-one exact ones, bit for bit (the capped widths and the Python nearest point against
their exact versions are in ``tests/parity/test_paths.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.scenario import (
    DriveSpec,
    FollowSpec,
)
from sim.spatial.controller import DiffDriveController
from sim.spatial.navigation.paths import SCALAR_FREE_MAX, PathFollower, _to_segment
from sim.spatial.navigation.widths import _gap

# the settings' defaults (sim.scenario), under the names these tests use
LOOKAHEAD_M = FollowSpec().lookahead_m
WAYPOINT_SWITCH_M = FollowSpec().waypoint_switch_m
R = 0.25
W, H = 20.0, 10.0
WALLS = [((0, 0), (W, 0)), ((W, 0), (W, H)), ((W, H), (0, H)), ((0, H), (0, 0))]
C = np.array([1.0, 1j])


def box(x, y, w=1.0, h=1.0):
    return ((x, y), (x + w, y), (x + w, y + h), (x, y + h))


OBSTACLES = [
    box(3.0, 2.0),
    box(8.0, 6.0, 2.0, 0.5),
    ((12.0, 4.0), (16.0, 4.5), (14.0, 8.0)),  # a triangle
    box(16.5, 1.0, 0.6, 2.0),
    ((6.0, 1.0), (7.5, 1.6)),  # a lone wall: a segment, its ends no other edge's
    *WALLS,
]


def outline(poly, step):
    """Points every ``step`` m or closer along a polygon's outline (a segment's, for two)."""
    p = np.asarray(poly, dtype=float) @ C
    ends = [(p[0], p[1])] if len(p) == 2 else list(zip(p, np.roll(p, -1), strict=True))
    out = [a + (b - a) * np.linspace(0, 1, int(abs(b - a) / step) + 2) for a, b in ends]
    return np.concatenate(out)


def brute_widths(a, b, obstacles, step=0.005):
    """Free width left and right of segment a -> b (complex): the least distance between points
    sampled along it and along each obstacle's outline, less R; an obstacle counts on the left
    if any of its outline is left of the segment's line, on the right if any is right of it."""
    seg = a + (b - a) * np.linspace(0, 1, int(abs(b - a) / step) + 2)
    unit = (b - a) / abs(b - a)
    left = right = np.inf
    for poly in obstacles:
        pts = outline(poly, step)
        dist = np.abs(seg[:, None] - pts[None]).min()
        side = ((pts - a) * unit.conjugate()).imag
        if side.max() > 0:
            left = min(left, dist)
        if side.min() < 0:
            right = min(right, dist)
    return max(left - R, 0.0), max(right - R, 0.0)


def free_segments(rng, n, obstacles, length=(0.5, 6.0)):
    """``n`` random segments in the arena that keep clear of every obstacle by more than R."""
    out = []
    while len(out) < n:
        a = complex(*rng.uniform((0.5, 0.5), (W - 0.5, H - 0.5)))
        b = a + rng.uniform(*length) * np.exp(1j * rng.uniform(-np.pi, np.pi))
        if not (0.3 < b.real < W - 0.3 and 0.3 < b.imag < H - 0.3):
            continue
        seg = a + (b - a) * np.linspace(0, 1, 200)
        if all(np.abs(seg[:, None] - outline(p, 0.02)[None]).min() > R for p in obstacles):
            out.append((a, b))
    return out


def test_free_widths_are_the_distance_to_the_nearest_obstacle_on_each_side_less_the_radius():
    """Array pass (many segment-edge pairs) and plain Python (few) both give the brute-force
    widths to within the sampling step, and each other's to 1e-12."""
    f = PathFollower(1, 1.5, OBSTACLES, R)
    segs = free_segments(np.random.default_rng(7), 40, OBSTACLES)
    a = np.array([s[0] for s in segs])
    b = np.array([s[1] for s in segs])
    assert len(a) * len(f.edge0_) > SCALAR_FREE_MAX  # the array pass
    array = f._free(a, b)
    one = np.array([f._free_one(p, q) for p, q in segs])
    np.testing.assert_allclose(array, one, rtol=0, atol=1e-12)
    for (p, q), got in zip(segs, array, strict=True):
        want = brute_widths(p, q, OBSTACLES)
        np.testing.assert_allclose(got, want, rtol=0, atol=0.006)
    assert (array < 1.0).sum() > 10 and np.isfinite(array).all()  # near obstacles, walls beyond


def test_an_obstacle_straddling_the_segment_s_line_bounds_both_sides():
    """A box ahead of the segment, across its line: it limits the width on both sides (at the
    distance from the segment's end), a box wholly to the left only the left width."""
    ahead = box(6.0, 4.5)  # the segment (1, 5) -> (5, 5) ends 1 m before it
    left = box(2.0, 6.0, 2.0, 1.0)  # 1 m above the segment
    f = PathFollower(1, 1.5, [ahead, left], R)
    (w_left, w_right) = f._free_one(1.0 + 5.0j, 5.0 + 5.0j)
    assert w_left == pytest.approx(1.0 - R) and w_right == pytest.approx(1.0 - R)
    g = PathFollower(1, 1.5, [left], R)
    assert g._free_one(1.0 + 5.0j, 5.0 + 5.0j) == (pytest.approx(1.0 - R), np.inf)
    pressed = PathFollower(1, 1.5, [left], 1.5)  # a radius beyond the gap: width 0, not < 0
    assert pressed._free_one(1.0 + 5.0j, 5.0 + 5.0j)[0] == 0.0
    point = PathFollower(1, 1.5, [left])  # radius 0 unless given: the distance itself
    assert point._free_one(1.0 + 5.0j, 5.0 + 5.0j)[0] == pytest.approx(1.0)


@pytest.mark.parametrize(
    ("p", "want"),
    [
        (2.0 + 1.0j, 1.0),  # beside the segment (0, 0) -> (4, 0): straight down to it
        (-3.0 + 4.0j, 5.0),  # before its start: to (0, 0)
        (7.0 - 4.0j, 5.0),  # beyond its end: to (4, 0)
        (4.0 + 0.0j, 0.0),
    ],
)
def test_point_to_segment_distance_by_hand(p, want):
    """Both helpers, in plain Python and compiled as numpy computes it, and with the segment
    reversed."""
    s0, s1 = 0.0 + 0.0j, 4.0 + 0.0j
    assert _to_segment(p, s0, s1) == pytest.approx(want, abs=1e-12)
    assert _to_segment(p, s1, s0) == pytest.approx(want, abs=1e-12)
    got = [_gap(p.real, p.imag, s0.real, s0.imag, s1.real, s1.imag)]
    got.append(_gap(p.real, p.imag, s1.real, s1.imag, s0.real, s0.imag))
    np.testing.assert_allclose(got, [want, want], rtol=0, atol=1e-12)
    assert _to_segment(p, 1.0 + 1.0j, 1.0 + 1.0j) == pytest.approx(abs(p - 1.0 - 1.0j))
    assert _gap(p.real, p.imag, 0.0, 1.0, 0.0, 1.0) == pytest.approx(
        abs(p - 1j)
    )  # a segment of no length: the distance to its point


def test_path_length_left_and_corner_speeds_are_those_worked_by_hand():
    """Path (1, 1) -> (4, 1) -> (4, 3) -> (1, 7) -> (1, 9): legs 3, 2, 5, 2 m. A corner's
    squared speed is (v cos^2)^2 of the turn's cosine: (4, 3) turns from (0, 2) to (-3, 4)
    and (1, 7) back, both cosine 0.8; (4, 1) turns 90 degrees and stops the robot."""
    v = 1.5
    f = PathFollower(2, v, WALLS, R)
    path = np.array([[1.0, 1.0], [4.0, 1.0], [4.0, 3.0], [1.0, 7.0], [1.0, 9.0]])
    assert f.set_path(1, path) == pytest.approx(12.0)
    np.testing.assert_allclose(f.after_m[1], [12.0, 9.0, 7.0, 2.0, 0.0])
    want = [0.0, 0.0, (v * 0.8**2) ** 2, (v * 0.8**2) ** 2, 0.0]
    np.testing.assert_allclose(f.corner2[1], want, rtol=1e-12, atol=1e-15)
    assert f.last[1] == 4 and f.index[1] == 1 and f.last[0] == -1
    assert f.tgt_[1] == 4.0 + 1.0j and f.seg_m_[1] == pytest.approx(3.0)
    assert f.unit_c_[1] == pytest.approx(1.0)  # conj. of +x
    assert f.after_[1] == pytest.approx(9.0) and f.switch_[1] == WAYPOINT_SWITCH_M
    short = np.array([[1.0, 1.0], [1.0, 3.0]])  # a shorter path after a longer one: padded
    f.set_path(1, short)
    assert f.last[1] == 1 and (f.points[1, 1:] == 1.0 + 3.0j).all()
    assert (f.after_m[1, 1:] == 0.0).all() and (f.corner2[1] == 0.0).all()
    assert f.switch_[1] == -1.0 and f.beyond_[1] == -np.inf  # the last waypoint: never passed
    assert f.unit_c_[1] == pytest.approx(-1j)


def test_a_straight_on_corner_keeps_full_speed_and_a_sharp_one_none():
    v = 1.2
    f = PathFollower(1, v, WALLS, R)
    f.set_path(0, np.array([[1.0, 1.0], [3.0, 1.0], [5.0, 1.0], [5.0 - 1.0, 1.0 + 1e-3]]))
    assert f.corner2[0, 1] == pytest.approx(v * v)
    assert f.corner2[0, 2] == 0.0  # almost straight back
    f.set_path(0, np.array([[1.0, 1.0], [1.4, 1.0], [1.8, 1.0], [2.0, 1.2]]))  # short legs
    np.testing.assert_allclose(f.corner2[0, 1:3], [v * v, (v * 0.5) ** 2], rtol=1e-9)
    f.set_path(0, np.array([[1.0, 1.0], [1.0, 1.0], [3.0, 1.0]]))  # a leg of no length
    assert f.corner2[0, 1] == 0.0 and f.after_m[0, 0] == pytest.approx(2.0)
    assert f.unit_c_[0] == 0.0 and f.seg_m_[0] == 0.0


def test_waypoints_are_passed_within_the_switch_distance_or_beyond_their_normal_line():
    """Robot 0 0.19 m short of its first waypoint, robot 1 0.21 m short and 0.1 m aside,
    robot 2 past the normal line 0.5 m aside, robot 3 at its final waypoint's normal line."""
    f = PathFollower(4, 1.5, WALLS, R)
    path = np.array([[1.0, 1.0], [5.0, 1.0], [5.0, 6.0]])
    for j in range(3):
        f.set_path(j, path)
    f.set_path(3, np.array([[1.0, 3.0], [5.0, 3.0]]))
    z = np.array([4.81 + 1.0j, 4.79 + 1.1j, 5.01 + 1.5j, 5.3 + 3.0j])
    aim, gap, left, corner2, off = f.targets(z)
    assert f.index.tolist() == [2, 1, 2, 1]
    assert aim[0] == pytest.approx(5.0 + 6.0j - z[0])
    assert aim[1] == pytest.approx(5.0 + 1.0j - z[1]) and gap[1] == pytest.approx(abs(aim[1]))
    assert left[1] == pytest.approx(gap[1] + 5.0)  # to the waypoint, then 5 m
    assert left[0] == pytest.approx(gap[0]) and corner2[0] == 0.0
    assert f.tgt_[3] == 5.0 + 3.0j  # the final waypoint is never passed
    assert off is None


TURNS = [0.0, np.arctan2(3.0, 4.0), 2.5, -1.2]  # the same scene turned: diagonal segments too


def turned(turn: float):
    """Points (x + iy) and polygons ((x, y), ...) of a scene turned by ``turn`` about (0, 0)."""
    rot = np.exp(1j * turn)

    def point(z):
        return np.asarray(z) * rot

    def poly(vertices):
        return [(w.real, w.imag) for w in (np.array(vertices) @ C) * rot]

    def path(points):
        return np.array([[w.real, w.imag] for w in (np.array(points) @ C) * rot])

    return rot, point, poly, path


@pytest.mark.parametrize("turn", TURNS)
def test_a_robot_off_its_free_width_aims_at_the_path_ahead_not_at_the_waypoint(turn):
    """Segment (1, 5) -> (15, 5) below a box 0.6 m above it (free width left 0.35 m): a
    robot 0.5 m to the left, 2 m along, aims at the path LOOKAHEAD_M on; 0.3 m to the left it
    aims at the waypoint; one LOOKAHEAD_M from the waypoint or closer aims at the waypoint.
    Its room in the lane: 0.15 m beyond the free width on the left, unbounded on the right.
    Turned by any angle, the same answers turned."""
    rot, point, poly, path = turned(turn)
    f = PathFollower(4, 1.5, [poly(box(2.0, 5.6, 12.0, 1.0))], R)
    for j in range(3):
        f.set_path(j, path([[1.0, 5.0], [15.0, 5.0]]))
    f.set_path(3, path([[-1.0, 3.0], [1.0, 5.0], [15.0, 5.0]]))  # passes (1, 5) in this call
    assert f.free_m[0, 1, 0] == pytest.approx(0.6 - R) and f.free_m[0, 1, 1] == np.inf
    z = point([3.0 + 5.5j, 3.0 + 5.3j, 14.0 + 5.5j, 3.0 + 5.5j])
    aim, gap, _, _, off = f.targets(z)
    assert off.tolist() == [0, 2, 3] and f.index[3] == 2
    assert aim[0] == pytest.approx(point(3.0 + LOOKAHEAD_M + 5.0j) - z[0])
    assert aim[3] == pytest.approx(aim[0]) and gap[3] == pytest.approx(gap[0])
    assert aim[1] == pytest.approx(point(15.0 + 5.0j) - z[1])
    assert aim[2] == pytest.approx(point(15.0 + 5.0j) - z[2])  # the look-ahead stops there
    assert gap[0] == pytest.approx(abs(12.0 - 0.5j))
    left, room_l, room_r = f.lane_room(z[:2], np.array([0, 1]))
    np.testing.assert_allclose(left, [1j * rot] * 2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(room_l, [0.35 - 0.5, 0.35 - 0.3], rtol=0, atol=1e-9)
    assert (room_r == np.inf).all()


@pytest.mark.parametrize("turn", TURNS)
def test_a_robot_drifts_when_its_stopping_point_leaves_the_free_width(turn):
    """Same segment and box: heading straight up at 1 m/s from 0.2 m left of the path, it
    stops 0.6 m (0.1 s reaction, 1 / (2 a) = 0.5) farther up: beyond 0.35 m; at 0.1 m/s it
    stops 0.015 m on, inside; heading down (toward no obstacle) it never drifts; backing up at
    1 m/s with heading down it does; at 0.4 m/s it stops 0.12 m on (0.32 m off, inside), at
    0.5 m/s 0.175 m on (0.375 m off, beyond). A robot without a path never drifts. Turned, the
    same."""
    rot, point, poly, path = turned(turn)
    f = PathFollower(7, 1.5, [poly(box(2.0, 5.6, 12.0, 1.0))], R)
    for j in range(6):
        f.set_path(j, path([[1.0, 5.0], [15.0, 5.0]]))
    z = np.full(7, point(6.0 + 5.2j))
    h = np.array([1j, 1j, -1j, -1j, 1j, 1j, 1j]) * rot
    v = np.array([1.0, 0.1, 1.0, -1.0, 0.4, 0.5, 1.0])
    assert f.drifting(z, h, v, 0.1, 0.5).tolist() == [0, 3, 5]
    assert f.drifting(z, h, 0.0 * v, 0.1, 0.5) is None
    f.clear(0)
    assert f.last[0] == -1 and f.index[0] == 0 and not f.capped_[:, 0].any()
    assert f.drifting(z, h, v, 0.1, 0.5).tolist() == [3, 5]
    *_, off = f.targets(np.full(7, point(6.0 + 9.0j)))
    assert off.tolist() == [1, 2, 3, 4, 5]  # robots 0 and 6 have no path: never off it
    assert f.index[0] == f.index[6] == 0  # ... and pass no waypoint


def test_several_paths_at_once_give_what_one_at_a_time_gives():
    """``set_paths`` (widths of all segments in one array pass, side steps capped first) and
    ``set_path`` robot by robot leave the same arrays, bit for bit, with and without cap_m."""
    rng = np.random.default_rng(3)
    many = [*OBSTACLES, *(box(x, 8.5, 0.4, 0.4) for x in np.arange(1.0, 19.0, 1.5))]
    assert len(PathFollower(1, 1.5, many, R).edge0_) > SCALAR_FREE_MAX  # one leg: array pass
    segs = free_segments(rng, 30, many, length=(0.3, 4.0))
    paths = []
    for k in range(0, 30, 3):  # ten paths: polylines of one to three legs
        legs = 1 + (k // 3) % 3
        pts = [segs[k][0], *[segs[k + i][1] for i in range(legs)]]
        paths.append(np.array([[p.real, p.imag] for p in pts]))
    for cap_m in (np.inf, 1.0):
        batch = PathFollower(10, 1.5, many, R, cap_m=cap_m)
        single = PathFollower(10, 1.5, many, R, cap_m=cap_m)
        lengths = batch.set_paths(list(range(10)), paths)
        assert lengths == [single.set_path(j, p) for j, p in enumerate(paths)]
        for name in ("points", "after_m", "corner2", "free_m", "capped_m", "last", "index"):
            np.testing.assert_array_equal(getattr(batch, name), getattr(single, name))
        assert batch.capped_m.any() == (cap_m < np.inf)


def test_capped_widths_are_the_exact_ones_up_to_the_cap():
    """A side step's widths with cap_m: min(exact, cap_m), flagged where the exact is more."""
    exact = PathFollower(1, 1.5, OBSTACLES, R)
    capped = PathFollower(1, 1.5, OBSTACLES, R, cap_m=0.8)
    for a, b in free_segments(np.random.default_rng(11), 60, OBSTACLES, length=(0.3, 1.2)):
        width = np.array(exact._free_one(a, b))
        got = capped._free_capped(a, b)
        if got is None:  # near every obstacle's box: no saving, computed exactly instead
            continue
        w, flags = got
        np.testing.assert_allclose(w, np.minimum(width, 0.8), rtol=0, atol=1e-12)
        assert list(flags) == (width > 0.8).tolist()


def test_the_nearest_obstacle_point_is_the_nearest_point_of_any_outline():
    f = PathFollower(1, 1.5, OBSTACLES, R)
    rng = np.random.default_rng(5)
    z = rng.uniform((0.1, 0.1), (W - 0.1, H - 0.1), size=(200, 2)) @ C
    pts = np.concatenate([outline(p, 0.004) for p in OBSTACLES])
    got = f.to_obstacle(z)
    want = np.array([np.abs(pts - p).min() for p in z])
    np.testing.assert_allclose(np.abs(got), want, rtol=0, atol=0.004)
    on = z + got  # the point found lies on an outline
    assert max(np.abs(pts - p).min() for p in on) < 0.004
    one = np.array([f.to_obstacle_one(p) for p in z.tolist()])  # plain Python, boxes skipped
    np.testing.assert_allclose(one, got, rtol=0, atol=1e-12)
    empty = PathFollower(1, 1.5, (), R)
    assert empty.to_obstacle(z[:3]).tolist() == [np.inf] * 3
    assert empty.to_obstacle_one(complex(z[0])) == complex(np.inf, 0.0)


def test_the_cached_lists_follow_every_change_of_the_arrays():
    f = PathFollower(3, 1.5, OBSTACLES, R)
    path = np.array([[1.0, 1.0], [2.0, 1.0], [2.0, 0.6]])
    f.set_path(0, path)
    lists = f.segment_lists()
    assert lists[0][:2] == [2.0 + 1.0j, 0j] and lists[1][0] == 1.0  # waypoints, conj. unit
    f.clear(0)  # the first change after the lists were made
    assert f.segment_lists()[2][0] == -1.0  # no path: no switch distance
    f.set_path(0, path)

    def arrays():
        return [
            f.tgt_,
            f.unit_c_,
            f.switch_,
            f.beyond_,
            f.free_[0],
            f.free_[1],
            f.after_,
            f.corner2_,
            f.seg_m_,
        ]

    f.set_path(1, path)
    assert f.segment_lists() == [a.tolist() for a in arrays()]
    f.targets(np.array([2.0 + 1.0j, 1.0 + 1.0j, 0j]))  # robot 0 at its first waypoint
    assert f.index[0] == 2 and f.segment_lists() == [a.tolist() for a in arrays()]
    f.clear(0)
    assert f.segment_lists() == [a.tolist() for a in arrays()]
    cached = f.segment_lists()
    f.index[1] += 1
    f.load_one(1)
    f.refresh_list_entry(1)
    assert cached == [a.tolist() for a in arrays()]
    assert f.segment_lists() is cached  # the entry copied in: nothing else to rebuild
    f.index[1] -= 1
    f.load_one(1)
    f.clear(2)  # two changes: the next call rebuilds
    f.refresh_list_entry(1)
    assert f.segment_lists() is not cached
    assert f.segment_lists() == [a.tolist() for a in arrays()]


def test_passing_waypoints_over_arrays_loads_what_one_robot_at_a_time_loads():
    """Robots driven along their paths: each time ``targets`` passes waypoints (``_load``, over
    the rows that passed), every current-segment entry equals what ``load_one`` gives that
    robot at the same waypoint; at the final waypoint nothing more is passed."""
    f = PathFollower(4, 1.5, OBSTACLES, R)
    paths = [
        [[1.0, 1.0], [2.5, 1.0], [2.5, 4.0], [6.0, 4.5]],
        [[1.0, 9.0], [1.0, 9.0], [4.0, 9.0]],  # a first leg of no length
        [[10.0, 1.0], [12.0, 1.5]],
        # a leg of no length in the middle, and one shorter than 1 m
        [[6.0, 8.0], [7.0, 8.0], [7.0, 8.0], [9.0, 8.0], [9.5, 8.3], [11.0, 9.0], [13.0, 9.0]],
    ]
    for j, p in enumerate(paths):
        f.set_path(j, np.array(p))
    names = ("tgt_", "unit_c_", "seg_m_", "after_", "corner2_", "switch_", "beyond_")
    passed = 0
    for _ in range(10):  # each robot put 0.1 m short of its waypoint: one passes per call
        z = f.tgt_ - 0.1 * f.unit_c_.conj()
        before = f.index.copy()
        f.targets(z)
        moved = np.flatnonzero(f.index != before)
        passed += len(moved)
        for j in range(4):
            one = PathFollower(4, 1.5, OBSTACLES, R)
            one.set_path(j, np.array(paths[j]))
            one.index[j] = f.index[j]
            one.load_one(j)
            for name in names:
                assert getattr(f, name)[j] == pytest.approx(getattr(one, name)[j], abs=1e-15)
            np.testing.assert_array_equal(f.free_[:, j], one.free_[:, j])
            np.testing.assert_array_equal(f.capped_[:, j], one.capped_[:, j])
    assert passed == sum(len(p) - 2 for p in paths)  # every waypoint but the first and last
    assert f.index.tolist() == [len(p) - 1 for p in paths]
    assert (f.switch_ == -1.0).all() and (f.beyond_ == -np.inf).all()


R = DriveSpec().radius_m


def test_a_robot_pushed_off_its_path_near_an_obstacle_heads_back_to_the_path():
    """Straight for the waypoint would cut the obstacle corner: the robot aims at the path ahead
    instead and its speed toward the obstacle is capped; on the path it aims at the waypoint."""
    box = ((5.0, 1.0), (7.0, 1.0), (7.0, 3.0), (5.0, 3.0))  # corner (5, 3)
    walls = [((0, 0), (20, 0)), ((20, 0), (20, 10)), ((20, 10), (0, 10)), ((0, 10), (0, 0))]
    f = PathFollower(2, 1.5, [box, *walls], R)
    for j in range(2):
        f.set_path(j, np.array([[1.0, 3.4], [12.0, 3.4]]))  # 0.4 m above the corner
    assert f.free_m[0, 1, 1] == pytest.approx(0.4 - R)  # right of the path: the box
    z = np.array([4.7 + 3.05j, 4.7 + 3.4j])  # robot 0 pushed 0.35 m toward the box
    aim, _, _, _, off = f.targets(z)
    assert off.tolist() == [0]
    assert aim[1] == pytest.approx(12.0 + 3.4j - z[1])  # on the path: the waypoint
    assert aim[0].imag > 0.3 and aim[0].real < 2.0  # off it: back to the path, close ahead
    to_box = f.to_obstacle(z[off])
    assert to_box[0] == pytest.approx(5.0 + 3.0j - z[0])  # the corner
    c = DiffDriveController(DriveSpec(), 0.1)
    heading = np.exp(-0.3j)  # straight for the waypoint: down and right, past the corner
    assert c.wall_cap(np.conj([heading]), np.array([1.5]), to_box)[0] < 0.5


def test_lane_room_is_the_room_left_within_the_free_width_of_the_segment():
    """A path along y = 3.4, 0.4 m above a box (right of the path) and 6.6 m below the top
    wall: a robot 0.1 m left of the path has 0.1 m less room on the left and 0.1 m more on the
    right than the free widths; the left unit points +y."""
    box = ((5.0, 1.0), (7.0, 1.0), (7.0, 3.0), (5.0, 3.0))
    walls = [((0, 0), (20, 0)), ((20, 0), (20, 10)), ((20, 10), (0, 10)), ((0, 10), (0, 0))]
    f = PathFollower(1, 1.5, [box, *walls], R)
    f.set_path(0, np.array([[1.0, 3.4], [12.0, 3.4]]))
    f.targets(np.array([1.0 + 3.4j]))  # load the segment into the first waypoint... then on
    left, room_l, room_r = f.lane_room(np.array([6.0 + 3.5j]), np.array([0]))
    assert left[0] == pytest.approx(1j)
    assert room_r[0] == pytest.approx(f.free_m[0, 1, 1] + 0.1)
    assert room_l[0] == pytest.approx(f.free_m[0, 1, 0] - 0.1)
    assert f.free_m[0, 1, 1] == pytest.approx(0.4 - R)


def test_obstacle_points_keep_every_face_in_reach_and_no_corner_of_a_face_beside():
    """``PathFollower.obstacle_points`` (the wall lines of ``[spatial.orca] wall_lines``) in a
    room 20 x 10 m with a 4 x 1 m box at (8, 4):

    - beside the box's long face near its end: the face's foot only (the corner it leads to is
      on the face's line; the box's far faces behind it);
    - in the room's corner: both walls;
    - in the 1 m gap between the box and a second box above it: both faces;
    - off the box's corner, beyond both faces: the corner, once (two edges give it);
    - in the open: nothing; and never more than ``count``, nearest first."""
    box = ((8.0, 4.0), (12.0, 4.0), (12.0, 5.0), (8.0, 5.0))
    above = ((8.0, 6.0), (12.0, 6.0), (12.0, 7.0), (8.0, 7.0))
    f = PathFollower(1, 1.5, [box, above, *WALLS], R)
    z = np.array([11.8 + 3.55j, 0.4 + 0.5j, 10.0 + 5.5j, 12.3 + 3.7j, 5.0 + 2.0j])
    got = f.obstacle_points(z, 1.2, 4)
    finite = np.isfinite(got)
    assert finite.sum(axis=1).tolist() == [1, 2, 2, 1, 0]
    np.testing.assert_allclose(got[0, 0], 0.45j, atol=1e-12)  # the face's foot, not (12, 4)
    np.testing.assert_allclose(sorted(got[1, :2], key=abs), [-0.4 + 0j, -0.5j], atol=1e-12)
    np.testing.assert_allclose(sorted(got[2, :2], key=lambda q: q.imag), [-0.5j, 0.5j], atol=1e-12)
    np.testing.assert_allclose(got[3, 0], (12.0 + 4.0j) - z[3], atol=1e-12)
    assert np.array_equal(got[:4, 0], f.to_obstacle(z[:4]))  # the nearest point first
    assert np.isfinite(f.obstacle_points(z[1:2], 1.2, 1)).sum() == 1
