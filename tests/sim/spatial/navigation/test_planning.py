"""The planner (``sim.spatial.navigation.planning``): exact straight lines in open space, geodesics
around obstacles, never shorter; the path round robots (``path_around``)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from sim.scenario import DriveSpec, SpatialSpec
from sim.spatial.navigation.planning import GridPlanner, inflate, polygon_signed_distance
from tests.worlds import make_world

C = np.array([1.0, 1j])
BOX = ((8.0, 8.0), (12.0, 8.0), (12.0, 12.0), (8.0, 12.0))
TRIANGLE = ((14.0, 2.0), (17.0, 2.0), (15.5, 6.0))


def spatial(obstacles=(BOX,), width=20.0, height=20.0) -> SpatialSpec:
    return SpatialSpec(width, height, tuple(obstacles), ((),), DriveSpec(), clearance_m=0.1)


def path_length(path: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


def grid_distances(planner: GridPlanner, start, goals, res: float = 0.1) -> np.ndarray:
    """8-connected Dijkstra over cell centres (scipy csgraph): an upper bound on the geodesic."""
    nx, ny = int(planner.spatial.width_m / res), int(planner.spatial.height_m / res)
    gx, gy = np.meshgrid((np.arange(nx) + 0.5) * res, (np.arange(ny) + 0.5) * res, indexing="ij")
    centres = np.column_stack([gx.ravel(), gy.ravel()])
    free = planner.free(centres).reshape(nx, ny)
    idx = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, weights = [], [], []
    for dx, dy in ((1, 0), (0, 1), (1, 1), (1, -1)):
        a = idx[: nx - dx, max(0, -dy) : ny - max(0, dy)]
        b = idx[dx:, max(0, dy) : ny + min(0, dy)]
        ok = free.ravel()[a.ravel()] & free.ravel()[b.ravel()]
        rows.append(a.ravel()[ok])
        cols.append(b.ravel()[ok])
        weights.append(np.full(ok.sum(), res * np.hypot(dx, dy)))
    graph = coo_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
        shape=(nx * ny, nx * ny),
    ).tocsr()

    def cell(p) -> int:
        return int(p[0] / res) * ny + int(p[1] / res)

    dist = dijkstra(graph, directed=False, indices=cell(start))
    goals = np.asarray(goals, dtype=float)
    ends = np.array([cell(g) for g in goals])
    return (
        dist[ends]
        + np.linalg.norm(centres[ends] - goals, axis=1)
        + np.linalg.norm(centres[cell(start)] - start)
    )


def test_open_space_distance_is_the_straight_line_exactly():
    planner = GridPlanner(spatial(obstacles=()))
    rng = np.random.default_rng(1)
    pos, sites = rng.uniform(1, 19, (30, 2)), rng.uniform(1, 19, (7, 2))
    expect = np.linalg.norm(pos[:, None] - sites[None], axis=2)
    assert np.array_equal(planner.distances(pos, sites), expect)


def test_line_of_sight_past_an_obstacle_is_the_straight_line():
    planner = GridPlanner(spatial())
    d = planner.distances([[2.0, 2.0]], [[18.0, 2.0], [2.0, 18.0]])
    assert d[0, 0] == 16.0 and d[0, 1] == 16.0


def test_around_a_box_the_distance_is_the_geodesic_through_its_inflated_corners():
    planner = GridPlanner(spatial())
    start, goal = np.array([2.0, 10.0]), np.array([18.0, 10.0])
    r = 0.25 + 0.1
    corner_a, corner_b = np.array([8 - r, 12 + r]), np.array([12 + r, 12 + r])
    expect = np.linalg.norm(corner_a - start) + (12 - 8 + 2 * r) + np.linalg.norm(goal - corner_b)
    d = planner.distances(start[None], goal[None])[0, 0]
    assert d == pytest.approx(expect, rel=1e-12)
    path = planner.path(start, goal)
    assert path_length(path) == pytest.approx(d, rel=1e-12)
    assert np.array_equal(path[0], start) and np.array_equal(path[-1], goal)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_planned_distance_between_straight_line_and_a_fine_grid_path(seed):
    planner = GridPlanner(spatial(obstacles=(BOX, TRIANGLE)))
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0.5, 19.5, (40, 2))
    pts = pts[planner.free(pts)][:6]
    for a in pts[:3]:
        d = planner.distances(a[None], pts[3:])[0]
        grid = grid_distances(planner, a, pts[3:])
        assert (d >= np.linalg.norm(pts[3:] - a, axis=1) - 1e-12).all()
        assert (d <= grid + 1e-9).all()
        assert (d >= (grid - 0.3) / 1.0824).all()  # 8-connected: <= 8.24 % long, + end cells
        for b, db in zip(pts[3:], d, strict=True):
            assert path_length(planner.path(a, b)) == pytest.approx(db, rel=1e-9)


def test_path_never_cuts_through_an_obstacle():
    planner = GridPlanner(spatial(obstacles=(BOX, TRIANGLE)))
    path = planner.path([9.0, 3.0], [10.0, 17.0])
    assert not planner.blocked(path[:-1], path[1:]).any()
    t = np.linspace(0, 1, 200)[:, None]
    for a, b in itertools.pairwise(path):
        samples = a + t * (b - a)
        for poly in (BOX, TRIANGLE):
            clear = polygon_signed_distance(samples, np.asarray(poly, dtype=float))
            assert clear.min() >= 0.25 + 0.1 - 1e-9  # robot radius + clearance


def test_unreachable_site_is_inf_and_has_no_path():
    walls = (
        ((14.0, 14.0), (20.0, 14.0), (20.0, 14.5), (14.0, 14.5)),
        ((14.0, 14.0), (14.5, 14.0), (14.5, 20.0), (14.0, 20.0)),
    )
    planner = GridPlanner(spatial(obstacles=walls))
    assert planner.distances([[2.0, 2.0]], [[17.0, 17.0]])[0, 0] == np.inf
    assert planner.path([2.0, 2.0], [17.0, 17.0]).shape == (0, 2)


def test_nearer_robot_has_the_lower_distance():
    planner = GridPlanner(spatial())
    d = planner.distances([[2.0, 10.0], [4.0, 10.0], [2.0, 2.0]], [[18.0, 10.0]])[:, 0]
    assert d[1] < d[0]
    assert np.all(np.isfinite(d))


def test_a_robot_pressed_into_the_margin_still_gets_a_finite_bid_not_below_the_line():
    planner = GridPlanner(spatial())
    inside_margin = np.array([[7.8, 10.0]])  # within radius + clearance of the box
    assert not planner.free(inside_margin)[0]
    d = planner.distances(inside_margin, [[2.0, 10.0], [18.0, 10.0]])
    assert np.isfinite(d).all()
    assert (d >= np.linalg.norm(inside_margin - [[2.0, 10.0], [18.0, 10.0]], axis=1)).all()


def test_inflate_contains_the_grown_polygon():
    poly = np.array(TRIANGLE)
    grown = inflate(poly, 0.5)
    ring = np.array([[np.cos(a), np.sin(a)] for a in np.linspace(0, 2 * np.pi, 64)]) * 0.5
    around = (poly[:, None, :] + ring[None]).reshape(-1, 2)
    assert (polygon_signed_distance(around, grown) <= 1e-9).all()


@pytest.mark.parametrize(
    ("poly", "corners"),
    [
        (TRIANGLE, 6),  # three corners sharper than 90 degrees: each bevelled, two vertices
        (BOX, 4),  # right angles: the offset edges meet, no bevel
        (((0.0, 0.0), (4.0, 0.0), (5.0, 2.0), (2.0, 4.0), (-1.0, 2.0)), 5),  # all obtuse
        (((0.0, 0.0), (6.0, 0.0), (6.0, 0.5)), 5),  # a sliver: two sharp corners
    ],
)
def test_inflate_grows_no_more_than_its_bevels_allow(poly, corners):
    """Every edge moves out by exactly d, and no vertex lies farther than d * sqrt(2) from
    the polygon: a corner whose edge normals turn by at most 90 degrees keeps its mitre
    (d / cos of half the turn), a sharper one is cut by a bevel (d / cos of a quarter)."""
    d = 0.5
    poly = np.asarray(poly, dtype=float)
    grown = inflate(poly, d)
    assert len(grown) == corners
    depth = polygon_signed_distance(grown, poly)
    assert (depth >= d - 1e-9).all() and (depth <= d * np.sqrt(2) + 1e-9).all()
    mid = 0.5 * (grown + np.roll(grown, -1, axis=0))  # each grown edge's midpoint: d out
    edge = np.roll(grown, -1, axis=0) - grown
    normal = np.column_stack([edge[:, 1], -edge[:, 0]]) / np.linalg.norm(edge, axis=1)[:, None]
    gap = polygon_signed_distance(mid, poly)
    assert (gap >= d - 1e-9).all()
    assert (polygon_signed_distance(mid + 1e-6 * normal, grown) > 0).all()  # outward CCW
    assert np.array_equal(inflate(poly, 0.0), poly) and inflate(poly.astype(int), 0).dtype == float


def test_occupancy_grid_marks_obstacles_and_walls():
    planner = GridPlanner(spatial())
    grid = planner.occupancy
    assert grid.shape == (80, 80)
    assert grid[40, 40] and grid[0, 0] and not grid[10, 10]
    assert planner.reachable([2.0, 2.0]) and not planner.reachable([10.0, 10.0])


FIELD = tuple(  # 24 small boxes: single queries look at the buckets of a few (navigation.buckets)
    ((x, y), (x + 1.2, y), (x + 1.2, y + 0.9), (x, y + 0.9))
    for x, y in itertools.product((1.5, 4.5, 7.5, 10.5, 13.5, 16.5), (2.0, 7.0, 12.0, 16.5))
)


@pytest.mark.parametrize("obstacles", [(BOX, TRIANGLE), (), FIELD])
def test_single_queries_in_python_equal_the_array_versions(obstacles):
    """``blocked_one`` / ``free_one`` (path, side steps) decide as ``blocked`` / ``free`` do,
    segments grazing the inflated corners included, and the path's length is the distance."""
    planner = GridPlanner(spatial(obstacles))
    rng = np.random.default_rng(11)
    a, b = rng.uniform(-1, 21, size=(2, 4000, 2))
    b[2000:] = a[2000:] + rng.uniform(-1.5, 1.5, size=(2000, 2))  # short ones, as side steps
    corners = np.concatenate(planner.polygons_) if obstacles else np.zeros((0, 2))
    b[: len(corners)] = corners  # ends exactly on inflated corners
    ours = [planner.blocked_one(*p, *q) for p, q in zip(a.tolist(), b.tolist(), strict=True)]
    assert ours == planner.blocked(a, b).tolist()
    assert [planner.free_one(*p) for p in a.tolist()] == planner.free(a).tolist()
    for pts in (a, b):  # a few points at a time are tested one by one (FREE_ONE_MAX)
        few = [planner.free(c) for c in np.array_split(pts, 400)]
        assert np.concatenate(few).tolist() == planner.free(pts).tolist()
    starts, goals = a[planner.free(a)][:300], b[planner.free(b)][:300]
    n = min(len(starts), len(goals))
    lengths = [path_length(planner.path(s, g)) for s, g in zip(starts[:n], goals[:n], strict=True)]
    np.testing.assert_allclose(lengths, planner.distances(starts[:n], goals[:n]).diagonal())


