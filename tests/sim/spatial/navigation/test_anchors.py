"""The distance field's parts (`sim.spatial.navigation.anchors`, the helpers of
`sim.spatial.navigation.distfield`), each against numbers worked by hand.

`test_distfield.py` (beside this file) checks the whole field against the planner: exact distances.
The pruning here only ever drops candidates for a proof, so a part that prunes less (a wedge
too wide, an edge direction wrong the safe way) still gives exact distances there; these tests
pin the parts themselves.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from sim.spatial.navigation.anchors import (
    MARGIN_M,
    WEDGE_SLACK_RAD,
    _write,
    edge_directions,
    next_points,
    outside_wedge,
    run_starts,
    taut_wedges,
)
from sim.spatial.navigation.distfield import (
    DistanceField,
    FieldCache,
    _grid,
    _in_box,
    _within_box,
)
from sim.spatial.navigation.raster import Grid

# -- anchors -----------------------------------------------------------------------------


def test_run_starts():
    assert run_starts(np.array([3, 3, 5, 5, 5, 2, 3])).tolist() == [0, 2, 5, 6]
    assert run_starts(np.array([7])).tolist() == [0]
    empty = run_starts(np.array([], dtype=np.int32))
    assert empty.size == 0 and empty.dtype == np.int64


def test_write_sets_a_block_of_cells_of_one_site():
    codes = np.zeros((2, 4, 4), dtype=np.int16)
    _write(codes, 1, np.array([1]), np.array([1]), np.array([0]), 7)  # 2 x 2 cells
    want = np.zeros((2, 4, 4), dtype=np.int16)
    want[1, 0:2, 2:4] = 7
    assert (codes == want).all()
    _write(codes, 0, np.array([0, 0]), np.array([3, 0]), np.array([3, 1]), np.int16(5))
    want[0, 3, 3] = want[0, 1, 0] = 5
    assert (codes == want).all()
    _write(codes, 2, np.array([], dtype=int), np.array([], dtype=int), np.array([], dtype=int), 9)
    assert (codes == want).all()


def _square_planner(free=None):
    """A 2 m x 1 m rectangle, counter-clockwise from (0, 0)."""
    poly = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]])
    ok = np.ones(4, dtype=bool) if free is None else np.asarray(free)
    return SimpleNamespace(polygons_=[poly], free=lambda v: ok[: len(v)].copy())


def test_edge_directions_are_unit_vectors_along_both_edges_at_each_vertex():
    e1, e2 = edge_directions(_square_planner())
    assert e1.tolist() == [1j, -1, -1j, 1]  # toward the previous vertex
    assert e2.tolist() == [1, 1j, -1, -1j]  # toward the next one
    e1, e2 = edge_directions(_square_planner([True, False, True, True]))  # (2, 0) not free
    assert e1.tolist() == [1j, -1j, 1] and e2.tolist() == [1, -1, -1j]


def test_edge_directions_of_no_obstacles():
    e1, e2 = edge_directions(SimpleNamespace(polygons_=[]))
    assert e1.shape == e2.shape == (0,) and e1.dtype == e2.dtype == complex


def test_next_points_follow_the_recorded_path_or_go_to_the_goal():
    """Vertex 0's path leaves its last vertex 1 for the goal: the point after 0 is
    pred_[1, 0]; vertex 1 sees the goal; vertex 2 has no path (the goal, unused)."""
    planner = SimpleNamespace(
        vertices_=np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]]),
        pred_=np.array([[-9, 0, 1], [1, -9, 0], [0, 1, -9]]),
    )
    dist = np.array([3.0, 2.0, np.inf])
    last = np.array([1, 1, -1])
    got = next_points(planner, dist, last, 5 + 5j)
    assert got.tolist() == [1 + 0j, 5 + 5j, 5 + 5j]
    got = next_points(planner, np.array([3.0, 2.0, 4.0]), np.array([1, 1, 0]), 5 + 5j)
    assert got.tolist() == [1 + 0j, 5 + 5j, 1 + 0j]  # pred_[0, 2] = 1
    got = next_points(planner, np.array([3.0, np.inf, 4.0]), np.array([1, 0, 0]), 5 + 5j)
    assert got[1] == 5 + 5j  # no path (inf), whatever vertex is recorded: the goal


def _in_wedge(normals, apex, p) -> bool:
    q = p - apex
    return all((np.conj(n) * q).real <= 0 for n in normals)


def test_a_taut_wedge_lies_between_the_far_edge_and_the_path_s_extension():
    """The corner (0, 0) of the obstacle [0, 2] x [0, 1], a path bending there toward (2, -1):
    the points whose best anchor it can be lie between the far edge (+y) and the extension of
    (2, -1) -> (0, 0) beyond it (angles 90 to 153.4 degrees)."""
    zv = np.array([0j])
    edges = (np.array([1j]), np.array([1 + 0j]))
    normals, kind = taut_wedges(zv, edges, np.array([[2 - 1j]]), np.array([[3.0]]))
    assert normals.shape == (1, 1, 2) and kind.tolist() == [[1]]
    for deg, inside in [(91, True), (120, True), (153, True), (89, False), (154, False),
                        (200, False), (-30, False)]:  # fmt: skip
        p = 5 * complex(math.cos(math.radians(deg)), math.sin(math.radians(deg)))
        assert _in_wedge(normals[0, 0], 0j, p) == inside, deg


def test_the_wedge_turns_with_the_other_far_edge():
    """The same corner, the path bending toward (-1, 2): the far edge is +x, the wedge runs
    from the extension (angle -63.4 degrees) to +x (0 degrees)."""
    zv = np.array([0j])
    edges = (np.array([1j]), np.array([1 + 0j]))
    normals, kind = taut_wedges(zv, edges, np.array([[-1 + 2j]]), np.array([[3.0]]))
    assert kind.tolist() == [[1]]
    for deg, inside in [(-60, True), (-5, True), (-70, False), (5, False), (120, False)]:
        p = 5 * complex(math.cos(math.radians(deg)), math.sin(math.radians(deg)))
        assert _in_wedge(normals[0, 0], 0j, p) == inside, deg


def test_wedge_kinds():
    """0: the path's extension runs into the obstacle (no taut bend there) or no path; 2: the
    next point is the vertex itself (no direction): anywhere."""
    zv = np.array([0j, 0j, 0j, 0j])
    edges = (np.full(4, 1j), np.full(4, 1 + 0j))
    nxt = np.array([[-1 - 1j, 0j, 2 - 1j, 1e-7 + 0j]])
    with np.errstate(all="raise"):  # a next point at the vertex divides by nothing
        _, kind = taut_wedges(zv, edges, nxt, np.array([[1.0, 1.0, np.inf, 1.0]]))
    assert kind.tolist() == [[0, 2, 0, 2]]
    # along an edge's line (cross product 0) the extension is not "behind" the obstacle
    one = (edges[0][:1], edges[1][:1])
    with np.errstate(all="raise"):
        _, kind = taut_wedges(zv[:1], one, np.array([[-1 + 0j]]), np.array([[1.0]]))
    assert kind.tolist() == [[1]]


def test_outside_wedge_by_the_nearest_corner_and_the_slack():
    """The wedge x <= 0 and y <= 0 (normals +x and +y, apex at the origin)."""
    normals = np.array([[1 + 0j, 1j]] * 5)
    apex = np.zeros(5, dtype=complex)
    x0 = np.array([-3.0, 0.5, -1.0, -3.0, 1e-7])
    y0 = np.array([-3.0, -3.0, -0.5, 2.0, -3.0])
    got = outside_wedge(normals, apex, x0, y0, 1.0, 1.0)
    # inside; right of x = 0; straddling y = 0; above y = 0; right by less than the slack
    assert got.tolist() == [False, True, False, True, False]
    slack = MARGIN_M + WEDGE_SLACK_RAD * (abs(complex(1e-7 + 0.5, -2.5)) + math.hypot(0.5, 0.5))
    beyond = outside_wedge(normals[:1], apex[:1], np.array([slack * 1.01]), y0[4:], 1.0, 1.0)
    assert beyond.tolist() == [True]
    wide = outside_wedge(normals[:1], apex[:1], np.array([0.3]), np.array([-3.0]), 2.0, 0.5)
    assert wide.tolist() == [True]  # the block's near side is at x = 0.3


def test_the_wedge_slack_grows_with_the_distance_from_the_apex():
    """A block 2.5e-4 m past the line x = 0, its centre 2.5 m from the apex: the slack is
    1e-6 + 1e-4 (2.55 + 0.71) = 3.3e-4 m, so the block is not outside; 5 m further out the
    slack is 8.3e-4 m."""
    normals, apex = np.array([[1 + 0j, 1j]]), np.zeros(1, dtype=complex)
    got = outside_wedge(normals, apex, np.array([2.5e-4]), np.array([-3.0]), 1.0, 1.0)
    assert got.tolist() == [False]
    got = outside_wedge(normals, apex, np.array([3.4e-4]), np.array([-3.0]), 1.0, 1.0)
    assert got.tolist() == [True]
    got = outside_wedge(normals, apex, np.array([8e-4]), np.array([-8.0]), 1.0, 1.0)
    assert got.tolist() == [False]


def test_outside_a_line_whose_normal_points_down():
    """The wedge y >= 0 (normal -y): a block [0, 1] x [-3, -2] lies 2 m beyond it, by its
    top side; a block [0, 1] x [-0.5, 0.5] straddles the line."""
    normals = np.array([[-1j, -1j]] * 2)
    apex = np.zeros(2, dtype=complex)
    got = outside_wedge(normals, apex, np.zeros(2), np.array([-3.0, -0.5]), 1.0, 1.0)
    assert got.tolist() == [True, False]
    got = outside_wedge(normals[:1], apex[:1], np.zeros(1), np.array([-2.5]), 1.0, 2.0)
    assert got.tolist() == [True]  # [-2.5, -0.5]: 0.5 m beyond


# -- distfield helpers -------------------------------------------------------------------


@pytest.mark.parametrize(
    "w, h, sites, want",
    [
        (30.0, 20.0, 10, (64, 32, 5)),  # 0.5 m cells in 16 m blocks: 2 x 1 blocks
        (4.0, 3.0, 1, (32, 32, 5)),  # smaller than a block: one block
        (100.0, 100.0, 100_000, (24, 24, 2)),  # cells of 3.86 m keep the table in bounds
    ],
)
def test_field_grid(w, h, sites, want):
    grid, levels = _grid(w, h, sites)
    assert (grid.nx, grid.ny, levels) == want
    assert grid.dx_m == w / grid.nx and grid.dy_m == h / grid.ny
    assert grid.nx % (1 << levels) == 0 and grid.ny % (1 << levels) == 0


def test_cells_meeting_and_within_a_box():
    grid = Grid(1.0, 1.0, 4, 3)
    lo, hi = np.array([0.5, 0.5]), np.array([2.0, 2.0])
    meet = _in_box(grid, lo, hi).reshape(3, 4)
    assert meet.tolist() == [[True, True, True, False]] * 3  # column 2 touches x = 2
    within = _within_box(grid, lo, hi).reshape(3, 4)
    want = np.zeros((3, 4), dtype=bool)
    want[1, 1] = True
    assert (within == want).all()
    assert _within_box(grid, np.zeros(2), np.array([4.0, 3.0])).all()
    assert not _in_box(grid, np.array([4.5, 0.0]), np.array([6.0, 3.0])).any()


def test_field_cache_keeps_the_last_fields_used():
    cache, built = FieldCache(size=2), []

    def build(name):
        built.append(name)
        return name

    assert cache.get("a", lambda: build("a")) == "a"
    assert cache.get("b", lambda: build("b")) == "b"
    assert cache.get("a", lambda: build("a2")) == "a"  # kept; now the newest
    assert cache.get("c", lambda: build("c")) == "c"  # drops b, the oldest
    assert cache.get("b", lambda: build("b2")) == "b2"
    assert cache.get("a", lambda: build("a3")) == "a3"  # c and b were newer
    assert built == ["a", "b", "c", "b2", "a3"]
    cache.clear()
    assert cache.get("b", lambda: build("b3")) == "b3"


def test_a_field_fits_while_its_anchor_codes_fit():
    def planner(n_vertices, w=20.0, h=20.0):
        return SimpleNamespace(
            spatial=SimpleNamespace(width_m=w, height_m=h), vertices_=np.zeros((n_vertices, 2))
        )

    top = np.iinfo(np.int16).max - 3  # codes V + 2 (and V + 3 on) stay in int16
    assert DistanceField.fits(planner(top), 10)
    assert not DistanceField.fits(planner(top + 1), 10)
    # cells grow to keep the table within 128 MiB, so keys (cell x sites) stay in 31 bits
    assert DistanceField.fits(planner(10, 1000.0, 1000.0), 5000)


# -- refine: the pruning rules on one block of 2 x 2 cells ---------------------------------

NONE_, FULL_, PART_ = 1, 2, 3  # sim.spatial.navigation.raster's classes


def _refine(classes, a, b, fa, fb, kind=2, normals=None):
    """One site (hidden unless ``classes`` says otherwise) and two anchors a, b (x + iy) with
    geodesics fa, fb, on a 2 m x 2 m block of four 1 m cells. ``classes``: (3,) class of a, b
    and the site's goal, the same from every cell."""
    from sim.spatial.navigation.anchors import refine

    grid = Grid(1.0, 1.0, 2, 2)
    cells = np.repeat(np.asarray(classes, dtype=np.uint8)[:, None], 4, axis=1)
    pyramid = [cells, cells[:, :1].copy()]
    kind = np.full((1, 2), kind)  # 2: anywhere, no wedge
    normals = np.zeros((1, 2, 2), dtype=complex) if normals is None else normals
    anchor_z = np.array([[a, b, 10 + 10j, 0, 0]])
    anchor_f = np.array([[fa, fb, 0.0, np.inf, np.nan]])
    zv = np.array([a, b])
    with np.errstate(all="raise"):
        return refine(grid, 1, pyramid, kind, normals, zv, anchor_z, anchor_f, 0, 1)


