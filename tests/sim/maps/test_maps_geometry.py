"""Cells to convex polygons: fidelity to the grid both ways, valid polygons, specks, pockets,
holes, and walls one cell thick that stay walls."""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import numpy as np
import pymunk
import pytest
from scipy import ndimage

from sim.maps import Clearance, MapGeometry, cleaned_cells, load_map, map_obstacles
from sim.maps.contours import trace_loops
from sim.maps.decompose import convex_pieces
from sim.maps.lattice import area2, turns
from sim.maps.simplify import simplify_loops
from sim.scenario import ScenarioError, SpatialSpec
from sim.spatial.navigation.planning import GridPlanner

MAPS = Path(__file__).resolve().parents[3] / "scenarios" / "data" / "maps"


@pytest.fixture(scope="module", params=["depot", "tb3_sandbox"])
def bundled(request):
    occ = load_map(MAPS / f"{request.param}.yaml")
    return request.param, occ, map_obstacles(occ)


def covered(geometry: MapGeometry, pts: np.ndarray) -> np.ndarray:
    """(n,) True where points (n, 2), in half cells, are inside or on some polygon (exact)."""
    pts = np.asarray(pts, dtype=np.int64)
    out = np.zeros(len(pts), dtype=bool)
    starts = geometry.starts.tolist()
    for s, e in itertools.pairwise(starts):
        poly = geometry.corners[s:e]
        lo, hi = poly.min(axis=0), poly.max(axis=0)
        near = np.flatnonzero(((pts >= lo) & (pts <= hi)).all(axis=1) & ~out)
        if not len(near):
            continue
        p = pts[near]
        inside = np.ones(len(near), dtype=bool)
        for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
            inside &= (b[0] - a[0]) * (p[:, 1] - a[1]) - (b[1] - a[1]) * (p[:, 0] - a[0]) >= 0
        out[near[inside]] = True
    return out