def test_blocked_in_small_chunks_decides_as_in_one():
    """``blocked`` splits many segments into chunks of at most ``chunk`` (segment, edge)
    entries: with chunks of a few segments, some meeting no obstacle at all, every segment is
    decided as in one chunk (and as ``blocked_one`` decides it)."""
    planner = GridPlanner(spatial((BOX, TRIANGLE)))
    rng = np.random.default_rng(5)
    a, b = rng.uniform(0.5, 19.5, size=(2, 600, 2))
    b[::3] = a[::3] + 0.2  # short segments, most of them meeting no obstacle's box
    whole = planner.blocked(a, b)
    assert 50 < whole.sum() < 550
    small = GridPlanner(spatial((BOX, TRIANGLE)), chunk=3 * 2 * planner.normals_.shape[1])
    np.testing.assert_array_equal(small.blocked(a, b), whole)  # chunks of three segments
    single = [planner.blocked_one(*p, *q) for p, q in zip(a.tolist(), b.tolist(), strict=True)]
    assert single == whole.tolist()


@pytest.mark.parametrize("obstacles", [(BOX, TRIANGLE), FIELD])
def test_the_first_vertex_seen_is_the_one_by_one_scan_s(obstacles):
    """A path leaves through the first vertex visible from its start in order of the cost
    through it: tested a batch at a time, it is the vertex a scan one by one
    (``blocked_one``) finds, with ties in the cost, unreachable vertices (inf) and starts that
    see none."""
    planner = GridPlanner(spatial(obstacles))
    v = planner.vertices_
    rng = np.random.default_rng(3)
    starts = rng.uniform(0.5, 19.5, size=(300, 2))
    starts[:40] = v[rng.integers(0, len(v), 40)]  # on a vertex: it sees itself
    found = set()
    for k, s in enumerate(starts):
        lower = np.round(rng.uniform(0, 30, len(v)), 0 if k % 2 else 6)  # ties in half
        lower[rng.random(len(v)) < (0.9 if k % 7 == 0 else 0.2)] = np.inf
        want = -1
        for u in np.argsort(lower).tolist():
            if not np.isfinite(lower[u]):
                break
            if not planner.blocked_one(*s.tolist(), *v[u].tolist()):
                want = u
                break
        got = planner._first_seen(s, lower)
        assert got == want
        found.add("none" if want < 0 else "late" if (lower < lower[want]).sum() >= 8 else "early")
    assert found >= {"none", "early"}
    assert "late" in found or len(v) < 40  # past the first batch where there are many