def _candidates(extra):
    key, anchor, full = extra
    pairs = {
        int(k): zip(anchor[key == k].tolist(), full[key == k].tolist(), strict=True) for k in key
    }
    return {k: sorted(v) for k, v in pairs.items()}


def test_a_site_seen_from_the_whole_block_settles_it():
    codes, extra = _refine([FULL_, FULL_, FULL_], 1 + 5j, 1 + 5j, 0.0, 1.0)
    assert codes.tolist() == [[2, 2, 2, 2]] and extra[0].size == 0


@pytest.mark.parametrize("fb", [1.0, 0.3])
def test_an_anchor_dominated_at_every_point_of_a_cell_is_dropped(fb):
    """a and b at the same point (1, 5), b dearer by fb: b loses everywhere. The angle bound
    proves it per cell (rho sin-bound about 0.22-0.28 m at 1 m cells, 1.0 m for the 2 m block:
    fb = 1.0 is not proven for the block, fb = 0.3 needs the bound's exact constants)."""
    codes, extra = _refine([FULL_, FULL_, NONE_], 1 + 5j, 1 + 5j, 0.0, fb)
    assert codes.tolist() == [[0, 0, 0, 0]] and extra[0].size == 0


def test_anchors_seen_from_part_of_a_cell_prove_nothing():
    """Neither anchor is seen from the whole cell, so neither may drop the other, however
    much dearer b is: every cell keeps both, as candidates seen in part."""
    codes, extra = _refine([PART_, PART_, NONE_], 1 + 5j, 1 + 5j, 0.0, 10.0)
    assert codes.tolist() == [[4, 4, 4, 4]]
    assert _candidates(extra) == {k: [(0, False), (1, False)] for k in range(4)}


