"""BoxBuckets: the boxes a query may touch, never fewer than a full loop finds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim.spatial.navigation.buckets import MAX_CELLS, BoxBuckets, typical_size

coord = st.floats(-20.0, 40.0, allow_nan=False)
box = st.tuples(coord, coord, st.floats(0.0, 6.0), st.floats(0.0, 6.0)).map(
    lambda b: (b[0], b[1], b[0] + b[2], b[1] + b[3])
)


def meets(b, x0, y0, x1, y1) -> bool:
    return b[0] <= x1 and x0 <= b[2] and b[1] <= y1 and y0 <= b[3]


@settings(max_examples=200, deadline=None)
@given(st.lists(box, min_size=1, max_size=40), st.lists(box, min_size=1, max_size=10))
def test_near_and_at_return_every_box_that_meets_the_query_in_index_order(boxes, queries):
    buckets = BoxBuckets(boxes, typical_size(boxes))
    for q in queries:
        found = buckets.near(*q)
        assert found == sorted(set(found))
        assert {k for k, b in enumerate(boxes) if meets(b, *q)} <= set(found)
        x, y = q[0], q[1]
        at = buckets.at(x, y)
        assert at == sorted(set(at))
        assert {k for k, b in enumerate(boxes) if meets(b, x, y, x, y)} <= set(at)


def test_a_small_query_in_a_large_field_looks_at_few_boxes():
    """100 boxes on a grid: a 1 m query sees its neighbours, not all; a huge one gets all."""
    rng = np.random.default_rng(0)
    corners = rng.uniform(0.0, 100.0, size=(100, 2))
    boxes = [(x, y, x + 2.0, y + 2.0) for x, y in corners.tolist()]
    buckets = BoxBuckets(boxes, typical_size(boxes))
    assert typical_size(boxes) == 2.0
    sizes = [len(buckets.near(x, y, x + 1.0, y + 1.0)) for x, y in corners.tolist()]
    assert max(sizes) < 10 and min(sizes) >= 1  # each query holds its own box's corner
    assert buckets.near(0.0, 0.0, 2.0 * MAX_CELLS, 2.0 * MAX_CELLS) == list(range(100))


def _nearest_all(fol, z):
    """The nearest obstacle point by a pass over every edge: the reference."""
    e0, d = fol.edge0_, fol.edge1_ - fol.edge0_
    t = ((z[:, None] - e0) * d.conj()).real / np.maximum((d * d.conj()).real, 1e-24)
    near = e0 + np.minimum(np.maximum(t, 0.0), 1.0) * d - z[:, None]
    return near[np.arange(len(z)), np.abs(near).argmin(axis=1)]


def _boxes_in_arena(corners, size, w=30.0, h=20.0):
    boxes = [
        ((x, y), (x + s, y), (x + s, y + s), (x, y + s))
        for (x, y), s in zip(corners, size, strict=True)
    ]
    walls = [((0, 0), (w, 0)), ((w, 0), (w, h)), ((w, h), (0, h)), ((0, h), (0, 0))]
    return [*boxes, *walls]


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(st.floats(0.0, 28.0), st.floats(0.0, 18.0)), min_size=12, max_size=40),
    st.integers(0, 2**32 - 1),
)
def test_to_obstacle_over_grid_cells_is_the_full_pass_bit_for_bit(corners, seed):
    """``PathFollower.to_obstacle`` with the edge grid (``EdgeCells``) gives the very same
    vectors as a pass over every edge, for points inside, on cell borders and outside the
    grid, and for ties (points equally far from two edges: the first edge in both)."""
    from sim.spatial.navigation.buckets import EdgeCells
    from sim.spatial.navigation.paths import PathFollower

    rng = np.random.default_rng(seed)
    size = rng.uniform(0.2, 2.5, len(corners))
    fol = PathFollower(4, 1.0, _boxes_in_arena(corners, size), 0.25)
    assert isinstance(fol.cells_, EdgeCells)  # >= 52 edges: the grid is built
    cells = fol.cells_
    z = rng.uniform(-2.0, 32.0, 400) + 1j * rng.uniform(-2.0, 22.0, 400)
    side = 1.0 / cells.inv  # points on cell borders and corners
    border = cells.lo + side * (rng.integers(0, cells.nx, 60) + 1j * rng.integers(0, cells.ny, 60))
    mid = 0.5 * (fol.edge0_[:40] + fol.edge1_[:40])  # on an edge: distance 0, maybe two edges
    z = np.concatenate([z, border, mid, [15.0 + 10.0j]])
    want = _nearest_all(fol, z)
    inside = z[(z.real > 0) & (z.real < 30) & (z.imag > 0) & (z.imag < 20)]
    assert (cells.cell_of(inside) >= 0).all()  # the grid covers the arena: it is what runs
    for part in (z, inside, z[:100]):
        got = fol.to_obstacle(part)
        assert np.array_equal(got.view(float), _nearest_all(fol, part).view(float))
    assert np.array_equal(fol.to_obstacle(z).view(float), want.view(float))


def test_edge_cells_list_few_edges_in_a_large_arena():
    """The 1000-robot bench arena (392 edges): each cell lists at most a tenth of them, so a
    query over 300 robots does a tenth of the arithmetic; the grid is not built for a handful
    of edges."""
    from scenarios.bench.arena import bench_scenario
    from sim.spatial.navigation.paths import PathFollower

    sp = bench_scenario(1000, np.random.default_rng(0), control_hz=10.0).spatial
    w, h = sp.width_m, sp.height_m
    walls = [((0, 0), (w, 0)), ((w, 0), (w, h)), ((w, h), (0, h)), ((0, h), (0, 0))]
    fol = PathFollower(4, 1.0, [*sp.obstacles, *walls], 0.25)
    assert fol.cells_.table.shape[1] <= len(fol.edge0_) // 10
    small = PathFollower(4, 1.0, walls, 0.25)
    assert small.cells_ is None


def test_segment_distances_of_short_and_long_segments_against_sampled_points():
    """The point-to-segment distances EdgeCells keeps edges by, for segments from 1 mm to
    10 m (shorter than 1 m too, where a wrong normalisation would still pass long ones)."""
    from sim.spatial.navigation.buckets import _segment_distances

    rng = np.random.default_rng(4)
    e0 = rng.uniform(0, 10, 40) + 1j * rng.uniform(0, 10, 40)
    length = np.geomspace(1e-3, 10.0, 40)
    e1 = e0 + length * np.exp(1j * rng.uniform(-np.pi, np.pi, 40))
    p = rng.uniform(-2, 12, 50) + 1j * rng.uniform(-2, 12, 50)
    got = _segment_distances(p, e0, e1)
    s = np.linspace(0.0, 1.0, 20001)
    # point by point (one 40 x 20001 array at a time, not 50 of them: 1.2 GB at once)
    sampled = np.array([np.abs(e0[:, None] + s * (e1 - e0)[:, None] - q).min(axis=1) for q in p])
    assert got.shape == (50, 40)
    np.testing.assert_allclose(got, sampled, rtol=0, atol=0.5 * 10.0 / 20000)  # half a sample
    assert _segment_distances(np.array([3 + 4j]), np.array([0j]), np.array([0j]))[0, 0] == 5.0


def test_an_empty_bucket_set_finds_nothing():
    buckets = BoxBuckets([], 1.0)
    assert buckets.at(1.0, 2.0) == [] and buckets.near(0.0, 0.0, 3.0, 3.0) == []
    assert typical_size([]) == 1.0


def test_typical_size_is_the_median_longer_side_at_least_half_a_metre():
    boxes = [(0, 0, 3, 1), (0, 0, 1, 2), (0, 0, 0.2, 0.1), (5, 5, 6, 9), (0, 0, 1.5, 1)]
    assert typical_size(boxes) == 2.0  # longer sides 0.2, 1.5, 2, 3, 4
    assert typical_size([(0, 0, 0.1, 0.2), (1, 1, 1.3, 1.1)]) == 0.5


def test_edge_cells_grid_covers_the_region_from_its_corner():
    """A 20 m x 10 m region far from the origin, 50 cells: 2 m cells, 10 x 5; the cell index
    is row * nx + column, and points outside (the far borders too) have none."""
    from sim.spatial.navigation.buckets import EdgeCells

    e0, e1 = np.array([100 + 50j]), np.array([120 + 50j])
    cells = EdgeCells(e0, e1, 100 + 50j, 120 + 60j, cells=50)
    assert (cells.nx, cells.ny, cells.inv) == (10, 5, 0.5)
    z = np.array([100 + 50j, 101.9 + 51.9j, 119.99 + 59.99j, 106.5 + 55.5j, 120 + 55j,
                  104 + 60j, 99.99 + 52j, 104 + 49.99j])  # fmt: skip
    assert cells.cell_of(z).tolist() == [0, 0, 49, 23, -1, -1, -1, -1]
    assert cells.cell_of(z).dtype == np.intp


@pytest.mark.parametrize(
    "hi, n, want",
    [
        (0.5 + 0.5j, 2, (2, 2)),  # sqrt(0.25 / 2) = 0.354 m cells
        (1 + 1j, 16, (4, 4)),  # 0.25 m, the least side
        (1 + 1j, 4096, (4, 4)),  # never smaller than 0.25 m
        (10 + 0j, 100, (40, 1)),  # no height: one row of 0.25 m cells
        (3 + 3j, 1, (1, 1)),
    ],
)
def test_edge_cells_grid_size(hi, n, want):
    from sim.spatial.navigation.buckets import EdgeCells

    cells = EdgeCells(np.array([0j]), np.array([1 + 0j]), 0j, hi, cells=n)
    assert (cells.nx, cells.ny) == want


def test_edge_cells_keep_the_edges_within_reach_of_each_cell_in_index_order():
    """Each cell's row lists, ascending, the segments within d_min(centre) + sqrt(2) side
    (+1e-6 m) of its centre, padded with the index n of a far-away segment of length 0;
    checked against distances from the centres worked out one by one, over 600 cells (more
    than one pass of 256)."""
    from sim.spatial.navigation.buckets import _FAR, EdgeCells

    rng = np.random.default_rng(9)
    e0 = rng.uniform(0, 60, 25) + 1j * rng.uniform(0, 40, 25)
    e1 = e0 + rng.uniform(1, 12, 25) * np.exp(1j * rng.uniform(-np.pi, np.pi, 25))
    cells = EdgeCells(e0, e1, 0j, 60 + 40j, cells=600)
    side = 1.0 / cells.inv
    assert (cells.nx, cells.ny) == (30, 20) and side == 2.0
    rows = []
    for iy in range(cells.ny):
        for ix in range(cells.nx):
            c = complex(ix + 0.5, iy + 0.5) * side
            d = []
            for a, b in zip(e0, e1, strict=True):
                t = min(1.0, max(0.0, ((c - a) * (b - a).conjugate()).real / abs(b - a) ** 2))
                d.append(abs(a + t * (b - a) - c))
            rows.append([k for k, dk in enumerate(d) if dk <= min(d) + math.sqrt(2) * side + 1e-6])
    width = max(len(r) for r in rows)
    assert 1 < width < 25
    assert cells.table.shape == (600, width)
    for i, r in enumerate(rows):
        assert cells.table[i].tolist() == r + [25] * (width - len(r)), i
    assert cells.e0[-1] == _FAR and cells.d[-1] == 0
    assert np.array_equal(cells.e0[:-1], e0) and np.array_equal(cells.d[:-1], e1 - e0)
