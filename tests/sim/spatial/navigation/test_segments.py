"""The compiled visibility test (``sim.spatial.navigation.segments``) answers as the planner's
numpy test does, segment for segment, on maps and hand-typed arenas, including the segments that
touch a boundary or run along an edge (between obstacle vertices)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenarios.loader import load_scenario
from sim.scenario import DriveSpec, SpatialSpec
from sim.spatial.navigation.planning import GridPlanner

TB3 = Path(__file__).parents[3] / "scenarios" / "maps" / "tb3_sandbox.toml"


def segments(planner: GridPlanner, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Random segments in the arena, vertex-to-vertex segments (boundaries touched, edges run
    along), axis-parallel ones (zero denominators) and points (zero length)."""
    rng = np.random.default_rng(seed)
    sp = planner.spatial
    size = np.array([sp.width_m, sp.height_m])
    a, b = rng.uniform(0, size, (n, 2)), rng.uniform(0, size, (n, 2))
    v = planner.vertices_
    i, j = rng.integers(0, len(v), n), rng.integers(0, len(v), n)
    flat = a.copy()
    flat[: n // 2, 1] = b[: n // 2, 1]  # horizontal
    flat[n // 2 :, 0] = b[n // 2 :, 0]  # vertical
    along = v[i] + 0.5 * (v[(i + 1) % len(v)] - v[i])
    starts = np.concatenate([a, v[i], flat, along, a[:50]])
    ends = np.concatenate([b, v[j], b, v[(i + 1) % len(v)], a[:50]])
    return starts, ends


@pytest.mark.parametrize("scenario", ["depot", "warehouse", "paper_spatial", str(TB3)])
def test_compiled_and_numpy_visibility_agree_on_every_segment(scenario):
    planner = GridPlanner(load_scenario(scenario).spatial)
    a, b = segments(planner, 4000, seed=7)
    fast, reference = planner.blocked(a, b), planner.blocked_reference(a, b)
    assert 0.2 < fast.mean() < 0.98  # both kinds occur
    np.testing.assert_array_equal(fast, reference)
    some = np.arange(0, len(planner.polygons_), 3)  # a subset of the obstacles
    np.testing.assert_array_equal(
        planner.blocked(a, b, some), planner.blocked_reference(a, b, some)
    )


def test_a_segment_through_a_box_is_blocked_and_one_along_its_side_is_not():
    box = ((4.0, 4.0), (6.0, 4.0), (6.0, 6.0), (4.0, 6.0))
    planner = GridPlanner(SpatialSpec(10.0, 10.0, (box,), ((),), DriveSpec(radius_m=0.4)))
    d = 0.4 + 0.1  # radius + clearance: the box grows to [3.5, 6.5]^2
    a = np.array([[1.0, 5.0], [1.0, 4.0 - d], [1.0, 4.0 - d - 0.01], [5.0, 5.0]])
    b = np.array([[9.0, 5.0], [9.0, 4.0 - d], [9.0, 4.0 - d - 0.01], [5.0, 5.0]])
    assert planner.blocked(a, b).tolist() == [True, False, False, True]
    assert planner.blocked(a[:0], b[:0]).shape == (0,)
    empty = GridPlanner(SpatialSpec(10.0, 10.0, (), ((),), DriveSpec()))
    assert empty.blocked(a, b).tolist() == [False] * 4
