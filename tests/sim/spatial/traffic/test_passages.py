"""``sim.spatial.traffic.geometry`` and ``passages``: passages found from the geometry, with
exact numbers on hand-built arenas.

Robots of radius 0.25 m, ORCA margin 0.05 m, clearance 0.1 m: two lanes are 1.4 m, one lane
beside a robot at work 0.7 m, and no robot centre fits a gap of 0.7 m or less.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.spatial.traffic.geometry import (
    as_complex,
    clip_line,
    clip_segments,
    disc_polygon,
    polygon_gap,
    walls,
)
from sim.spatial.traffic.passages import (
    Passage,
    find_passages,
    lane_m,
    pair_passage,
    two_lanes_m,
    worker_passage,
)
from tests.golden.cases import in_baseline_child

R, MARGIN, CLEAR = 0.25, 0.05, 0.1
TWO_LANES = two_lanes_m(R, MARGIN, CLEAR)
LANE = lane_m(R, MARGIN, CLEAR)
MIN_GAP = 2 * (R + CLEAR)


def box(x0, y0, x1, y1):
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def test_lane_widths_follow_from_the_robot_the_margin_and_the_clearance():
    assert TWO_LANES == pytest.approx(1.4)
    assert LANE == pytest.approx(0.7)


def test_polygon_gap_of_two_squares_and_of_touching_ones():
    a, b = as_complex(box(0, 0, 1, 1)), as_complex(box(3, 0.5, 4, 1.5))
    gap, p, q = polygon_gap(a, b)
    assert gap == pytest.approx(2.0)
    assert p.real == pytest.approx(1.0) and q.real == pytest.approx(3.0)
    assert p.imag == pytest.approx(q.imag)
    assert polygon_gap(a, as_complex(box(0.5, 0.5, 2, 2)))[0] == 0.0  # overlapping


def test_clip_line_through_a_square_and_past_it():
    sq = as_complex(box(1, 1, 3, 2))
    assert clip_line(0 + 1.5j, 1 + 0j, sq) == pytest.approx((1.0, 3.0))
    lo, hi = clip_line(0 + 5j, 1 + 0j, sq)
    assert lo > hi


def test_clip_segments_gives_the_part_inside_a_rectangle():
    a = np.array([-2 + 0j, -2 + 2j, 0 + 0j])
    b = np.array([2 + 0j, 2 + 2j, 0.5 + 0j])
    t0, t1 = clip_segments(a, b, 0j, 1 + 0j, 1.0, 0.5)
    assert t0[0] == pytest.approx(0.25) and t1[0] == pytest.approx(0.75)
    assert t0[1] > t1[1]  # passes above it
    assert (t0[2], t1[2]) == (0.0, 1.0)  # wholly inside


def test_the_warehouse_cross_aisle_gap_is_a_passage_one_metre_long_and_wide():
    """Two shelf ends 1 m apart (x 9.5 and 10.5, y 7..8)."""
    found = find_passages([box(3, 7, 9.5, 8), box(10.5, 7, 17, 8)], 30, 20, TWO_LANES, MIN_GAP)
    assert len(found) == 1
    p = found[0]
    assert p.centre == pytest.approx(10 + 7.5j)
    assert abs(p.axis.imag) == pytest.approx(1.0)
    assert (p.half_length_m, p.half_width_m, p.gap_m) == pytest.approx((0.5, 0.5, 1.0))
    assert p.worker == -1 and p.passable


@pytest.mark.parametrize(("gap_m", "found"), [(0.6, 0), (0.9, 1), (1.39, 1), (1.4, 0), (1.6, 0)])
def test_only_gaps_a_robot_fits_and_two_cannot_pass_in_are_passages(gap_m, found):
    shelves = [box(3, 7, 10 - gap_m / 2, 8), box(10 + gap_m / 2, 7, 17, 8)]
    assert len(find_passages(shelves, 30, 20, TWO_LANES, MIN_GAP)) == found


def test_a_gap_filled_by_a_third_obstacle_is_no_passage():
    """A wall in three convex pieces (as a map's walls are): the end pieces face each other
    1 m apart across the middle one, which fills that gap; a pillar that leaves less than a
    robot each side fills it too; a block beside the gap, not in it, leaves it a passage."""
    ends = [box(3, 7, 9.5, 8), box(10.5, 7, 17, 8)]
    assert find_passages([*ends, box(9.5, 7, 10.5, 8)], 30, 20, TWO_LANES, MIN_GAP) == ()
    assert len(find_passages(ends, 30, 20, TWO_LANES, MIN_GAP)) == 1
    nearly = [*ends, box(9.9, 7.3, 10.1, 7.7)]  # a pillar in the gap leaves 0.4 m each side
    assert find_passages(nearly, 30, 20, TWO_LANES, MIN_GAP) == ()
    below = [*ends, box(8.0, 5.0, 12.0, 6.0)]  # 1 m below the pieces, not in their gap
    found = find_passages(below, 30, 20, TWO_LANES, MIN_GAP)
    assert len(found) == 3  # the gap between the ends, and one under each end
    assert sorted(round(p.centre.imag, 6) for p in found) == [6.5, 6.5, 7.5]


def test_an_obstacle_near_the_arena_wall_makes_a_corridor_along_it():
    """A 4 m long block 1 m from the bottom wall: a passage 4 m long between them."""
    found = find_passages([box(3, 1, 7, 2)], 12, 8, TWO_LANES, MIN_GAP)
    assert len(found) == 1
    p = found[0]
    assert p.centre == pytest.approx(5 + 0.5j)
    assert abs(p.axis.real) == pytest.approx(1.0)
    assert p.half_length_m == pytest.approx(2.0, abs=1e-3)
    assert p.gap_m == pytest.approx(1.0)


def test_a_wedge_gap_ends_where_it_reaches_two_lanes():
    tri = [(5.0, 1.0), (7.0, 2.0), (3.0, 2.0)]  # tip 1 m above the wall, sides rise 1 in 2
    p = pair_passage(as_complex(tri), walls(12, 8)[0], TWO_LANES, MIN_GAP)
    assert p.gap_m == pytest.approx(1.0)
    # the gap reaches 1.4 m where the sides have risen 0.4 m: 0.8 m either side of the tip
    assert p.half_length_m == pytest.approx(0.8, abs=1e-3)
    assert p.centre.real == pytest.approx(5.0, abs=1e-3)


def test_a_robot_at_work_in_the_middle_of_a_two_metre_aisle_leaves_a_lane_each_side():
    shelves = [as_complex(box(1, 4, 15, 5)), as_complex(box(1, 7, 15, 8))]
    p = worker_passage(3, 8 + 6j, R, shelves, np.zeros(0, complex), TWO_LANES, LANE)
    assert p is not None and p.worker == 3 and p.passable
    assert p.centre == pytest.approx(8 + 6j)
    assert abs(p.axis.real) == pytest.approx(1.0)  # along the aisle
    assert p.half_width_m == pytest.approx(1.0)  # across the whole aisle
    assert p.gap_m == pytest.approx(0.75)


@pytest.mark.parametrize("y", [5.8, 6.2])
def test_a_robot_at_work_off_the_middle_of_an_aisle_makes_a_passage_across_the_whole_aisle(y):
    """Nearer one shelf (0.55 m of room on that side, 0.95 m on the other, or the mirror): the
    passage is still centred on the aisle and spans it; the wider side is its room."""
    shelves = [as_complex(box(1, 4, 15, 5)), as_complex(box(1, 7, 15, 8))]
    p = worker_passage(1, 8 + y * 1j, R, shelves, np.zeros(0, complex), TWO_LANES, LANE)
    assert p is not None and p.passable
    assert p.centre == pytest.approx(8 + 6j)
    assert p.half_width_m == pytest.approx(1.0)
    assert p.gap_m == pytest.approx(0.95)


def test_a_robot_at_work_that_leaves_no_lane_closes_the_aisle():
    shelves = [as_complex(box(1, 4, 15, 5)), as_complex(box(1, 6.2, 15, 7))]  # 1.2 m aisle
    p = worker_passage(0, 8 + 5.6j, R, shelves, np.zeros(0, complex), TWO_LANES, LANE)
    assert p is not None and not p.passable
    assert p.centre == pytest.approx(8 + 5.6j)


def test_another_robot_at_work_across_the_aisle_counts_as_a_wall():
    """In a 4 m aisle one robot at work leaves two lanes; with another at work across from
    it, 1.3 m from it, the two leave one lane between them."""
    shelves = [as_complex(box(1, 4, 15, 5)), as_complex(box(1, 9, 15, 10))]
    alone = worker_passage(0, 8 + 5.6j, R, shelves, np.zeros(0, complex), TWO_LANES, LANE)
    assert alone is None
    pair = worker_passage(0, 8 + 5.6j, R, shelves, np.array([8 + 6.9j]), TWO_LANES, LANE)
    assert pair is not None and pair.passable


def test_a_robot_at_work_on_open_floor_makes_no_passage():
    assert (
        worker_passage(0, 5 + 5j, R, walls(10, 10), np.zeros(0, complex), TWO_LANES, LANE) is None
    )


def worker_passage_reference(worker, z, radius_m, obstacles, others, passage_m, lane):
    """:func:`worker_passage` in plain Python over the compiled gap and clip of one polygon
    each (the compiled :func:`sim.spatial.plane.worker_room` is checked against it)."""
    shapes = list(obstacles) + [disc_polygon(o, radius_m) for o in np.asarray(others).tolist()]
    if not shapes:
        return None
    body = disc_polygon(z, radius_m)
    gaps = [polygon_gap(body, s) for s in shapes]
    k = int(np.argmin([g[0] for g in gaps]))
    if not gaps[k][0] < passage_m:
        return None
    across = gaps[k][2] - gaps[k][1]
    across = across / abs(across) if abs(across) > 1e-12 else 1.0 + 0j
    room = {}
    for sign in (-1.0, 1.0):
        hits = [clip_line(z, sign * across, s) for s in shapes]
        ahead = [t0 for t0, t1 in hits if t0 <= t1 and t1 > 0.0]
        room[sign] = min((max(t, 0.0) for t in ahead), default=np.inf) - radius_m
        if room[sign] >= passage_m:
            return None
    near, far = room[1.0], room[-1.0]
    centre = z + 0.5 * (near - far) * across
    half_w = 0.5 * (near + far) + radius_m
    passable = max(near, far) >= lane
    return Passage(
        centre, 1j * across, 2.0 * radius_m, half_w, float(max(near, far)), worker, passable
    )


def worker_cases(seed: int, n: int = 400):
    """(got, want) pairs of passages for robots at work in random aisles: two shelves (a gap
    of 0.8-4 m, at any angle), a robot at work in the aisle, 0-2 others near it, half of
    the cases on a 0.05 m grid (equal distances); walls only in some."""
    rng = np.random.default_rng(seed)
    for c in range(n):
        grid = c % 2 == 0
        gap = rng.uniform(0.8, 4.0)
        turn = np.exp(1j * rng.uniform(0, 2 * np.pi)) if c % 3 else 1.0 + 0j
        a = np.array([0, 10, 10 + 1j, 1j]) - 1j
        b = np.array([0, 10, 10 + 1j, 1j]) + gap * 1j
        shelves = [5 + 5j + (s - 5 - 0.5j) * turn for s in (a, b)]
        z = 5 + 5j + (rng.uniform(-2, 2) + rng.uniform(0.3, gap - 0.3) * 1j - 0.5j) * turn
        others = z + rng.uniform(-1.5, 1.5, rng.integers(0, 3)) * 1j * turn
        others = others + rng.uniform(-0.3, 0.3, len(others))
        if grid:
            shelves = [np.round(s / 0.05) * 0.05 for s in shelves]
            z, others = np.round(z / 0.05) * 0.05, np.round(others / 0.05) * 0.05
        obstacles = shelves + (walls(10, 10) if c % 5 == 0 else [])
        obstacles = [np.ascontiguousarray(o, dtype=complex) for o in obstacles]
        for far_off in (others, others[:0]):
            args = (c, complex(z), R, obstacles, far_off, TWO_LANES, LANE)
            yield worker_passage(*args), worker_passage_reference(*args)


def worker_mismatches(seed: int) -> list[int]:
    """[cases, passages found, cases whose passage differs from the reference's in a field
    or a bit]."""
    tally = [0, 0, 0]
    for got, want in worker_cases(seed):
        tally[0] += 1
        tally[1] += want is not None
        tally[2] += repr(got) != repr(want)
    return tally


def test_worker_passage_is_the_python_reference_s():
    """The compiled room round a robot at work gives the reference's passage in every case,
    field for field (repr: every float's digits), and the cases reach both answers."""
    cases, found, differ = worker_mismatches(0)
    assert differ == 0
    assert 0.1 * cases < found < 0.9 * cases


@pytest.mark.slow  # a child Python: about 3 s
def test_worker_passage_is_the_reference_s_bit_for_bit_with_baseline_kernels():
    """The same in a child Python with numpy's baseline kernels (the golden runs')."""
    tallies = in_baseline_child(__file__, "[ns['worker_mismatches'](s) for s in (1, 2)]")
    assert all(differ == 0 and found > 0 for _, found, differ in tallies)