def test_an_anchor_at_or_near_the_block_centre():
    """The angle bound's arcsines take rho / distance capped at 1: an anchor at the block's
    centre (distance 0) or within rho of it raises no floating-point error (errors raise
    here), and the cheaper anchor stays a candidate of every cell."""
    codes, extra = _refine([FULL_, FULL_, NONE_], 1 + 5j, 1 + 1j, 0.0, 4.5)  # b at the centre
    cand = _candidates(extra)
    for cell in range(4):
        assert codes[0, cell] == 0 or (0, True) in cand[cell]
    codes, extra = _refine([FULL_, FULL_, NONE_], 1 + 1.2j, 1 + 3j, 0.0, 0.0)  # a near it
    cand = _candidates(extra)
    for cell in range(4):
        assert codes[0, cell] == 0 or (0, True) in cand[cell]


def test_a_block_that_sees_no_anchor_has_no_path():
    codes, extra = _refine([NONE_, NONE_, NONE_], 1 + 5j, 1 + 5j, 0.0, 1.0)
    assert codes.tolist() == [[3, 3, 3, 3]] and codes.dtype == np.int16  # V + 1
    assert extra[0].size == 0


def test_only_anchors_with_a_wedge_are_tested_against_it():
    """Wedges x <= 0 (normals +x) exclude the block [0, 2] x [0, 2] of anchors of kind 1;
    anchors of kind 2 (no usable direction) are kept whatever their normals say."""
    away = np.full((1, 2, 2), 1 + 0j)
    codes, _ = _refine([PART_, PART_, NONE_], -4 + 1j, -4 + 1j, 0.0, 0.0, kind=1, normals=away)
    assert codes.tolist() == [[3, 3, 3, 3]]  # both dropped: no candidate left
    codes, extra = _refine([PART_, PART_, NONE_], -4 + 1j, -4 + 1j, 0.0, 0.0, normals=away)
    assert codes.tolist() == [[4, 4, 4, 4]]
    key, anchor, full = extra
    assert key.dtype == np.int32 and anchor.dtype == np.int16 and full.dtype == bool
    assert _candidates(extra) == {k: [(0, False), (1, False)] for k in range(4)}