def _same_graph(a: GridPlanner, b: GridPlanner) -> None:
    np.testing.assert_array_equal(a.vertices_, b.vertices_)
    np.testing.assert_array_equal(a.seen_, b.seen_)
    np.testing.assert_array_equal(a.apsp_, b.apsp_)
    np.testing.assert_array_equal(a.pred_, b.pred_)


def _squares(centres, r: float = 0.25) -> list:
    return [((x - r, y - r), (x + r, y - r), (x + r, y + r), (x - r, y + r)) for x, y in centres]


@pytest.mark.parametrize("seed", range(6))
def test_obstacles_added_to_known_ones_give_the_graph_built_from_scratch(seed):
    """set_obstacles(..., known=(planner, n)) looks the pairs of the planner's vertices up
    and tests only the obstacles past the n: the same vertices, visibility, geodesics and
    predecessors bit for bit (squares where robots stand, as the fault world adds them, one
    on an obstacle vertex and two coincident, so both kinds of pair occur)."""
    rng = np.random.default_rng(seed)
    static = (BOX, TRIANGLE, ((2.0, 14.0), (5.0, 14.0), (5.0, 17.0), (2.0, 17.0)))
    base = GridPlanner(spatial(static))
    corner = base.vertices_[rng.integers(len(base.vertices_))]
    centres = [tuple(corner + 0.35), *rng.uniform(1.0, 19.0, (5, 2)).tolist()]
    centres.append(centres[-1])
    obstacles = [*static, *_squares(centres)]
    fast, slow = GridPlanner(spatial(static)), GridPlanner(spatial(static))
    fast.set_obstacles(obstacles, known=(base, len(static)))
    slow.set_obstacles(obstacles)
    _same_graph(fast, slow)
    assert len(fast.vertices_) > len(base.vertices_) and not fast.seen_.all()
    assert all(fast.polygons_[k] is base.polygons_[k] for k in range(len(static)))  # reused
    np.testing.assert_array_equal(fast.normals_, slow.normals_)
    np.testing.assert_array_equal(fast.offsets_, slow.offsets_)
    assert fast.scalar_ == slow.scalar_


