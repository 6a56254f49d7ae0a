"""``sim.spatial.navigation.shapes.grown_shape``: the planner's grown obstacle, compiled, against
the numpy functions it replaces in the planner (``planning.inflate``, ``planning.halfplanes``)."""

from __future__ import annotations

import numpy as np
import pytest

from sim.spatial.navigation.planning import GridPlanner, halfplanes, inflate
from sim.spatial.navigation.shapes import grown_shape
from tests.golden.cases import in_baseline_child


def polygons(seed: int, n: int = 600) -> list[np.ndarray]:
    """Random convex CCW polygons of 3-9 corners (on a circle, some centred on whole metres),
    robots' octagons, and axis-aligned boxes with corners on the axes (zero products)."""
    rng = np.random.default_rng(seed)
    out = []
    for c in range(n):
        k = rng.integers(3, 10)
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        centre = rng.integers(-3, 3, 2).astype(float) if c % 2 else rng.uniform(-5, 5, 2)
        out.append(centre + rng.uniform(0.1, 3) * np.column_stack([np.cos(ang), np.sin(ang)]))
    for z in (0.0, 1.0, -2.0, 7.25):
        out.append(np.array([[z, z], [z + 1, z], [z + 1, z + 2], [z, z + 2]]))
        ring = np.exp(1j * (np.pi / 8 + np.pi / 4 * np.arange(8))) * 0.27 / np.cos(np.pi / 8)
        out.append(np.column_stack([(ring + z).real, (ring + z * 1j).imag]))
    return out


def shape_mismatches(seed: int) -> list[int]:
    """[values compared, values not the numpy functions' to the last bit (or of another
    shape), polygons with a bevelled corner]."""
    tally = [0, 0, 0]
    for poly in polygons(seed):
        for d in (0.35, 0.5, 1e-3):
            want = inflate(poly, d)
            want = (want, *halfplanes(want))
            got = grown_shape(np.ascontiguousarray(poly), d)
            tally[2] += len(want[0]) > len(poly)
            for g, w in zip(got, want, strict=True):
                tally[0] += w.size
                same = g.shape == w.shape and (g.view(np.uint64) == w.view(np.uint64)).all()
                tally[1] += 0 if same else w.size
    return tally


def test_grown_shapes_are_the_numpy_functions_to_the_last_bit():
    """Corners, normals and offsets (signs of zero included) are inflate's and halfplanes',
    and the cases reach bevelled corners (sharper than 90 degrees)."""
    values, differ, bevelled = shape_mismatches(0)
    assert differ == 0
    assert values > 10_000 and bevelled > 100


@pytest.mark.slow  # a child Python: about 3 s
def test_grown_shapes_are_the_numpy_functions_with_baseline_kernels():
    """The same in a child Python with numpy's baseline kernels (the golden runs')."""
    tallies = in_baseline_child(__file__, "[ns['shape_mismatches'](s) for s in (1, 2)]")
    assert all(differ == 0 and values > 0 for values, differ, _ in tallies)


def test_a_planner_grows_a_box_as_inflate_does():
    """The planner's grown obstacle (compiled) has inflate's corners and halfplanes' edges."""
    from sim.scenario import SpatialSpec

    box = ((4.0, 4.0), (6.0, 4.0), (6.0, 7.0), (4.0, 7.0))
    planner = GridPlanner(SpatialSpec(width_m=10.0, height_m=10.0, obstacles=(box,)))
    poly, normal, offset, lo, hi, edges = planner.shapes_[planner.obstacles[0]]
    want = inflate(np.array(box), planner.inflate_m)
    want_normal, want_offset = halfplanes(want)
    assert poly.tobytes() == want.tobytes()
    assert normal.tobytes() == want_normal.tobytes()
    assert offset.tobytes() == want_offset.tobytes()
    assert [list(e[:2]) for e in edges] == want_normal.tolist()
    assert lo == want.min(axis=0).tolist() and hi == want.max(axis=0).tolist()


def test_a_repeated_corner_gives_numpy_s_nans_not_an_error():
    """A polygon with a corner repeated has an edge of no length: numpy's functions divide by
    zero there (NaN, with a warning), and so does the compiled one, to the same bits."""
    poly = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    with np.errstate(invalid="ignore", divide="ignore"):
        want = inflate(poly, 0.35)
        want = (want, *halfplanes(want))
    got = grown_shape(poly, 0.35)
    assert np.isnan(want[0]).any()
    for g, w in zip(got, want, strict=True):
        assert g.shape == w.shape and g.tobytes() == w.tobytes()