def test_wedge_normals_are_unit_vectors():
    """The wedge test's slack is in metres only for unit normals."""
    zv = np.zeros(3, dtype=complex)
    edges = (np.full(3, 1j), np.full(3, 1 + 0j))
    nxt = np.array([[2 - 1j, -1 + 2j, 0.3 - 0.2j]])  # the last closer than 1 m
    with np.errstate(all="raise"):
        normals, kind = taut_wedges(zv, edges, nxt, np.ones((1, 3)))
    assert kind.tolist() == [[1, 1, 1]]
    np.testing.assert_allclose(np.abs(normals), 1.0, rtol=0, atol=1e-12)


def test_the_far_edge_is_the_one_least_along_the_path():
    """A corner whose edges leave toward 170 and 80 degrees (the obstacle between them), the
    path leaving toward 230 degrees: the far edge is the one at 80 degrees (cos 150 < cos 60
    along the path), and the wedge runs from the path's extension beyond the corner (50
    degrees) to it."""

    def unit(deg):
        return complex(math.cos(math.radians(deg)), math.sin(math.radians(deg)))

    edges = (np.array([unit(170)]), np.array([unit(80)]))
    with np.errstate(all="raise"):
        normals, kind = taut_wedges(
            np.array([0j]), edges, np.array([[3 * unit(230)]]), np.ones((1, 1))
        )
    assert kind.tolist() == [[1]]
    for deg, inside in [(55, True), (65, True), (79, True), (45, False), (85, False),
                        (120, False), (230, False), (300, False)]:  # fmt: skip
        assert _in_wedge(normals[0, 0], 0j, 5 * unit(deg)) == inside, deg