def test_obstacles_kept_as_float_tuples_are_taken_as_they_are_and_others_converted():
    """set_obstacles keeps every obstacle as a tuple of (x, y) float tuples: one given so
    already is kept (path_around gives its planner's own and the octagons so), any other form
    (arrays, lists, integer corners) is converted; the graph is the same either way."""
    as_arrays = GridPlanner(spatial(()))
    as_arrays.set_obstacles([np.array(BOX), np.array(TRIANGLE)])
    ints = ((4, 4), (8, 4), (8, 8), (4, 8))
    given = (tuple(map(tuple, np.array(BOX, dtype=float).tolist())), ints)
    kept = GridPlanner(spatial(()))
    kept.set_obstacles(given)
    assert kept.obstacles[0] is given[0]
    assert kept.obstacles[1] == tuple((float(x), float(y)) for x, y in ints)
    assert all(type(c) is float for point in kept.obstacles[1] for c in point)
    assert as_arrays.obstacles[0] == kept.obstacles[0]
    again = GridPlanner(spatial(()))
    again.set_obstacles(as_arrays.obstacles)
    _same_graph(again, as_arrays)


@pytest.mark.parametrize("seed", range(4))
def test_the_visibility_graph_is_scipys_shortest_paths_over_the_visible_pairs(seed):
    """The geodesics and predecessors between vertices are those of
    ``scipy.sparse.csgraph.shortest_path`` over the visible pairs (COO, then CSR), bit for bit
    (the planner builds its sparse rows directly), and agree with Floyd-Warshall; squares on a
    whole-metre grid make paths of equal length, so ties occur."""
    from scipy.sparse.csgraph import floyd_warshall, shortest_path

    rng = np.random.default_rng(seed)
    centres = rng.integers(2, 18, (8, 2)).astype(float).tolist()
    planner = GridPlanner(spatial([BOX, *_squares(centres, 0.5)]))
    v, nv = planner.vertices_, len(planner.vertices_)
    i, j = np.triu_indices(nv, k=1)
    i, j = i[planner.seen_], j[planner.seen_]
    w = np.linalg.norm(v[i] - v[j], axis=1) + 1e-12
    graph = coo_matrix((w, (i, j)), shape=(nv, nv)).tocsr()
    dist, pred = shortest_path(graph, method="D", directed=False, return_predecessors=True)
    np.testing.assert_array_equal(planner.apsp_, dist)
    np.testing.assert_array_equal(planner.pred_, pred)
    np.testing.assert_allclose(planner.apsp_, floyd_warshall(graph, directed=False), atol=1e-9)
    assert nv > 20 and 0 < planner.seen_.sum() < len(planner.seen_)


