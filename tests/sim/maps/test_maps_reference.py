"""The grid's own ground truth (clearance, eroded free cells, grid distances), and the planner
built on each bundled map's polygons measured against it."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse.csgraph import connected_components

from sim.maps import Clearance, GridReference, cleaned_cells, load_map, map_obstacles
from sim.maps.reference import eroded_free, moves
from sim.scenario import SpatialSpec
from sim.spatial.navigation.planning import GridPlanner

MAPS = Path(__file__).resolve().parents[3] / "scenarios" / "data" / "maps"
METRIC = 1.0 / math.cos(math.atan2(1, 3) / 2)  # reach 3: the widest gap between moves, 18.4 deg


def test_clearance_is_the_distance_to_the_nearest_blocked_square_or_the_edge():
    blocked = np.zeros((20, 30), dtype=bool)
    blocked[10, 12] = True  # with 1 m cells and the origin at (-5, 0): [7, 8] x [10, 11]
    clear = Clearance.build(blocked, 1.0, (-5.0, 0.0))
    pts = np.array([[7.5, 10.5], [7.7, 13.0], [9.0, 14.0], [7.5, 10.9], [-5.5, 3.0], [-4.7, 5.0]])
    on_free, dist = clear.query(pts)
    assert on_free.tolist() == [False, True, True, False, False, True]
    assert dist.tolist()[0] == dist.tolist()[3] == dist.tolist()[4] == 0.0
    assert dist[1] == pytest.approx(2.0)  # straight above the cell, 2 m from its top
    assert dist[2] == pytest.approx(math.hypot(9 - 8, 14 - 11))  # nearer its corner than the edge
    assert dist[5] == pytest.approx(0.3)  # the map's left edge


def test_clearance_agrees_with_brute_force_on_random_points():
    rng = np.random.default_rng(3)
    blocked = rng.random((30, 40)) < 0.05
    res, origin = 0.1, (1.0, -2.0)
    clear = Clearance.build(blocked, res, origin)
    pts = np.column_stack([rng.uniform(1.0, 5.0, 300), rng.uniform(-2.0, 1.0, 300)])
    on_free, dist = clear.query(pts)
    j, i = np.nonzero(blocked)
    lo = np.column_stack([origin[0] + i * res, origin[1] + j * res])
    for p, free, d in zip(pts, on_free, dist, strict=True):
        gap = np.maximum(np.maximum(lo - p, p - (lo + res)), 0.0)
        square = np.linalg.norm(gap, axis=1).min()
        edge = min(p[0] - 1.0, 5.0 - p[0], p[1] + 2.0, 1.0 - p[1])
        assert d == pytest.approx(min(square, edge) if free else 0.0, abs=1e-12)


def test_erosion_keeps_the_cells_with_room_for_a_robot_centre():
    blocked = np.zeros((20, 20), dtype=bool)
    blocked[:, 10] = True
    free = eroded_free(blocked, 0.1, (0.0, 0.0), 0.24)
    # centres at x = (i + 0.5) * 0.1; the wall spans [1.0, 1.1]; the edges are at 0 and 2
    assert free[10].tolist() == [False] * 2 + [True] * 6 + [False] * 5 + [True] * 5 + [False] * 2


def test_moves_are_one_per_direction():
    assert len(moves(1)) == 4 and len(moves(2)) == 8 and len(moves(3)) == 16


def test_grid_distances_in_open_space_are_within_the_metric_bound():
    blocked = np.zeros((60, 60), dtype=bool)
    ref = GridReference.build(blocked, 0.1, (0.0, 0.0), inflate_m=0.0)
    a = np.array([[0.05, 0.05]])
    rng = np.random.default_rng(5)
    b = (rng.integers(0, 60, size=(50, 2)) + 0.5) * 0.1
    d = ref.distances(a, b)[0]
    straight = np.linalg.norm(b - a, axis=1)
    assert (d >= straight - 1e-9).all() and (d <= METRIC * straight + 1e-9).all()
    assert ref.distances(a, np.array([[3.05, 1.05]]))[0, 0] == pytest.approx(math.hypot(3, 1))


def test_grid_distances_go_round_a_wall_through_its_door():
    blocked = np.zeros((40, 40), dtype=bool)
    blocked[:, 20] = True
    blocked[30:36, 20] = False  # a door 0.6 m wide at y in [3.0, 3.6]
    ref = GridReference.build(blocked, 0.1, (0.0, 0.0), inflate_m=0.2)
    d = ref.distances(np.array([[1.05, 0.55]]), np.array([[3.05, 0.55], [1.05, 0.05]]))[0]
    via_door = math.hypot(2.05 - 1.05, 3.3 - 0.55) + math.hypot(3.05 - 2.05, 3.3 - 0.55)
    assert via_door <= d[0] <= METRIC * via_door + 0.2
    assert d[1] == np.inf  # 0.05 m from the map's edge: no room for the robot centre
    narrow = GridReference.build(blocked, 0.1, (0.0, 0.0), inflate_m=0.35)
    assert narrow.distances(np.array([[1.05, 0.55]]), np.array([[3.05, 0.55]]))[0, 0] == np.inf


@pytest.fixture(scope="module", params=["depot", "tb3_sandbox"])
def planned(request):
    """A bundled map, its geometry, and the existing planner on the polygons (shifted so the
    map's lower-left corner is the arena's origin), with its build time."""
    occ = load_map(MAPS / f"{request.param}.yaml")
    geometry = map_obstacles(occ)
    spec = SpatialSpec(
        width_m=geometry.width_m,
        height_m=geometry.height_m,
        obstacles=geometry.arena_polygons,
        sites=(((1.0, 1.0),),),
    )
    t0 = time.perf_counter()
    planner = GridPlanner(spec)
    return request.param, occ, geometry, planner, time.perf_counter() - t0


def corner_excess(path: np.ndarray, r: float) -> float:
    """What going round sharp corners costs over round ones: at each bend by an angle a of a
    path kept r from the obstacles, 2 r tan(a / 2) against the arc r a."""
    seg = np.diff(path, axis=0)
    seg = seg[np.linalg.norm(seg, axis=1) > 1e-12]
    u, w = seg[:-1], seg[1:]
    turn = np.abs(np.arctan2(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0], (u * w).sum(axis=1)))
    turn = np.minimum(turn, math.radians(179.0))
    return float((r * (2 * np.tan(turn / 2) - turn)).sum())


def test_planned_distances_agree_with_the_grid(planned, report_line):
    """The planner against the grid on 30 random pairs of free points (6 sources x 5 targets).

    r = robot radius + clearance, t = tolerance_m, c = cell side. The reference is the grid of
    cells a robot centre can be in: those whose centre has r - c sqrt(1/2) of clearance. The
    polygons cover every blocked cell and reach at most t + c / 4 beyond it, and the planner
    grows them by r, sharp corners left sharp. So for each pair:

    - (reference - 2 c) / METRIC <= planned: a planned path has r of clearance, so it runs
      through reference cells, and the grid metric overestimates a line by at most METRIC
      (1.3 %); two cells of rounding at the ends and corners;
    - planned <= reference + 2 c + the corner excess (a sharp corner costs 2 r tan(a / 2) - r a
      over a round one at a bend by a; at most 0.43 r for a right angle);
    - planned <= the grid eroded by r sqrt(2) + t + c (1/2 + sqrt(1/2)), exactly: every point of
      such a grid path is free for the planner (where that grid connects the pair at all).

    The grid eroded by r itself (cell centres with r of clearance) closes gaps between 2 r and
    2 r + c wide; tb3_sandbox's pillars stand that far apart, so it is only reported.
    """
    name, occ, geometry, planner, build_s = planned
    res, tol = occ.resolution_m, geometry.tolerance_m
    r = planner.inflate_m
    cleaned = cleaned_cells(occ).blocked
    radii = {
        "ref": r - res * math.sqrt(0.5),
        "strict": r,
        "roomy": r * math.sqrt(2) + tol + res * (0.5 + math.sqrt(0.5)),
    }
    grids = {
        k: GridReference.build(cleaned, res, (0.0, 0.0), inflate_m=v) for k, v in radii.items()
    }
    strict = grids["strict"]
    _, labels = connected_components(strict.graph, directed=False)
    nodes = np.flatnonzero(labels == np.argmax(np.bincount(labels)))
    rng = np.random.default_rng(20240611)
    pts = strict.centres(rng.choice(nodes, size=200, replace=False))
    pts = pts[planner.free(pts)][:11]
    a, b = pts[:6], pts[6:]  # few sources keep the grid's Dijkstra quick
    plan = planner.distances(a, b).ravel()
    grid = {k: g.distances(a, b).ravel() for k, g in grids.items()}
    straight = np.linalg.norm(a[:, None] - b[None], axis=2).ravel()
    paths = [planner.path(p, q) for p in a for q in b]
    length = np.array([np.linalg.norm(np.diff(w, axis=0), axis=1).sum() for w in paths])
    excess = np.array([corner_excess(w, r) for w in paths])
    assert np.isfinite(plan).all() and np.allclose(length, plan, atol=1e-6)
    assert (plan >= straight - 1e-9).all()
    ref = grid["ref"]
    assert ((ref - 2 * res) / METRIC <= plan).all()
    assert (plan <= ref + 2 * res + excess).all()
    roomy = np.isfinite(grid["roomy"])
    assert (plan[roomy] <= grid["roomy"][roomy] + 1e-6).all()

    diff = plan - ref
    near = np.abs(diff) <= 2 * res
    strict_diff = plan - grid["strict"]
    strict_ok = np.abs(strict_diff) <= 2 * res + (METRIC - 1) * grid["strict"]
    probe = np.random.default_rng(7).choice(nodes, size=400, replace=False)
    q = strict.centres(probe)
    q = q[planner.free(q)]
    t0 = time.perf_counter()
    planner.distances(q[:10], q[10:17])
    cold = time.perf_counter() - t0
    t0 = time.perf_counter()
    planner.distances(q[20:30], q[10:17])
    warm = time.perf_counter() - t0
    report_line(
        f"maps planner {name}: {geometry.n_polygons} polygons, {geometry.n_vertices} vertices "
        f"({len(planner.vertices_)} planner vertices), {geometry.specks_dropped} specks dropped; "
        f"build {build_s:.2f} s; 10 x 7 query {cold * 1e3:.1f} ms (new sites), "
        f"{warm * 1e3:.1f} ms (known sites)"
    )
    report_line(
        f"maps planner {name} vs grid: planned - reference in [{diff.min() / res:.1f}, "
        f"{diff.max() / res:.1f}] cells, {int(near.sum())}/30 within 2 cells, corner excess "
        f"<= {excess.max() / res:.1f} cells; {int(roomy.sum())}/30 pairs joined by the roomy grid;"
        f" grid eroded by r: {int(strict_ok.sum())}/30 within 2 cells + 1.3 %"
    )


def test_map_frame_helpers_follow_the_origin():
    """tb3_sandbox's origin is (-10, -10): the map frame and the arena frame (origin at the
    map's lower-left corner) give the same answers 10 m apart."""
    occ = load_map(MAPS / "tb3_sandbox.yaml")
    on_free, clear = Clearance.from_map(occ).query(np.array([[0.55, 0.55], [-9.0, -9.0]]))
    assert on_free.tolist() == [True, False] and clear[0] > 0.5 and clear[1] == 0.0
    in_map = GridReference.from_map(occ, inflate_m=0.35)
    in_arena = GridReference.build(occ.blocked, occ.resolution_m, (0.0, 0.0), inflate_m=0.35)
    a, b = np.array([[-0.55, -0.55]]), np.array([[0.55, 0.55], [-2.0, 0.55]])  # between pillars
    d = in_map.distances(a, b)
    assert np.isfinite(d).all()
    assert np.allclose(d, in_arena.distances(a + 10.0, b + 10.0))
