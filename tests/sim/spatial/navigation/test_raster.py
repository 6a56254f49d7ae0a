"""The raster of shadows (`sim.spatial.navigation.raster`), function by function: hand-worked cases
and brute force (half-planes clipped cell by cell, segments clipped polygon by polygon).

`test_distfield.py` (beside this file) checks that the raster is *sound* (a FULL cell is
never blocked, a NONE cell never seen) on the planner's arenas; these tests also check that it
is *tight* (no cell is PART, no obstacle listed, that need not be), which soundness alone cannot
see, and the certainty margin at cell borders.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sim.spatial.navigation.raster import (
    FULL,
    NONE,
    PART,
    Grid,
    Obstacles,
    SightIndex,
    inside_rows,
    line_spans,
    meet_rows,
    paint,
    polygon_cells,
    region_vertices,
    shadow_halfplanes,
    tangents,
    visibility,
)

INF = math.inf


@pytest.fixture(autouse=True)
def _floating_point_errors_raise():
    """The raster silences the infinities it means (vertical edges, unbounded cones) where it
    makes them; anything else would raise here."""
    with np.errstate(all="raise"):
        yield


# -- brute force -------------------------------------------------------------------------


def halfplanes(poly) -> tuple[np.ndarray, np.ndarray]:
    """Unit outward normals and offsets of a counter-clockwise convex polygon: n . p < c."""
    v = np.asarray(poly, dtype=float)
    e = np.roll(v, -1, axis=0) - v
    n = np.stack([e[:, 1], -e[:, 0]], axis=1)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return n, (n * v).sum(axis=1)


def obstacles(polys, edges: int | None = None) -> Obstacles:
    """Polygons as the raster takes them, padded to ``edges`` (padding repeats the first
    vertex, has a zero normal and offset 1, and is not real)."""
    e = edges or max(len(p) for p in polys)
    k = len(polys)
    verts, normals = np.zeros((k, e, 2)), np.zeros((k, e, 2))
    offsets, real = np.ones((k, e)), np.zeros((k, e), dtype=bool)
    for i, p in enumerate(polys):
        n, c = halfplanes(p)
        verts[i, : len(p)], verts[i, len(p) :] = p, p[0]
        normals[i, : len(p)], offsets[i, : len(p)], real[i, : len(p)] = n, c, True
    return Obstacles(verts, normals, offsets, real)


def clip(poly: list, normals, offsets) -> list:
    """Sutherland-Hodgman: the part of a convex polygon where n . p <= c for every row."""
    for n, c in zip(normals, offsets, strict=True):
        out = []
        for a, b in zip(poly, poly[1:] + poly[:1], strict=True):
            fa, fb = n @ a - c, n @ b - c
            if fa <= 0:
                out.append(a)
            if (fa < 0 < fb) or (fb < 0 < fa):
                out.append(a + (b - a) * (fa / (fa - fb)))
        poly = out
        if not poly:
            break
    return poly


def area(poly: list) -> float:
    if len(poly) < 3:
        return 0.0
    p = np.asarray(poly)
    return 0.5 * abs(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1)))


def cell_box(grid: Grid, row: int, col: int) -> list:
    x0, y0 = col * grid.dx_m, row * grid.dy_m
    x1, y1 = x0 + grid.dx_m, y0 + grid.dy_m
    return [np.array(p) for p in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]


def meets(grid, row, col, normals, offsets, margin) -> bool:
    return area(clip(cell_box(grid, row, col), normals, offsets + margin)) > 0


def contains(grid, row, col, normals, offsets, margin) -> bool:
    corners = np.array(cell_box(grid, row, col))
    return bool((corners @ normals.T < offsets - margin).all())


def enters(x, q, normals, offsets) -> bool:
    """Cyrus-Beck: the segment x-q passes through the open convex polygon n . p < c."""
    d = q - x
    t0, t1 = 0.0, 1.0
    for n, c in zip(normals, offsets, strict=True):
        room, rate = c - n @ x, n @ d
        if rate == 0:
            if room <= 0:
                return False
        elif rate > 0:
            t1 = min(t1, room / rate)
        else:
            t0 = max(t0, room / rate)
    return t0 < t1


def convex(rng, centre, radius, n=6) -> list:
    """A random counter-clockwise convex polygon round ``centre``: corners at random angles on
    an ellipse of half-axes ``radius`` times 0.6-1 (an affine image of a circle's chords)."""
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    a, b = radius * rng.uniform(0.6, 1.0, 2)
    pts = centre + np.stack([a * np.cos(ang), b * np.sin(ang)], axis=1)
    return [tuple(p) for p in pts]


def rows_of(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and last True column per row of a (ny, nx) mask, first > last where none."""
    ny, nx = cells.shape
    first, last = np.full(ny, nx), np.full(ny, -1)
    for r in range(ny):
        c = np.flatnonzero(cells[r])
        if c.size:
            first[r], last[r] = c[0], c[-1]
    return first, last


def assert_rows(got, want_cells):
    """Row ranges (first, last) of one region equal the cells of a (ny, nx) mask."""
    first, last = got
    for r, (f, la) in enumerate(zip(*rows_of(want_cells), strict=True)):
        if f > la:
            assert first[r] > last[r], f"row {r}: ({first[r]}, {last[r]}), want none"
        else:
            assert (first[r], last[r]) == (f, la), f"row {r}"


SQUARE = [(2.0, 1.0), (4.0, 1.0), (4.0, 3.0), (2.0, 3.0)]  # [2, 4] x [1, 3]
PAD = (np.zeros((1, 2)), np.ones(1))


def region(poly):
    """One region (1, H, 2), (1, H) from a polygon, with one padding row."""
    n, c = halfplanes(poly)
    n, c = np.concatenate([n, PAD[0]]), np.concatenate([c, PAD[1]])
    return n[None], c[None]


# -- Grid --------------------------------------------------------------------------------


def test_grid_holds_points_on_it_borders_included():
    grid = Grid(0.5, 0.25, 8, 12)  # 4 m x 3 m
    xy = [
        (0, 0),
        (4, 3),
        (2, 1.5),
        (4 + 1e-9, 1),
        (1, 3 + 1e-9),
        (-1e-9, 1),
        (1, -1e-9),
        (3.5, 0.1),
        (4.5, 0.1),
        (0.1, 3.5),
    ]
    assert grid.holds(np.array(xy)).tolist() == [
        True, True, True, False, False, False, False, True, False, False
    ]  # fmt: skip


def test_grid_cells_number_row_by_row_and_clip_to_the_grid():
    grid = Grid(0.5, 0.25, 8, 12)
    xy = np.array([(1.2, 0.6), (0.0, 0.0), (3.99, 2.99), (-1.0, -1.0), (100.0, 100.0), (4, 3)])
    assert grid.cells(xy).tolist() == [2 * 8 + 2, 0, 11 * 8 + 7, 0, 95, 95]


# -- line spans and region vertices ------------------------------------------------------


def test_line_spans_of_a_square_open_at_its_borders():
    normals, offsets = region(SQUARE)
    ys = np.array([0.0, 1.0, 1.5, 2.0, 3.0, 4.0])
    lo, hi = line_spans(normals, offsets, ys)
    hit = np.array([False, False, True, True, False, False])  # n . p < c: y = 1, 3 miss
    assert (lo[0, hit] == 2.0).all() and (hi[0, hit] == 4.0).all()
    assert (hi[0, ~hit] == -INF).all()


def test_line_spans_take_normals_of_any_length():
    """Half-planes need not be normalised: y < 3 as 2 y < 6, x > 2 as -3 x < -6."""
    normals = np.array([[[0.0, 2.0], [-3.0, 0.0], [1.0, 1.0]]])  # and x + y < 6
    offsets = np.array([[6.0, -6.0, 6.0]])
    lo, hi = line_spans(normals, offsets, np.array([0.0, 2.5, 2.9, 3.0]))
    assert lo[0, :3].tolist() == [2.0, 2.0, 2.0]
    assert hi[0, :3].tolist() == [6.0, 3.5, 3.1]
    assert hi[0, 3] == -INF


def test_a_sloped_region_spans_by_its_edges():
    """The triangle (0, 0), (4, 0), (0, 4): x > 0, y > 0, x + y < 4."""
    normals, offsets = region([(0.0, 0.0), (4.0, 0.0), (0.0, 4.0)])
    lo, hi = line_spans(normals, offsets, np.array([0.5, 1.0, 3.0]))
    assert lo[0].tolist() == [0.0, 0.0, 0.0]
    assert hi[0].tolist() == [3.5, 3.0, 1.0]


@pytest.mark.parametrize("offset", [0.0, -1.0])
def test_a_zero_normal_that_nothing_satisfies_empties_the_region(offset):
    """0 . p < c holds nowhere for c <= 0 (and everywhere for c > 0, the padding)."""
    normals, offsets = region(SQUARE)
    normals = np.concatenate([normals, np.zeros((1, 1, 2))], axis=1)
    offsets = np.concatenate([offsets, [[offset]]], axis=1)
    _, hi = line_spans(normals, offsets, np.array([1.5, 2.0]))
    assert (hi == -INF).all()


def test_the_whole_plane_spans_every_line():
    lo, hi = line_spans(np.zeros((1, 3, 2)), np.ones((1, 3)), np.array([-5.0, 0.0, 7.0]))
    assert (lo == -INF).all() and (hi == INF).all()


def test_region_vertices_are_the_corners_only():
    """A square with its corner (4, 3) cut by x + y < 6.5: five corners; the pairs of parallel
    edges and the cut-off corner are not corners."""
    n, c = halfplanes(SQUARE)
    cut = np.array([[1.0, 1.0]]) / math.sqrt(2)
    n = np.concatenate([n, cut, PAD[0]])
    c = np.concatenate([c, [6.5 / math.sqrt(2)], PAD[1]])
    pts, ok = region_vertices(n[None], c[None])
    assert pts.shape == (1, 15, 2) and ok.shape == (1, 15)  # 6 lines: 15 pairs
    got = sorted((round(x, 9), round(y, 9)) for x, y in pts[0, ok[0]])
    assert got == [(2.0, 1.0), (2.0, 3.0), (3.5, 3.0), (4.0, 1.0), (4.0, 2.5)]


def test_parallel_edges_of_a_region_round_the_origin_meet_nowhere():
    """Parallel lines have no crossing (their "point" is not finite): not a corner, even when
    the region holds the origin, where such a point is first put to be tested."""
    pts, ok = region_vertices(*region([(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]))
    assert ok[0].sum() == 4
    got = sorted((round(x, 9), round(y, 9)) for x, y in pts[0, ok[0]])
    assert got == [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)]


# -- meeting and containing rows ---------------------------------------------------------


GRID = Grid(1.0, 1.0, 6, 5)


def test_a_square_on_grid_lines_meets_the_cells_beyond_its_borders():
    """The margin grows [2, 4] x [1, 3] by 1e-6: it then meets the cells across each border
    (columns 1 and 4, rows 0 and 3), and contains no cell whole."""
    normals, offsets = region(SQUARE)
    first, last = meet_rows(normals, offsets, GRID)
    assert first[0].tolist()[:4] == [1, 1, 1, 1] and last[0].tolist()[:4] == [4, 4, 4, 4]
    assert first[0, 4] > last[0, 4]
    first, last = inside_rows(normals, offsets, GRID)
    assert (first > last).all()


def test_a_square_off_the_grid_lines_contains_the_cells_inside_it():
    normals, offsets = region([(1.5, 0.5), (4.5, 0.5), (4.5, 3.5), (1.5, 3.5)])
    first, last = inside_rows(normals, offsets, GRID)
    assert first[0, 1:3].tolist() == [2, 2] and last[0, 1:3].tolist() == [3, 3]
    assert (first[0, [0, 3, 4]] > last[0, [0, 3, 4]]).all()
    first, last = meet_rows(normals, offsets, GRID)
    assert first[0, :4].tolist() == [1] * 4 and last[0, :4].tolist() == [4] * 4
    assert first[0, 4] > last[0, 4]


def test_a_vertex_inside_a_row_widens_that_row():
    """A diamond round (3, 2.5), corners (2, 2.5) and (4, 2.5) inside row 2: on the row's
    grid lines it spans only x in [2.5, 3.5], its corners reach columns 1 and 4 (grown by the
    margin, each corner moves 1.4e-6 m across the column border)."""
    normals, offsets = region([(3.0, 1.5), (4.0, 2.5), (3.0, 3.5), (2.0, 2.5)])
    first, last = meet_rows(normals, offsets, GRID)
    assert (first[0, 2], last[0, 2]) == (1, 4)
    assert (first[0, 1], last[0, 1]) == (2, 3)  # y 1..2: only its lower tip
    assert (first[0, 3], last[0, 3]) == (2, 3)


@pytest.mark.parametrize("row", [0, 4])
def test_a_region_within_one_row_is_found_by_its_vertices(row):
    """A diamond between two grid lines: no grid line meets it, only its corners do."""
    y = row + 0.5
    normals, offsets = region([(3.0, y - 0.4), (3.4, y), (3.0, y + 0.4), (2.6, y)])
    first, last = meet_rows(normals, offsets, GRID)
    for r in range(GRID.ny):
        if r == row:
            assert (first[0, r], last[0, r]) == (2, 3)
        else:
            assert first[0, r] > last[0, r]


def test_vertices_above_the_grid_are_not_counted():
    grid = Grid(1.0, 0.5, 6, 10)  # y up to 5; its corners (2, 5.6), (4, 5.6) lie above
    normals, offsets = region([(3.0, 4.6), (4.0, 5.6), (3.0, 6.6), (2.0, 5.6)])
    first, last = meet_rows(normals, offsets, grid)
    assert (first[0, 9], last[0, 9]) == (2, 3)  # x in [2.6, 3.4] on y = 5
    assert (first[0, :9] > last[0, :9]).all()


def test_a_vertex_rounding_onto_the_top_line_falls_in_the_last_row():
    """With 0.1 m rows, y = 1.7 lies below the top line 17 * 0.1 = 1.7000000000000002 but
    1.7 / 0.1 = 17.0: the vertex belongs to row 16, not to a row 17 that does not exist."""
    grid = Grid(1.0, 0.1, 6, 17)
    normals, offsets = region([(3.0, 1.6), (3.7, 1.7), (3.0, 1.8), (2.3, 1.7)])
    pts, ok = region_vertices(normals, offsets)
    y = pts[0, ok[0], 1]
    assert ((y < 17 * 0.1) & ((y / 0.1).astype(int) == 17)).any()  # the case is there
    first, last = meet_rows(normals, offsets, grid, margin_m=0.0)
    assert (first[0, 16], last[0, 16]) == (2, 3)
    assert (first[0, :16] > last[0, :16]).all()


@pytest.mark.parametrize(
    "poly, want",
    [
        ([(7.0, 1.0), (9.0, 1.0), (9.0, 3.0), (7.0, 3.0)], None),  # right of the grid
        ([(-3.0, 1.0), (-2.0, 1.0), (-2.0, 3.0), (-3.0, 3.0)], None),  # left of it
        ([(-3.0, 0.5), (9.0, 0.5), (9.0, 2.5), (-3.0, 2.5)], (0, 5)),  # across it
    ],
)
def test_regions_beyond_the_grid_sides(poly, want):
    normals, offsets = region(poly)
    for rows in (meet_rows, inside_rows):
        first, last = rows(normals, offsets, GRID)
        if want is None:
            assert (first > last).all(), rows.__name__
        else:
            assert (first[0, 1], last[0, 1]) == want, rows.__name__


def test_unbounded_regions_clip_to_the_grid():
    """x < 2.5 and the cone y > |x - 3| (open upward): infinite spans, finite columns."""
    left = (np.array([[[1.0, 0.0]]]), np.array([[2.5]]))
    first, last = meet_rows(*left, GRID)
    assert first[0].tolist() == [0] * 5 and last[0].tolist() == [2] * 5
    first, last = inside_rows(*left, GRID)
    assert first[0].tolist() == [0] * 5 and last[0].tolist() == [1] * 5
    s = 1 / math.sqrt(2)
    cone = (np.array([[[s, -s], [-s, -s]]]), np.array([[3 * s, -3 * s]]))
    first, last = inside_rows(*cone, GRID)
    for r in range(GRID.ny):  # corners (c, r) and (c + 1, r): c > 3 - r and c + 1 < 3 + r
        lo_c, hi_c = max(4 - r, 0), min(r + 1, GRID.nx - 1)
        if lo_c <= hi_c:
            assert (first[0, r], last[0, r]) == (lo_c, hi_c), r
        else:
            assert first[0, r] > last[0, r], r


def test_rows_agree_with_clipping_cells_one_by_one():
    """Random convex regions (polygons, and cones open to one side) on a 0.5 m x 0.4 m grid:
    the cells met (grown by the margin) and contained (shrunk by it) are those clipping finds,
    away from cells a region touches within 1e-4 m."""
    rng = np.random.default_rng(11)
    grid = Grid(0.5, 0.4, 14, 12)
    regions = [
        halfplanes(convex(rng, rng.uniform(0, 7, 2), rng.uniform(0.3, 3))) for _ in range(30)
    ]
    for _ in range(10):  # cones: two half-planes through an apex
        apex, a = rng.uniform(0, 6, 2), rng.uniform(0, 2 * np.pi)
        w = rng.uniform(0.2, 2.5)
        dirs = np.array(
            [[math.cos(a - w / 2), math.sin(a - w / 2)], [math.cos(a + w / 2), math.sin(a + w / 2)]]
        )
        n = np.array([[dirs[0, 1], -dirs[0, 0]], [-dirs[1, 1], dirs[1, 0]]])
        regions.append((n, n @ apex))
    h = max(len(c) for _, c in regions) + 1
    normals, offsets = np.zeros((len(regions), h, 2)), np.ones((len(regions), h))
    for i, (n, c) in enumerate(regions):
        normals[i, : len(c)], offsets[i, : len(c)] = n, c
    met, held = meet_rows(normals, offsets, grid), inside_rows(normals, offsets, grid)
    checked = 0
    for i, (n, c) in enumerate(regions):
        for r in range(grid.ny):
            for col in range(grid.nx):
                m_sure = meets(grid, r, col, n, c, -1e-4)
                m_maybe = meets(grid, r, col, n, c, 1e-4)
                c_sure = contains(grid, r, col, n, c, 1e-4)
                c_maybe = contains(grid, r, col, n, c, -1e-4)
                in_met = met[0][i, r] <= col <= met[1][i, r]
                in_held = held[0][i, r] <= col <= held[1][i, r]
                if m_sure == m_maybe:
                    assert in_met == m_sure, (i, r, col)
                    checked += 1
                if c_sure == c_maybe:
                    assert in_held == c_sure, (i, r, col)
    assert checked > 0.97 * len(regions) * grid.nx * grid.ny


# -- paint -------------------------------------------------------------------------------


def test_paint_counts_the_ranges_over_each_cell_by_owner():
    grid = Grid(1.0, 1.0, 5, 2)
    lo = np.array([[0, 3], [2, 4], [1, 0]])
    hi = np.array([[2, 2], [4, 4], [1, 4]])  # region 0, row 1: empty (3 > 2)
    owner = np.array([0, 0, 1])
    got = paint(lo, hi, owner, 2, grid)
    assert got.shape == (2, 2, 5)
    assert got[0].tolist() == [[1, 1, 2, 1, 1], [0, 0, 0, 0, 1]]
    assert got[1].tolist() == [[0, 1, 0, 0, 0], [1, 1, 1, 1, 1]]


def test_polygon_cells_meet_and_hold():
    polys = obstacles([[(1.5, 0.5), (4.5, 0.5), (4.5, 3.5), (1.5, 3.5)]], edges=6)
    met, inside = polygon_cells(polys, GRID)
    want_met = np.zeros((5, 6), dtype=bool)
    want_met[0:4, 1:5] = True
    want_in = np.zeros((5, 6), dtype=bool)
    want_in[1:3, 2:4] = True
    assert (met == want_met).all() and (inside == want_in).all()
    none = obstacles([[(0, 0), (1, 0), (0, 1)]])
    none = Obstacles(none.verts[:0], none.normals[:0], none.offsets[:0], none.real[:0])
    met, inside = polygon_cells(none, GRID)
    assert met.shape == (5, 6) and not met.any() and not inside.any()


# -- tangents and shadows ----------------------------------------------------------------


def test_tangents_of_a_square_seen_from_its_left():
    polys = obstacles([SQUARE])
    front, dr, dl = tangents(np.array([[0.5, 2.0]]), polys)
    assert front[0, 0].tolist() == [False, False, False, True]  # the left edge x = 2
    assert dr[0, 0].tolist() == [1.5, -1.0] and dl[0, 0].tolist() == [1.5, 1.0]


def test_tangents_from_a_vertex_of_the_obstacle():
    """Seen from its own corner (2, 1), a 0.5 m square lies between +x and +y; the two edges
    through the corner face it (the point is on their lines)."""
    polys = obstacles([[(2.0, 1.0), (2.5, 1.0), (2.5, 1.5), (2.0, 1.5)]])
    front, dr, dl = tangents(np.array([[2.0, 1.0]]), polys)
    assert front[0, 0].tolist() == [True, False, False, True]
    assert dr[0, 0].tolist() == [0.5, 0.0] and dl[0, 0].tolist() == [0.0, 0.5]


def test_shadows_are_the_points_a_segment_reaches_only_through_an_obstacle():
    """Random convex obstacles and viewpoints (one on a vertex, one inside an obstacle): a
    point lies in a piece iff it is hidden and outside the obstacle, and in the whole shadow
    iff it is hidden or inside."""
    rng = np.random.default_rng(5)
    polys = [convex(rng, c, 1.2) for c in ([3.0, 3.0], [7.0, 2.0], [5.0, 7.0])]
    obs = obstacles(polys, edges=8)
    points = np.concatenate(
        [rng.uniform(0, 10, (6, 2)), [polys[1][2]], [[5.0, 7.0]]]  # a vertex, an inside point
    )
    points = points[[not any(enters(p, p, *halfplanes(q)) for q in polys) or i >= 6
                     for i, p in enumerate(points)]]  # fmt: skip
    (wn, wc), (pn, pc, of) = shadow_halfplanes(points, obs)
    k = len(polys)
    front = tangents(points, obs)[0]  # pieces come point by point, obstacle by obstacle
    piece_obstacle = np.nonzero(obs.real & ~front)[1]
    assert len(piece_obstacle) == len(of)
    assert wn.shape == (len(points) * k, 2 + 8, 2) and wc.shape == (len(points) * k, 10)
    cones = np.linalg.norm(wn[:, :2], axis=-1)
    assert np.allclose(cones[cones > 0], 1.0, rtol=0, atol=1e-12)  # margins are in metres
    q = rng.uniform(-2, 12, (400, 2))
    for p_i, x in enumerate(points):
        for k_i, poly in enumerate(polys):
            n, c = halfplanes(poly)
            inside = (q @ n.T < c).all(axis=1)
            hidden = np.array([enters(x, y, n, c) for y in q])
            r = p_i * k + k_i
            in_whole = (q @ wn[r].T < wc[r]).all(axis=1)
            assert (in_whole == (hidden | inside)).all(), (p_i, k_i)
            in_piece = np.zeros(len(q), dtype=bool)
            for j in np.flatnonzero((of == p_i) & (piece_obstacle == k_i)):
                in_piece |= (q @ pn[j].T < pc[j]).all(axis=1)
            assert (in_piece == (hidden & ~inside)).all(), (p_i, k_i)


def test_a_point_inside_an_obstacle_sees_nothing():
    polys = obstacles([SQUARE])
    (wn, wc), _ = shadow_halfplanes(np.array([[3.0, 2.0]]), polys)
    lo, hi = line_spans(wn, wc, np.array([-10.0, 2.0, 10.0]))
    assert (lo == -INF).all() and (hi == INF).all()
    cls = visibility(np.array([[3.0, 2.0]]), polys, GRID)
    assert (cls == NONE).all()


# -- visibility --------------------------------------------------------------------------


def brute_visibility(points, polys, grid, margin=1e-4):
    """Classes by clipping each cell with each shadow, and which cells are decided (the same
    class with every shadow grown and shrunk by ``margin``)."""
    out = np.full((len(points), grid.ny, grid.nx), FULL, dtype=np.uint8)
    decided = np.ones(out.shape, dtype=bool)
    for p_i, x in enumerate(points):
        shadows = []
        for poly in polys:
            n, c = halfplanes(poly)
            front = n @ x - c >= 0
            if not front.any():  # inside: the whole plane is shadow, pieces lie beyond edges
                cone_n, cone_c = np.zeros((0, 2)), np.zeros(0)
            else:  # tangents: the extreme angles seen round the direction to the centroid
                d = np.asarray(poly) - x
                ref = np.mean(poly, axis=0) - x
                rel = np.arctan2(d @ [-ref[1], ref[0]], d @ ref)
                dr, dl = d[np.argmin(rel)], d[np.argmax(rel)]
                nr = np.array([dr[1], -dr[0]]) / np.hypot(*dr)
                nl = np.array([-dl[1], dl[0]]) / np.hypot(*dl)
                cone_n, cone_c = np.array([nr, nl]), np.array([nr @ x, nl @ x])
            whole = (np.concatenate([cone_n, n[front]]), np.concatenate([cone_c, c[front]]))
            pieces = [
                (np.concatenate([cone_n, -n[[e]]]), np.concatenate([cone_c, -c[[e]]]))
                for e in np.flatnonzero(~front)
            ]
            shadows.append((whole, pieces))
        for r in range(grid.ny):
            for col in range(grid.nx):
                hid = [contains(grid, r, col, *w, s * margin) for w, _ in shadows for s in (1, -1)]
                met = [meets(grid, r, col, *pc, s * margin) for _, ps in shadows for pc in ps
                       for s in (-1, 1)]  # fmt: skip
                sure_hid, maybe_hid = any(hid[0::2]), any(hid[1::2])
                sure_met, maybe_met = any(met[0::2]), any(met[1::2])
                out[p_i, r, col] = NONE if sure_hid else PART if sure_met else FULL
                decided[p_i, r, col] = sure_hid == maybe_hid and sure_met == maybe_met
    return out, decided


def test_visibility_equals_clipping_cell_by_cell():
    """Three random convex obstacles and a box, viewpoints around and between them (one on
    a grid line in line with the box's edge, one inside the box): FULL, PART and NONE
    exactly as clipping finds, on every cell whose class no 1e-4 m would change."""
    rng = np.random.default_rng(3)
    polys = [convex(rng, c, 1.0) for c in ([2.2, 2.4], [4.6, 1.3], [3.9, 4.2])]
    polys.append([(0.5, 4.0), (1.5, 4.0), (1.5, 4.6), (0.5, 4.6)])  # an axis-aligned box
    points = np.array([[0.3, 0.4], [5.7, 5.1], [3.1, 2.9], [0.2, 2.0], [3.0, 4.0], [1.0, 4.3]])
    grid = Grid(0.5, 0.5, 12, 10)
    got = visibility(points, obstacles(polys, edges=6), grid, chunk=2)
    assert got.dtype == np.uint8 and got.shape == (6, 10, 12)
    want, decided = brute_visibility(points, polys, grid)
    assert decided.mean() > 0.95
    assert (got[decided] == want[decided]).all()
    assert (got == PART).any() and (got == NONE).any() and (got == FULL).any()


def test_visibility_without_obstacles_is_full():
    none = obstacles([SQUARE])
    none = Obstacles(none.verts[:0], none.normals[:0], none.offsets[:0], none.real[:0])
    got = visibility(np.array([[1.0, 1.0], [2.0, 2.0]]), none, GRID)
    assert got.dtype == np.uint8 and got.shape == (2, 5, 6) and (got == FULL).all()


def test_the_margin_makes_full_and_none_certain_at_cell_borders():
    """A point at (0.5, 2) before the square [2, 4] x [1, 3]: the shadow's border x = 2 runs
    along a grid line and its corners (2, 1) and (2, 3) are cell corners. Column 1 touches
    the shadow only there, but within the margin: PART in rows 0-3, FULL beyond; column 2 is
    PART (the margin cannot promise it hidden); column 3, rows 1-2, is NONE."""
    got = visibility(np.array([[0.5, 2.0]]), obstacles([SQUARE]), GRID)[0]
    assert (got[:, 0] == FULL).all()
    assert got[:, 1].tolist() == [PART, PART, PART, PART, FULL]
    assert got[1, 2] == PART and got[2, 2] == PART
    assert got[1, 3] == NONE and got[2, 3] == NONE


# -- the sight index ---------------------------------------------------------------------


def _sight_scene():
    a = [(2.0, 0.5), (3.0, 0.5), (3.0, 1.5), (2.0, 1.5)]  # from (0, 0): angles 0.17-0.64
    b = [(-3.0, -0.5), (-2.0, -0.5), (-2.0, 0.5), (-3.0, 0.5)]  # across the angle pi
    c = [(9.0, 9.0), (11.0, 9.0), (11.0, 11.0), (9.0, 11.0)]  # holds the second point
    return np.array([[0.0, 0.0], [10.0, 10.0]]), obstacles([a, b, c])


def test_sight_index_lists_exactly_the_obstacles_of_each_sector():
    """Eight sectors of pi/4: from (0, 0) A covers sector 0, B sectors 3 and 4 (across pi),
    C sectors 0 and 1; from (10, 10), inside C, C covers all eight, B sector 4, A sector 5."""
    points, polys = _sight_scene()
    index = SightIndex(points, polys, bins=8)
    want = {
        0: {0: {0, 2}, 1: {2}, 3: {1}, 4: {1}},
        1: {s: {2} for s in range(8)} | {4: {1, 2}, 5: {0, 2}},
    }
    for p in (0, 1):
        mid = (np.arange(8) + 0.5) * np.pi / 4
        towards = points[p] + 5 * np.stack([np.cos(mid), np.sin(mid)], axis=1)
        seg, obstacle = index.candidates(np.full(8, p), towards)
        for s in range(8):
            assert set(obstacle[seg == s].tolist()) == want[p].get(s, set()), (p, s)
    assert index.nbytes == 15 * 2 + (2 * 8 + 1) * 8  # 15 (sector, obstacle) entries


def test_sight_index_candidates_come_in_segment_order():
    points, polys = _sight_scene()
    index = SightIndex(points, polys, bins=8)
    towards = np.array([[5.0, 1.0], [-5.0, 0.1], [20.0, 10.0]])
    seg, obstacle = index.candidates(np.array([0, 0, 1]), towards)
    assert seg.tolist() == [0, 0, 1, 2]
    assert obstacle.tolist() == [0, 2, 1, 2]


def test_a_sight_index_without_obstacles_lists_none():
    _, polys = _sight_scene()
    none = Obstacles(polys.verts[:0], polys.normals[:0], polys.offsets[:0], polys.real[:0])
    index = SightIndex(np.array([[0.0, 0.0], [1.0, 1.0]]), none, bins=16)
    seg, obstacle = index.candidates(np.array([0, 1, 1]), np.array([[1.0, 0], [0, 0], [5, 5]]))
    assert seg.size == 0 and obstacle.size == 0
    assert index.nbytes == (2 * 16 + 1) * 8