def test_path_around_in_a_local_box_builds_the_graph_it_would_from_scratch(monkeypatch):
    """In a large arena path_around keeps the obstacles near a box and reuses the arena's
    visibility for their vertices: each throwaway graph equals the one built without."""
    boxes = tuple(
        ((x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0))
        for x in range(5, 60, 6)
        for y in range(5, 60, 6)
    )
    sp = SpatialSpec(64.0, 64.0, boxes, (((2.0, 2.0),),), DriveSpec())
    pl = GridPlanner(sp)
    built = []
    plain = GridPlanner.set_obstacles

    def spy(self, obstacles, known=None):
        plain(self, obstacles, known)
        if known is not None:
            ref = self.empty_like()
            plain(ref, obstacles)
            built.append((self, ref))

    monkeypatch.setattr(GridPlanner, "set_obstacles", spy)
    rng = np.random.default_rng(3)
    for _ in range(12):
        start = rng.uniform(2.0, 62.0, 2)
        robots = start[0] + 1j * start[1] + rng.normal(0.0, 1.5, 4) + 1j * rng.normal(0.0, 1.5, 4)
        goal = tuple(rng.uniform(2.0, 62.0, 2))
        path = pl.path_around(tuple(start), goal, robots, 0.25)
        afresh = pl.path_around(tuple(start), goal, robots, 0.25, reuse=False)  # bench baseline
        np.testing.assert_array_equal(path, afresh)
    assert len(built) == 12
    for fast, slow in built:
        _same_graph(fast, slow)


def test_path_around_grows_a_robot_once_while_it_stands_and_plans_as_a_fresh_planner(
    monkeypatch,
):
    """path_around keeps the grown octagons of the robots it went round (robots at work stand
    where they stood): going round the same robots again grows none of them, moving one grows
    that one only, and every path equals a fresh planner's; past ``grown_max`` shapes the
    planner starts again, so what it keeps stays bounded."""
    pl = GridPlanner(spatial(obstacles=(BOX, TRIANGLE)))
    grown = []
    shape = GridPlanner._shape

    def counted(self, obstacle):
        grown.append(obstacle)
        return shape(self, obstacle)

    monkeypatch.setattr(GridPlanner, "_shape", counted)
    robots = np.array([6.0 + 10.0j, 13.0 + 13.0j, 10.0 + 14.5j])
    moved = robots + np.array([0.0, 0.01, 0.0])
    calls = [((2.0, 10.0), robots), ((3.0, 3.0), robots), ((2.0, 17.0), robots)]
    calls.append(((2.0, 10.0), moved))
    paths = []
    for start, them in calls:
        before = len(grown)
        paths.append(pl.path_around(start, (18.0, 10.0), them, 0.25))
        assert len(grown) - before == (3 if not paths[:-1] else int(them is moved))
    fresh = GridPlanner(spatial(obstacles=(BOX, TRIANGLE)))
    for (start, them), path in zip(calls, paths, strict=True):
        fresh.grown_.clear()
        np.testing.assert_array_equal(path, fresh.path_around(start, (18.0, 10.0), them, 0.25))
    assert any(len(p) > 2 for p in paths)  # some go round a robot
    small = GridPlanner(spatial(obstacles=(BOX, TRIANGLE)), grown_max=4)
    for k in range(6):
        small.path_around((2.0, 10.0), (18.0, 10.0), robots + 0.1 * (k + 1), 0.25)
        assert len(small.grown_) <= 4 + 3


def open_planner(*obstacles) -> GridPlanner:
    """A 20 x 20 m arena; obstacles grow by 0.35 m (radius 0.25 m and clearance 0.1 m)."""
    return GridPlanner(spatial(obstacles=obstacles))