def cell_points(shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """(centres, corners) of every cell in half cells: (ny * nx, 2) and (ny * nx, 4, 2)."""
    j, i = np.mgrid[0 : shape[0], 0 : shape[1]]
    x, y = 2 * i.ravel(), 2 * j.ravel()
    centres = np.column_stack([x + 1, y + 1])
    corners = np.stack(
        [np.column_stack([x + dx, y + dy]) for dx, dy in ((0, 0), (2, 0), (0, 2), (2, 2))], axis=1
    )
    return centres, corners


def check_polygons(geometry: MapGeometry) -> None:
    """Each polygon: >= 3 corners, strictly convex and counter-clockwise (exact, on the integer
    corners), inside the map."""
    ny2, nx2 = (
        round(geometry.height_m / geometry.resolution_m) * 2,
        round(geometry.width_m / geometry.resolution_m) * 2,
    )
    starts = geometry.starts.tolist()
    for s, e in itertools.pairwise(starts):
        p = geometry.corners[s:e]
        assert len(p) >= 3
        u, w = p - np.roll(p, 1, axis=0), np.roll(p, -1, axis=0) - p
        assert (u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0] > 0).all()
        assert len(np.unique(p, axis=0)) == len(p)
        x, y = p[:, 0], p[:, 1]
        assert (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() > 0
        assert (p >= 0).all() and (p[:, 0] <= nx2).all() and (p[:, 1] <= ny2).all()


def test_bundled_polygons_pass_the_scenario_schema_and_pymunk(bundled):
    _name, occ, geometry = bundled
    check_polygons(geometry)
    spec = SpatialSpec(
        width_m=geometry.width_m, height_m=geometry.height_m, obstacles=geometry.arena_polygons
    )  # SpatialSpec checks its obstacles: convex, counter-clockwise, inside the arena
    assert spec.obstacles == geometry.arena_polygons
    for poly in geometry.arena_polygons:
        assert len(pymunk.Poly(None, poly).get_vertices()) == len(poly)  # its own convex hull
    ox, oy = occ.origin_xy
    first = np.array(geometry.polygons[0]) - np.array(geometry.arena_polygons[0])
    assert np.allclose(first, [ox, oy])


def test_the_schema_check_is_the_one_that_rejects_bad_polygons():
    with pytest.raises(ScenarioError, match="must be convex"):
        SpatialSpec(width_m=5.0, height_m=5.0, obstacles=(((0, 0), (1, 0), (2, 0), (1, 1)),))
    with pytest.raises(ScenarioError, match="outside the arena"):
        SpatialSpec(width_m=5.0, height_m=5.0, obstacles=(((0, 0), (5.1, 0), (1, 1)),))


def test_bundled_polygons_match_the_cells_both_ways(bundled, report_line):
    """Every cleaned blocked cell (its centre and its four corners) is covered: the polygons
    only ever add to the blocked cells. A free cell centre is covered only within tolerance_m
    plus a quarter cell (a saddle's cut) of a blocked cell, so within one cell plus tolerance_m
    of the boundary, measured centre to centre."""
    name, occ, geometry = bundled
    res, tol = occ.resolution_m, geometry.tolerance_m
    cleaned = cleaned_cells(occ).blocked
    centres, corners = cell_points(occ.shape)
    on = covered(geometry, centres).reshape(occ.shape)
    assert on[cleaned].all()
    blocked_corners = corners[cleaned.ravel()].reshape(-1, 2)
    assert covered(geometry, blocked_corners).all()
    extra = on & ~cleaned
    j, i = np.nonzero(extra)
    clear = Clearance.build(cleaned, res, (0.0, 0.0)).query(
        np.column_stack([(i + 0.5) * res, (j + 0.5) * res])
    )[1]
    assert clear.max() <= tol + 0.25 * res + 1e-9
    to_blocked = ndimage.distance_transform_edt(~cleaned) * res
    assert to_blocked[extra].max() <= res + tol + 1e-9
    report_line(
        f"maps fidelity {name}: all {int(cleaned.sum())} blocked cells covered; "
        f"{int(extra.sum())} free cells covered, at most {clear.max():.4f} m from a blocked "
        f"cell (bound tolerance + res/4 = {tol + res / 4:.4f} m)"
    )


def test_specks_are_counted_as_an_independent_labelling_counts_them(bundled):
    name, occ, geometry = bundled
    labels, _n = ndimage.label(occ.blocked, structure=np.ones((3, 3)))
    sizes = np.bincount(labels.ravel())[1:]
    small = sizes * occ.resolution_m**2 < geometry.min_speck_m2
    assert geometry.specks_dropped == int(small.sum()) == {"depot": 64, "tb3_sandbox": 0}[name]
    assert geometry.speck_area_m2 == pytest.approx(sizes[small].sum() * occ.resolution_m**2)


def test_without_tolerance_the_polygons_are_the_cells_exactly(text_map):
    occ = load_map(
        text_map(
            [
                "..........",
                ".####.....",
                ".#..#..#..",
                ".####...#.",
                "......#...",
                "..........",
            ]
        )
    )
    geometry = map_obstacles(occ, tolerance_m=0.0, min_speck_m2=0.0, min_pocket_m2=0.0)
    centres, _ = cell_points(occ.shape)
    on = covered(geometry, centres).reshape(occ.shape)
    assert np.array_equal(on, occ.blocked)
    check_polygons(geometry)
    area = sum(_area(p) for p in geometry.arena_polygons)
    blocked = occ.blocked.sum() * 0.05**2
    cuts = 2 * (0.025**2 / 2)  # one saddle (the lone diagonal pair): two corner cuts
    assert area == pytest.approx(blocked + cuts)


def _area(poly) -> float:
    p = np.asarray(poly)
    return 0.5 * float((p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]).sum())


def planner(geometry: MapGeometry, radius_m: float = 0.1) -> GridPlanner:
    spec = SpatialSpec(
        width_m=geometry.width_m,
        height_m=geometry.height_m,
        obstacles=geometry.arena_polygons,
        sites=(((0.5, 0.5),),),
    )
    spec = _with_radius(spec, radius_m)
    return GridPlanner(spec)


