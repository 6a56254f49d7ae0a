"""``sim.spatial.traffic.annotate``: a path's crossings of passages, its chains and the holding
points before a mouth, with exact numbers on straight and bent paths."""

from __future__ import annotations

import numpy as np
import pytest

from sim.spatial.traffic.annotate import at_left, chains, crossings, cut, hold_points, left_along
from sim.spatial.traffic.passages import Passage

# the warehouse's cross-aisle gaps: 1 m square passages at x = 10, y 7..8 and 10..11
GAP_A = Passage(10 + 7.5j, 1j, 0.5, 0.5, 1.0)
GAP_B = Passage(10 + 10.5j, 1j, 0.5, 0.5, 1.0)


def test_left_along_and_at_left_name_points_by_the_path_left_to_the_end():
    pts = np.array([0j, 3 + 0j, 3 + 4j])
    assert left_along(pts).tolist() == [7.0, 4.0, 0.0]
    left = left_along(pts)
    assert at_left(pts, left, 5.0) == pytest.approx(2 + 0j)
    assert at_left(pts, left, 2.0) == pytest.approx(3 + 2j)
    assert at_left(pts, left, 9.0) == 0j and at_left(pts, left, -1.0) == 3 + 4j
    assert cut(pts, left, 5.0, 2.0) == pytest.approx([2 + 0j, 3 + 0j, 3 + 2j])


def test_a_straight_path_up_through_a_gap_crosses_it_along_its_axis():
    pts = np.array([10 + 5j, 10 + 9j])  # 4 m; the gap spans y 7..8
    (c,) = crossings(pts, {0: GAP_A})
    assert (c.key, c.direction) == (0, 1)
    assert (c.entry_left_m, c.exit_left_m) == pytest.approx((2.0, 1.0))
    (back,) = crossings(pts[::-1], {0: GAP_A})
    assert back.direction == -1


def test_a_bent_path_entering_from_the_side_and_a_path_that_misses():
    """From the aisle at y 6.5 to the corner (9.85, 6.65), then up: it enters at y 7."""
    pts = np.array([6 + 6.5j, 9.85 + 6.65j, 9.85 + 9j])
    (c,) = crossings(pts, {0: GAP_A})
    up = abs(9.85 + 9j - (9.85 + 6.65j))
    assert c.entry_left_m == pytest.approx(up - 0.35)
    assert c.exit_left_m == pytest.approx(up - 1.35)
    assert crossings(np.array([6 + 6.5j, 14 + 6.5j]), {0: GAP_A}) == []  # along the aisle


def test_a_path_that_ends_in_a_passage_exits_at_its_end():
    (c,) = crossings(np.array([10 + 5j, 10 + 7.6j]), {0: GAP_A})
    assert (c.entry_left_m, c.exit_left_m) == pytest.approx((0.6, 0.0))


@pytest.mark.parametrize(("chain_m", "n_chains"), [(2.5, 1), (1.5, 2)])
def test_gaps_closer_than_chain_m_are_one_chain(chain_m, n_chains):
    """Up through both gaps: 2 m between A's exit (y 8) and B's entry (y 10)."""
    pts = np.array([10 + 5j, 10 + 13j])
    found = crossings(pts, {0: GAP_A, 1: GAP_B})
    assert [c.key for c in found] == [0, 1]
    out = chains(pts, found, chain_m, 0.45)
    assert len(out) == n_chains
    first = out[0]
    assert first.entry_left_m == pytest.approx(6.0)
    if n_chains == 1:
        assert first.passages == ((0, 1), (1, 1))
        assert first.exits_left_m == pytest.approx((5.0, 2.0))
        assert first.exit_left_m == pytest.approx(2.0)
        # the zone runs from A's entry to 0.45 m beyond B's exit
        assert first.zone[0] == pytest.approx(10 + 7j) and first.zone[-1] == pytest.approx(
            10 + 11.45j
        )
    else:
        assert [c.passages for c in out] == [((0, 1),), ((1, 1),)]
    assert chains(pts, [], chain_m, 0.45) == []  # a way that crosses no passage


def test_hold_points_lie_before_the_mouth_on_the_way_moved_right_first():
    """A robot at (10, 3) going up to the gap at y 7: the first holding point is 0.6 m before
    the entry on its way, 0.7 m to its right (+x), then 0.35 m, then on the way; then the
    same 0.25 m farther back."""
    pts = np.array([10 + 3j, 10 + 9j])
    (c,) = crossings(pts, {0: GAP_A})
    out = hold_points(pts, c.entry_left_m, 0.6, 0.7)
    spots = [s for s, _ in out]
    assert spots[:3] == pytest.approx([10.7 + 6.4j, 10.35 + 6.4j, 10 + 6.4j])
    assert spots[3:6] == pytest.approx([10.7 + 6.15j, 10.35 + 6.15j, 10 + 6.15j])
    assert all(left == pytest.approx(-1 + 0j) for _, left in out)  # left of going up is -x
    assert len(out) == 3 * 9


def test_a_robot_already_near_the_mouth_holds_beside_where_it_is():
    pts = np.array([10 + 6.8j, 10 + 9j])
    (c,) = crossings(pts, {0: GAP_A})
    spots = [s for s, _ in hold_points(pts, c.entry_left_m, 0.6, 0.7)]
    assert spots == pytest.approx([10.7 + 6.8j, 10.35 + 6.8j, 10 + 6.8j])