def test_a_side_step_goes_away_from_the_other_robot_s_line_else_the_other_way_else_ahead():
    """Robot at (5, 4.8), 0.2 m below the line of a robot at (3, 5) driving +x: it steps 1 m
    down; with that cell taken (a box whose margin covers (5, 3.8)) or the way there cut (a
    thin bar between), 1 m up; with both taken, 1 m ahead; with all three, no path."""
    xy, other, step = 5.0 + 4.8j, 3.0 + 5.0j, 1.0
    below = ((4.0, 2.5), (6.0, 2.5), (6.0, 3.6), (4.0, 3.6))  # margin up to y = 3.95
    bar = ((4.0, 4.2), (6.0, 4.2), (6.0, 4.3), (4.0, 4.3))  # margin 3.85-4.65: (5, 3.8) free
    above = ((4.0, 6.0), (6.0, 6.0), (6.0, 7.0), (4.0, 7.0))
    ahead = ((6.2, 4.0), (7.0, 4.0), (7.0, 5.5), (6.2, 5.5))

    def step_to(planner, avoid=()):
        path = planner.side_step(xy, other, 1.0 + 0j, step, np.asarray(avoid, dtype=complex))
        assert path.shape in ((2, 2), (0, 2))
        if len(path):
            assert path[0].tolist() == [5.0, 4.8]
        return complex(*path[1]) if len(path) else None

    assert step_to(open_planner()) == pytest.approx(5.0 + 3.8j)
    assert step_to(open_planner(below)) == pytest.approx(5.0 + 5.8j)
    bar_planner = open_planner(bar)
    assert bar_planner.free_one(5.0, 3.8) and bar_planner.blocked_one(5.0, 4.8, 5.0, 3.8)
    assert step_to(bar_planner) == pytest.approx(5.0 + 5.8j)
    assert step_to(open_planner(below, above)) == pytest.approx(6.0 + 4.8j)
    assert step_to(open_planner(below, above, ahead)) is None
    # a robot within step / 2 of the end takes the place as an obstacle would
    assert step_to(open_planner(), avoid=[5.3 + 3.6j]) == pytest.approx(5.0 + 5.8j)
    assert step_to(open_planner(), avoid=[5.6 + 3.6j]) == pytest.approx(5.0 + 3.8j)
    path = open_planner().side_step(xy, 3.0 + 4.7j, 1.0 + 0j, step, np.zeros(0, complex))
    assert complex(*path[1]) == pytest.approx(xy + 1j)  # the other robot below: step up


def test_a_detour_passes_a_standing_robot_on_our_side_of_it_then_plans_to_the_goal():
    """Robot at (2, 4.9) going +x to (10, 5) past a robot standing at (5, 5): it first aims
    0.8 m below that robot (its own side), then straight on; with that place taken, 0.8 m
    above; with both taken, or the goal out of reach, no path."""
    start, around, goal = 2.0 + 4.9j, 5.0 + 5.0j, (10.0, 5.0)
    none = np.zeros(0, dtype=complex)
    planner = open_planner()
    path = planner.detour(start, around, 1.0 + 0j, 0.8, goal, none)
    np.testing.assert_allclose(path, [[2.0, 4.9], [5.0, 4.2], [10.0, 5.0]], rtol=0, atol=1e-12)
    path = planner.detour(start, around, 1.0 + 0j, 0.8, goal, np.array([5.2 + 4.3j]))
    np.testing.assert_allclose(path, [[2.0, 4.9], [5.0, 5.8], [10.0, 5.0]], rtol=0, atol=1e-12)
    taken = np.array([5.2 + 4.3j, 4.8 + 5.7j])  # within 0.4 m (half the offset) of each place
    assert planner.detour(start, around, 1.0 + 0j, 0.8, goal, taken).shape == (0, 2)
    walled = (  # a box round the goal: both places free, the goal unreachable
        ((8.0, 3.0), (12.0, 3.0), (12.0, 3.5), (8.0, 3.5)),
        ((8.0, 6.5), (12.0, 6.5), (12.0, 7.0), (8.0, 7.0)),
        ((8.0, 3.0), (8.5, 3.0), (8.5, 7.0), (8.0, 7.0)),
        ((11.5, 3.0), (12.0, 3.0), (12.0, 7.0), (11.5, 7.0)),
    )
    assert open_planner(*walled).detour(start, around, 1.0 + 0j, 0.8, goal, none).shape == (0, 2)
    around_path = open_planner(BOX).detour(2.0 + 10.2j, 5.0 + 10.0j, 1.0 + 0j, 0.8, (18, 10), none)
    assert around_path[1].tolist() == pytest.approx([5.0, 10.8])  # above: our side
    assert not open_planner(BOX).blocked(around_path[:-1], around_path[1:]).any()
    assert path_length(around_path) > 16.0  # round the box, not through it