def test_keys_of_the_undecided_pairs_stay_in_31_bits():
    """A 1 m x 1 m arena is one 16 m block of 32 x 32 cells whatever the sites: 1024 cells x
    2**21 sites = 2**31 keys is one too many."""

    def planner(n):
        return SimpleNamespace(
            spatial=SimpleNamespace(width_m=1.0, height_m=1.0), vertices_=np.zeros((n, 2))
        )

    assert DistanceField.fits(planner(10), 2**21 - 1)
    assert not DistanceField.fits(planner(10), 2**21)


def test_field_grid_of_a_vast_arena():
    """20 km x 20 km, one site: cells of 2.44 m keep the table below 128 MiB; 1 km x 1 km
    with 17,180 sites: cells of 16 m, blocks of one cell (no halving)."""
    grid, levels = _grid(20_000.0, 20_000.0, 1)
    assert grid.dx_m == pytest.approx(2.44, abs=0.01) and levels == 3
    grid, levels = _grid(1000.0, 1000.0, 17_180)
    assert levels == 0 and grid.dx_m == pytest.approx(16.13, abs=0.01)


def test_box_masks_at_cell_borders_and_off_square():
    grid = Grid(0.5, 1.0, 6, 4)  # 3 m x 4 m
    lo, hi = np.array([1.0, 2.0]), np.array([2.0, 3.5])
    meet = _in_box(grid, lo, hi).reshape(4, 6)
    want = np.zeros((4, 6), dtype=bool)
    want[1:4, 1:5] = True  # cells touching x = 1 and x = 2, y = 2 (row 1's top) count
    assert (meet == want).all()
    within = _within_box(grid, lo, hi).reshape(4, 6)
    want = np.zeros((4, 6), dtype=bool)
    want[2, 2:4] = True
    assert (within == want).all()
    tall = Grid(1.0, 0.5, 4, 6)  # 4 m x 3 m: rows of 0.5 m
    within = _within_box(tall, np.array([1.0, 1.0]), np.array([3.0, 2.0])).reshape(6, 4)
    want = np.zeros((6, 4), dtype=bool)
    want[2:4, 1:3] = True
    assert (within == want).all()