def _with_radius(spec: SpatialSpec, radius_m: float) -> SpatialSpec:
    drive = dataclasses.replace(spec.drive, radius_m=radius_m, wheel_base_m=radius_m)
    return dataclasses.replace(spec, drive=drive, clearance_m=0.0)


@pytest.mark.parametrize("tolerance_m", [0.0, 0.05, 0.2])
def test_a_wall_one_cell_thick_stays_a_wall(text_map, tolerance_m):
    """A straight wall and a diagonal one (cells touching only at corners) split the map; the
    polygons cover every point of their cells, and no planned path crosses them."""
    n = 40
    straight = np.full((n, n), ".")
    straight[:, n // 2] = "#"
    diagonal = np.full((n, n), ".")
    diagonal[np.arange(n), np.arange(n)] = "#"
    for rows, a, b in (
        (straight, (0.5, 1.0), (1.5, 1.0)),
        (diagonal, (0.45, 0.45), (1.55, 1.55)),  # the wall runs from top left to bottom right
    ):
        occ = load_map(text_map(["".join(r) for r in rows]))
        geometry = map_obstacles(occ, tolerance_m=tolerance_m)
        check_polygons(geometry)
        j, i = np.nonzero(occ.blocked)
        fine = np.array([(2 * i + dx, 2 * j + dy) for dx in (0, 1, 2) for dy in (0, 1, 2)])
        assert covered(geometry, fine.transpose(0, 2, 1).reshape(-1, 2)).all()
        plan = planner(geometry)
        assert plan.reachable(a) and plan.reachable(b)
        assert not np.isfinite(plan.distances(np.array([a]), np.array([b]))[0, 0])
        assert len(plan.path(a, b)) == 0


def test_specks_go_and_are_counted_pillars_stay(text_map):
    occ = load_map(
        text_map(
            ["..........", ".#........", "......##..", ".......#..", "..........", "..#......."]
        )
    )
    geometry = map_obstacles(occ)  # min_speck_m2 0.004: one cell (0.0025 m2) goes, three stay
    assert geometry.specks_dropped == 2 and geometry.speck_area_m2 == pytest.approx(2 * 0.0025)
    assert geometry.n_polygons >= 1
    centres, _ = cell_points(occ.shape)
    on = covered(geometry, centres).reshape(occ.shape)
    assert on[3, 6] and on[3, 7] and on[2, 7] and not on[4, 1] and not on[0, 2]
    assert map_obstacles(occ, min_speck_m2=0.0).specks_dropped == 0


def test_pockets_and_holes(text_map):
    """A one-cell pocket is filled and counted; a large enclosed room stays a hole (the ring
    round it is decomposed with the hole cut in, a pillar inside is its own polygon);
    fill_detached fills the room too."""
    ring = ["." * 16, "." + "#" * 14 + "."]
    ring += ["." + "#" + "." * 12 + "#" + "."] * 10
    ring += ["." + "#" * 14 + ".", "." * 16]
    ring[6] = ".#...#" + "." * 8 + "#."  # a one-cell pillar in the room
    block = ["." + "#" * 5 + "." * 10, ".##.##" + "." * 10, "." + "#" * 5 + "." * 10]
    rows = ring + block + ["." * 16] * 8  # the floor outside is the largest free region
    occ = load_map(text_map(rows))
    geometry = map_obstacles(occ, min_speck_m2=0.0)
    assert geometry.pockets_filled == 1 and geometry.pocket_area_m2 == pytest.approx(0.0025)
    check_polygons(geometry)
    centres, _ = cell_points(occ.shape)
    on = covered(geometry, centres).reshape(occ.shape)
    room = np.zeros((len(rows), 16), dtype=bool)
    room[2:12, 2:14] = True
    room = np.flipud(room) & ~occ.blocked
    assert on[occ.blocked].all()
    assert not on[room].any()  # a tolerance of one cell keeps the room's free cells free here
    assert on[len(rows) - 1 - 15, 3]  # the pocket
    filled = map_obstacles(occ, min_speck_m2=0.0, fill_detached=True)
    on = covered(filled, centres).reshape(occ.shape)
    assert on[room].all() and filled.pockets_filled == 2
    assert filled.n_polygons < geometry.n_polygons


def test_a_band_round_the_map_with_the_arena_as_its_hole(text_map):
    """As tb3_sandbox: unknown cells everywhere but a free octagon in the middle."""
    n = 30
    j, i = np.mgrid[0:n, 0:n]
    c = (n - 1) / 2
    inside = (np.abs(i - c) + np.abs(j - c) < 14) & (np.abs(i - c) < 11) & (np.abs(j - c) < 11)
    rows = ["".join("." if v else "?" for v in row) for row in inside]
    occ = load_map(text_map(rows))
    geometry = map_obstacles(occ)
    check_polygons(geometry)
    centres, _ = cell_points(occ.shape)
    on = covered(geometry, centres).reshape(occ.shape)
    assert on[occ.blocked].all() and not on[n // 2, n // 2]
    assert geometry.n_polygons <= 16
    total = sum(_area(p) for p in geometry.arena_polygons)
    assert total >= occ.blocked.sum() * 0.05**2 - 1e-9


def pieces_of(blocked: np.ndarray, tol: float) -> list[np.ndarray]:
    """The pipeline of map_obstacles on a bare grid: trace, simplify, decompose."""
    loops, n = trace_loops(blocked)
    outline, holes = {}, {k: [] for k in range(1, n + 1)}
    for loop in loops:
        if loop.outer:
            outline[loop.component] = loop.points
        else:
            holes[loop.component].append(loop.points)
    out = []
    for k in sorted(outline):
        rings = simplify_loops([outline[k], *holes[k]], tol)
        out += convex_pieces(rings[0], rings[1:])
    return out


@pytest.mark.parametrize("seed", range(4))
def test_random_grids_become_convex_pieces_that_cover_their_cells(seed):
    """Noise, blobs, saddles and holes of every shape: the pieces are strictly convex and
    counter-clockwise, cover every blocked cell, and without tolerance cover nothing else."""
    rng = np.random.default_rng(seed)
    for _ in range(10):
        ny, nx = rng.integers(3, 30, size=2)
        blocked = rng.random((ny, nx)) < rng.uniform(0.1, 0.7)
        if rng.random() < 0.5:
            blocked = ndimage.binary_opening(blocked) | (rng.random((ny, nx)) < 0.05)
        tol = float(rng.choice([0.0, 1.0, 2.0, 6.0]))
        pieces = pieces_of(blocked, tol)
        assert all(len(p) >= 3 and (turns(p) > 0).all() for p in pieces)
        starts = np.concatenate([[0], np.cumsum([len(p) for p in pieces])])
        corners = np.concatenate(pieces) if pieces else np.zeros((0, 2), dtype=np.int64)
        geometry = MapGeometry.from_corners(
            corners,
            starts,
            resolution_m=1.0,
            origin_xy=(0.0, 0.0),
            width_m=float(nx),
            height_m=float(ny),
            specks_dropped=0,
            speck_area_m2=0.0,
            pockets_filled=0,
            pocket_area_m2=0.0,
            min_speck_m2=0.0,
            min_pocket_m2=0.0,
            fill_detached=False,
            tolerance_m=tol / 2,
            map_sha256="",
        )
        centres, _ = cell_points((ny, nx))
        on = covered(geometry, centres).reshape(ny, nx)
        assert on[blocked].all()
        if tol == 0:
            assert not on[~blocked].any()


def test_a_checkerboard_of_saddles():
    blocked = np.add.outer(np.arange(12), np.arange(12)) % 2 == 0
    pieces = pieces_of(blocked, 0.0)
    # a cell is 2 x 2 half cells; each of the 11 x 11 saddles adds two cuts of half a half cell
    assert sum(area2(p) for p in pieces) == 2 * (4 * int(blocked.sum()) + 121)