def test_a_path_round_a_standing_robot_runs_along_the_flat_side_of_its_octagon():
    """A robot standing on the straight line: the path goes round an octagon with flat sides
    up, down, left and right that holds the robot's disc, grown like every obstacle, so its
    top (or bottom) leg runs exactly radius + inflation from the robot's centre, and no point
    of the path comes closer than that."""
    planner = open_planner()
    grow = planner.inflate_m
    for robot, r in ((10.0 + 10.1j, 0.25), (10.0 + 9.9j, 0.25), (7.0 + 10.0j, 0.4)):
        path = planner.path_around((2.0, 10.0), (18.0, 10.0), np.array([robot]), r)
        z = path @ C
        assert len(z) == 4  # start, the two corners of the flat side, goal
        above = z[1].imag > robot.imag
        side = robot.imag + (r + grow if above else -(r + grow))
        assert z[1].imag == pytest.approx(side, abs=1e-9)
        assert z[2].imag == pytest.approx(side, abs=1e-9)
        t = np.linspace(0.0, 1.0, 400)[:, None]
        points = (z[:-1] + t * (z[1:] - z[:-1])).ravel()
        assert np.abs(points - robot).min() >= r + grow - 1e-9


def test_distances_to_no_site_or_from_no_position_are_empty_tables():
    planner = open_planner(BOX)
    assert planner.distances(np.zeros((3, 2)) + 1.0, np.zeros((0, 2))).shape == (3, 0)
    assert planner.distances(np.zeros((0, 2)), [[2.0, 2.0], [18.0, 18.0]]).shape == (0, 2)
    assert planner.exact_distances(np.zeros((0, 2)), [[2.0, 2.0]]).shape == (0, 1)


def test_a_segment_parallel_to_an_obstacle_edge_and_outside_it_is_not_blocked_by_it():
    """y = 13 runs parallel to the box's grown top edge (y = 12.35) and 0.65 m above it: that
    box does not block it, in plain Python or over arrays, nor does a diamond block a segment
    1 m outside its edge and parallel to it; a second box the line crosses does block it.
    (Cyrus-Beck's branch for a segment exactly parallel to an edge and outside it is never
    reached: an exactly parallel edge is axis-parallel, so it is a side of the obstacle's
    bounding box, and a segment outside it misses the box, which is tested first.)"""
    planner = open_planner(BOX)
    assert not planner.blocked_one(2.0, 13.0, 18.0, 13.0)
    assert not planner.blocked(np.array([[2.0, 13.0]]), np.array([[18.0, 13.0]]))[0]
    assert not planner.blocked_one(10.0, 2.0, 10.0, 7.0)  # vertical, below: another edge
    diamond = open_planner(((10.0, 6.0), (14.0, 10.0), (10.0, 14.0), (6.0, 10.0)))
    assert not diamond.blocked_one(11.0, 5.0, 15.0, 9.0)  # y = x - 6, the edge y = x - 4
    assert not diamond.blocked(np.array([[11.0, 5.0]]), np.array([[15.0, 9.0]]))[0]
    assert diamond.blocked_one(11.0, 7.0, 15.0, 11.0)  # y = x - 4: on the edge, in the margin
    crossed = open_planner(BOX, ((14.5, 12.5), (15.5, 12.5), (15.5, 13.5), (14.5, 13.5)))
    assert crossed.blocked_one(2.0, 13.0, 18.0, 13.0)
    assert crossed.blocked(np.array([[2.0, 13.0]]), np.array([[18.0, 13.0]]))[0]
    assert not crossed.blocked_one(2.0, 13.0, 13.5, 13.0)  # stops short of the second box


def test_a_path_from_or_to_a_point_in_a_margin_starts_and_ends_there_via_the_nearest_free_one():
    """A robot pressed into the box's margin (7.8, 10): its path starts where it is, then the
    nearest free point (7.65 m, on the grown edge, pushed out 1e-6 m), then plans on; the same
    at the goal end, and a point beyond the arena's wall margin is pulled back inside first."""
    planner = open_planner(BOX)
    grow = planner.inflate_m
    path = planner.path((7.8, 10.0), (2.0, 10.0))
    np.testing.assert_allclose(path, [[7.8, 10.0], [8.0 - grow, 10.0], [2.0, 10.0]], atol=2e-6)
    assert not planner.free_one(*path[0]) and planner.free_one(*path[1])
    back = planner.path((2.0, 10.0), (7.8, 10.0))
    np.testing.assert_allclose(back, path[::-1], atol=2e-6)
    edge = planner.snap([[-1.0, 5.0], [25.0, 5.0], [5.0, 0.1], [5.0, 25.0]])
    np.testing.assert_allclose(
        edge, [[grow, 5.0], [20.0 - grow, 5.0], [5.0, grow], [5.0, 20.0 - grow]]
    )


def test_an_arena_cut_in_two_by_a_wall_has_no_path_across():
    """A wall as wide as the arena: no vertex of its grown outline lies in the arena, and no
    path crosses; each half plans as before."""
    planner = open_planner(((0.0, 9.5), (20.0, 9.5), (20.0, 10.5), (0.0, 10.5)))
    assert len(planner.vertices_) == 0
    assert planner.path((2.0, 2.0), (2.0, 18.0)).shape == (0, 2)
    assert planner.distances([[2.0, 2.0]], [[2.0, 18.0]])[0, 0] == np.inf
    np.testing.assert_allclose(planner.path((2.0, 2.0), (18.0, 3.0)), [[2.0, 2.0], [18.0, 3.0]])


