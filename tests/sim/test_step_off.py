"""``Jobs.step_off`` (an idle robot steps off a stuck robot's way) and ``_to_polyline``, on
scenes set by hand: which end point each rule picks. Written for the gaps mutation run H
found in ``sim/spatial/jobs.py`` (README, "Testing").

Robot 0 is the stuck robot j; the idle robot k steps ``YIELD_STEP_M`` (1 m), else 2 m, to
the side of j's way away from j, the other side, or straight on; an end must be half a
step from other robots, two radii + ``LANE_GAP_M`` (0.6 m) off the rest of j's way, and
its path must keep two radii (0.5 m) from j.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.spatial.jobs import _to_polyline
from tests.sim.test_jams import set_way
from tests.sim.test_jobs import orca_world


def step(starts, k: int, way=None, heading: float = 0.0):
    """Where idle robot k steps to, off the way of robot 0 (at starts[0], along ``way`` (x + iy
    points from it), or with no path, facing ``heading``); None if nowhere."""
    w = orca_world(starts)
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


# ---- _to_polyline ------------------------------------------------------------------------


def test_to_polyline_measures_to_the_nearest_point_of_each_segment():
    p = np.array([0.25 - 0.3j, 1.0 + 0.25j, -1.0 + 0j])
    way = np.array([0j, 0.5 + 0j, 0.5 + 0.5j])  # two legs of 0.5 m
    assert _to_polyline(p, way) == pytest.approx([0.3, 0.5, 1.0])
    two = np.array([0j, 4 + 0j])
    assert _to_polyline(np.array([2 + 1j, 5 + 0j]), two).tolist() == [1.0, 1.0]
    assert _to_polyline(np.array([4 + 5j]), np.array([1 + 1j])).tolist() == [5.0]
    empty = _to_polyline(np.array([1 + 1j, 2j]), np.zeros(0, dtype=complex))
    assert empty.dtype == float and empty.tolist() == [np.inf, np.inf]