@pytest.mark.parametrize("mirror", [False, True])
def test_a_local_plan_keeps_an_obstacle_just_outside_its_box_whose_margin_reaches_in(mirror):
    """In an arena of more than 256 vertices ``path_around`` plans in a box 6 m round the
    start, goal and robots (here x 4-16 m). A wall from x = 1 to 15.5 m stands between start
    and goal; the gap between its end and the box's side is closed by a post whose grown shape
    starts at 15.8 m, 0.2 m inside the box, though the post itself lies outside it: the post
    must be planned around, so no path is found in the box (the whole arena has one, round
    the wall's far end). Mirrored, the same at the box's low side."""

    def flip(x):
        return 40.0 - x if mirror else x

    def rect(x0, x1, y0, y1):
        xs = sorted((flip(x0), flip(x1)))
        return ((xs[0], y0), (xs[1], y0), (xs[1], y1), (xs[0], y1))

    filler = [
        rect(2.0 + 3 * k, 2.5 + 3 * k, 26.0 + 3 * j, 26.5 + 3 * j)
        for k in range(13)
        for j in range(5)
    ]
    wall, post = rect(1.0, 15.5, 11.8, 12.2), rect(16.15, 17.0, 10.0, 14.0)
    planner = GridPlanner(spatial((*filler, wall, post), width=40.0, height=40.0))
    assert len(planner.vertices_) > 256
    start, goal = (flip(10.0), 10.0), (flip(10.0), 14.0)
    robot = np.array([flip(10.0) + 8.0j])
    assert planner.path_around(start, goal, robot, 0.25).shape == (0, 2)
    whole = planner.path(start, goal)
    assert len(whole) and not planner.blocked(whole[:-1], whole[1:]).any()


def test_path_around_without_robots_is_the_plain_path():
    w = make_world([(2.0, 2.0)], obstacles=[((8.0, 3.0), (12.0, 3.0), (12.0, 7.0), (8.0, 7.0))])
    pl = w.planner
    a, b = (2.0, 5.0), (18.0, 5.0)
    assert np.array_equal(pl.path_around(a, b, np.zeros(0), 0.25), pl.path(a, b))


def test_in_a_large_arena_path_around_plans_in_a_local_box_and_finds_the_same_path():
    """More than ``local_min_vertices`` obstacle vertices: the throwaway planner keeps only the
    obstacles near the start, the goal and the robots; round one robot in open floor that
    gives the path the whole arena gives (the robot 0.1 m off the straight way, so that one
    side is shorter: round a robot on it the two ways tie, and float rounding picks one)."""
    import sim.spatial.navigation.planning as planning
    from sim.scenario import DriveSpec, SpatialSpec

    boxes = tuple(
        ((x, y), (x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0))
        for x in range(5, 60, 6)
        for y in range(5, 60, 6)
    )
    sp = SpatialSpec(64.0, 64.0, boxes, (((2.0, 2.0),),), DriveSpec())
    pl = planning.GridPlanner(sp)
    assert len(pl.vertices_) > pl.local_min_vertices
    start, goal, robot = (2.5, 3.0), (9.0, 3.0), np.array([5.0 + 2.9j])
    local = pl.path_around(start, goal, robot, 0.25)
    whole = planning.GridPlanner(sp, local_min_vertices=10**9).path_around(start, goal, robot, 0.25)
    assert len(local) > 2 and np.allclose(local, whole)
    assert (local[1:-1, 1] > 3.0).all()  # past it on the far side from it, the shorter way
    far = pl.path_around((2.5, 3.0), (62.0, 62.0), robot, 0.25)  # goal far off: the box grows
    assert len(far) and np.allclose(far[-1], (62.0, 62.0))


@pytest.mark.parametrize("n", [0, 1, 5, 256, 257])
def test_vertex_pairs_are_the_upper_triangle_and_shared_ones_cannot_be_written(n):
    from sim.spatial.navigation.planning import PAIRS_CACHED, _pairs

    i, j = _pairs(n)
    want = np.triu_indices(n, k=1)
    np.testing.assert_array_equal(i, want[0])
    np.testing.assert_array_equal(j, want[1])
    shared = n <= PAIRS_CACHED
    assert i.flags.writeable is not shared and j.flags.writeable is not shared
    assert (_pairs(n)[0] is i) is shared  # small n: the same arrays again
