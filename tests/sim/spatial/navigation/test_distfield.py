"""The fleet's distance field gives the planner's own distances, from a table, for many robots."""

from __future__ import annotations

import itertools
import time

import numpy as np
import pytest

from scenarios.bench.arena import bench_scenario
from sim.scenario import DriveSpec, SpatialSpec
from sim.spatial.navigation.distfield import SHARED, DistanceField, planner_obstacles
from sim.spatial.navigation.planning import FIELD_MIN_ROBOTS, GridPlanner
from sim.spatial.navigation.raster import FULL, NONE, PART, Grid, SightIndex, visibility

BOX = ((8.0, 8.0), (12.0, 8.0), (12.0, 12.0), (8.0, 12.0))
TRIANGLE = ((14.0, 2.0), (17.0, 2.0), (15.5, 6.0))
HEXAGON = tuple(
    (4.0 + 1.5 * np.cos(a), 15.0 + 1.5 * np.sin(a))
    for a in np.linspace(0.3, 0.3 + 2 * np.pi, 7)[:-1]
)
# a wall across the arena with a passage 0.7 m wide once grown by radius + clearance (0.35 m)
PASSAGE = (
    ((0.0, 9.0), (9.3, 9.0), (9.3, 10.0), (0.0, 10.0)),
    ((10.7, 9.0), (20.0, 9.0), (20.0, 10.0), (10.7, 10.0)),
)
FIELD = tuple(  # 24 small boxes
    ((x, y), (x + 1.2, y), (x + 1.2, y + 0.9), (x, y + 0.9))
    for x, y in itertools.product((1.5, 4.5, 7.5, 10.5, 13.5, 16.5), (2.0, 7.0, 12.0, 16.5))
)
ARENAS = {
    "open": (),
    "obstacles": (BOX, TRIANGLE, HEXAGON),
    "passage": PASSAGE,
    "clutter": FIELD,
}


def planner_with_sites(obstacles, n_sites: int = 40, seed: int = 0) -> GridPlanner:
    rng = np.random.default_rng(seed)
    empty = SpatialSpec(20.0, 20.0, tuple(obstacles), ((),), DriveSpec(), clearance_m=0.1)
    cand = rng.uniform(0.5, 19.5, size=(10 * n_sites, 2))
    sites = cand[GridPlanner(empty).free(cand)][:n_sites]
    sites = (
        tuple(map(tuple, sites[: n_sites // 2].tolist())),
        tuple(map(tuple, sites[n_sites // 2 :].tolist())),
    )
    return GridPlanner(
        SpatialSpec(20.0, 20.0, tuple(obstacles), sites, DriveSpec(), clearance_m=0.1)
    )


def path_length(path: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) if len(path) else np.inf


@pytest.fixture(autouse=True)
def fresh_cache():
    SHARED.clear()
    yield
    SHARED.clear()


@pytest.mark.parametrize("arena", sorted(ARENAS))
def test_field_equals_the_planner_on_every_pair(arena):
    """Robots anywhere (free, in the margins, on corners) to every site: the table gives what
    the planner computes, never less than the straight line."""
    planner = planner_with_sites(ARENAS[arena])
    sites = planner.site_points()
    field = DistanceField.build(planner, sites)
    rng = np.random.default_rng(1)
    pos = rng.uniform(0.0, 20.0, size=(600, 2))  # some inside obstacles and wall margins
    if len(planner.vertices_):
        pos[:50] = planner.vertices_[rng.integers(0, len(planner.vertices_), 50)]
    got = field.distances(pos, field.columns(sites))
    want = planner.exact_distances(pos, sites)
    assert np.array_equal(np.isinf(got), np.isinf(want))
    ok = np.isfinite(want)
    np.testing.assert_allclose(got[ok], want[ok], rtol=1e-12, atol=1e-9)
    straight = np.linalg.norm(pos[:, None] - sites[None], axis=2)
    assert (got >= straight - 1e-9).all()


@pytest.mark.parametrize("arena", sorted(ARENAS))
def test_field_agrees_with_path_lengths_within_a_centimetre(arena):
    """The issue's criterion on random pairs: within 1 cm or 0.5 % of ``path()``'s length."""
    planner = planner_with_sites(ARENAS[arena], seed=2)
    sites = planner.site_points()
    field = DistanceField.build(planner, sites)
    rng = np.random.default_rng(3)
    pos = rng.uniform(0.5, 19.5, size=(400, 2))
    pos = pos[planner.free(pos)][:200]
    pick = rng.integers(0, len(sites), size=len(pos))
    got = field.distances(pos, field.columns(sites))[np.arange(len(pos)), pick]
    lengths = np.array(
        [path_length(planner.path(p, sites[k])) for p, k in zip(pos, pick, strict=True)]
    )
    assert np.array_equal(np.isinf(got), np.isinf(lengths))
    ok = np.isfinite(lengths)
    assert (np.abs(got[ok] - lengths[ok]) <= np.maximum(0.01, 0.005 * lengths[ok])).all()
    assert np.abs(got[ok] - lengths[ok]).max() < 1e-9


def test_narrow_passage_bids_go_through_it():
    planner = planner_with_sites(PASSAGE)
    below, above = np.array([[10.0, 5.0]]), np.array([[10.0, 14.0]])
    field = DistanceField.build(planner, above)
    d = field.distances(below, field.columns(above))[0, 0]
    assert d == pytest.approx(9.0, abs=1e-9)  # straight up through the gap
    far = np.array([[2.0, 5.0]])
    d = field.distances(far, field.columns(above))[0, 0]
    assert d > np.linalg.norm(far - above) + 0.1
    assert d == pytest.approx(path_length(planner.path(far[0], above[0])), abs=1e-9)


def test_planner_uses_the_field_only_for_many_robots_and_only_once_asked():
    planner = planner_with_sites((BOX, TRIANGLE))
    sites = planner.site_points()
    rng = np.random.default_rng(4)
    few = rng.uniform(1, 19, size=(FIELD_MIN_ROBOTS - 1, 2))
    planner.distances(few, sites)
    assert planner.field_ is None  # small calls build nothing
    many = rng.uniform(1, 19, size=(FIELD_MIN_ROBOTS, 2))
    got = planner.distances(many, sites[::-1])
    assert planner.field_ is not None
    np.testing.assert_allclose(
        got, planner.exact_distances(many, sites[::-1]), rtol=1e-12, atol=1e-9
    )


def test_sites_the_field_does_not_know_are_computed_directly():
    planner = planner_with_sites((BOX,))
    rng = np.random.default_rng(5)
    pos = rng.uniform(1, 19, size=(FIELD_MIN_ROBOTS, 2))
    sites = np.concatenate([planner.site_points()[:3], [[3.3, 17.1], [18.2, 9.9]]])
    got = planner.distances(pos, sites)
    np.testing.assert_allclose(got, planner.exact_distances(pos, sites), rtol=1e-12, atol=1e-9)


def test_new_obstacles_invalidate_the_field():
    planner = planner_with_sites(())
    sites = planner.site_points()
    rng = np.random.default_rng(6)
    pos = rng.uniform(1, 19, size=(FIELD_MIN_ROBOTS, 2))
    before = planner.distances(pos, sites)
    np.testing.assert_allclose(
        before, np.linalg.norm(pos[:, None] - sites[None], axis=2), rtol=1e-15
    )
    planner.set_obstacles((BOX, TRIANGLE))
    assert planner.field_ is None
    after = planner.distances(pos, sites)
    np.testing.assert_allclose(after, planner.exact_distances(pos, sites), rtol=1e-12, atol=1e-9)
    assert (after > before + 1e-6).any()  # the box is in the way of some
    planner.set_obstacles(())
    np.testing.assert_array_equal(planner.distances(pos, sites), before)


def test_planners_of_one_arena_share_one_field():
    a, b = planner_with_sites((BOX,)), planner_with_sites((BOX,))
    assert a.field() is b.field()
    assert planner_with_sites((TRIANGLE,)).field() is not a.field()


def test_field_reports_its_size_and_build_time():
    field = planner_with_sites(FIELD).field()
    assert 0 < field.nbytes < 50 * 2**20
    assert set(field.timings_) == {"fields_s", "raster_s", "refine_s"}
    assert field.build_s_ >= sum(field.timings_.values()) - 1e-9


@pytest.mark.parametrize("arena", ["obstacles", "clutter"])
def test_raster_classes_hold_for_every_point_of_a_cell(arena):
    """FULL cells see the point from every free point sampled in them, NONE cells from none."""
    planner = planner_with_sites(ARENAS[arena])
    grid = Grid(0.5, 0.5, 40, 40)
    points = np.concatenate([planner.vertices_[::3], planner.site_points()[:8]])
    cls = visibility(points, planner_obstacles(planner), grid)
    rng = np.random.default_rng(7)
    cells = rng.integers(0, 40, size=(2000, 2))
    q = (cells + rng.random((2000, 2))) * 0.5
    q[:200] = cells[:200] * 0.5  # corners
    free = planner.free(q)
    for i, x in enumerate(points):
        blocked = planner.blocked(np.broadcast_to(x, q.shape), q)
        c = cls[i, cells[:, 1], cells[:, 0]]
        assert not (free & (c == FULL) & blocked).any()
        assert not (free & (c == NONE) & ~blocked).any()
    assert (cls == PART).mean() < 0.2


def test_sight_index_lists_every_obstacle_that_can_cut_a_sight_line():
    planner = planner_with_sites(FIELD)
    points = planner.vertices_[::4]
    index = SightIndex(points, planner_obstacles(planner), bins=64)
    rng = np.random.default_rng(8)
    point = rng.integers(0, len(points), 3000)
    towards = rng.uniform(0, 20, size=(3000, 2))
    seg, obstacle = index.candidates(point, towards)
    listed = np.zeros((3000, len(planner.polygons_)), dtype=bool)
    listed[seg, obstacle] = True
    for k in range(len(planner.polygons_)):
        cut = planner.blocked_by(points[point], towards, np.full(3000, k))
        assert not (cut & ~listed[:, k]).any()
    assert listed.sum(axis=1).mean() < 0.5 * len(planner.polygons_)


def test_bench_arena_field_equals_the_planner():
    """The synthetic arena of ``mrta bench`` (300 robots: 30 boxes in rows, 150 sites)."""
    scenario = bench_scenario(300, np.random.default_rng(0))
    planner = GridPlanner(scenario.spatial)
    sites = planner.site_points()[::5]
    field = DistanceField.build(planner, sites)
    rng = np.random.default_rng(9)
    pos = rng.uniform(0, scenario.spatial.width_m, size=(1500, 2))
    got = field.distances(pos, field.columns(sites))
    want = planner.exact_distances(pos, sites)
    assert np.array_equal(np.isinf(got), np.isinf(want))
    np.testing.assert_allclose(
        got[np.isfinite(want)], want[np.isfinite(want)], rtol=1e-12, atol=1e-9
    )


@pytest.mark.parametrize("arena", ["obstacles", "clutter"])
def test_blocked_by_decides_as_blocked(arena):
    """The one-obstacle test the field's queries use equals the planner's segment test,
    segments ending on inflated corners and running along edges included."""
    planner = planner_with_sites(ARENAS[arena])
    rng = np.random.default_rng(10)
    a, b = rng.uniform(-1, 21, size=(2, 3000, 2))
    corners = np.concatenate(planner.polygons_)
    b[: len(corners)] = corners
    a[len(corners) : 2 * len(corners)] = corners
    b[len(corners) : 2 * len(corners)] = np.roll(corners, 1, axis=0)  # along the edges
    k = len(planner.polygons_)
    per = np.array([planner.blocked_by(a, b, np.full(len(a), j)) for j in range(k)])
    np.testing.assert_array_equal(per.any(axis=0), planner.blocked(a, b))


def test_a_scenario_without_sites_builds_no_field():
    planner = GridPlanner(SpatialSpec(20.0, 20.0, (BOX,), ((),), DriveSpec(), clearance_m=0.1))
    rng = np.random.default_rng(11)
    pos, sites = rng.uniform(1, 19, size=(FIELD_MIN_ROBOTS, 2)), rng.uniform(1, 19, size=(5, 2))
    np.testing.assert_array_equal(
        planner.distances(pos, sites), planner.exact_distances(pos, sites)
    )
    assert planner.field_ is None and not planner.field_fits()


def test_a_shared_field_keeps_its_arena_when_one_planner_gets_new_obstacles():
    a, b = planner_with_sites((BOX,)), planner_with_sites((BOX,))
    rng = np.random.default_rng(12)
    pos = rng.uniform(0, 20, size=(FIELD_MIN_ROBOTS, 2))
    sites = a.site_points()
    a.distances(pos, sites)
    a.set_obstacles((TRIANGLE,))
    np.testing.assert_allclose(
        b.distances(pos, sites), b.exact_distances(pos, sites), rtol=1e-12, atol=1e-9
    )
    np.testing.assert_allclose(
        a.distances(pos, sites), a.exact_distances(pos, sites), rtol=1e-12, atol=1e-9
    )


def _field_against_planner(planner, field, pos):
    sites = planner.site_points()
    got = field.distances(pos, field.columns(sites))
    want = planner.exact_distances(pos, sites)
    assert np.array_equal(np.isinf(got), np.isinf(want))
    ok = np.isfinite(want)
    np.testing.assert_allclose(got[ok], want[ok], rtol=1e-12, atol=1e-9)
    return got


@pytest.mark.parametrize("arena", ["obstacles", "clutter"])
def test_candidate_lists_filed_by_key_and_digested_in_several_passes(arena):
    """With room for only two lists of their own in the table (the rest found by key) and
    digests of seven pairs a pass, the field gives the same distances as the planner, bit for
    bit the same as with the defaults."""
    planner = planner_with_sites(ARENAS[arena])
    sites = planner.site_points()
    rng = np.random.default_rng(11)
    pos = rng.uniform(0.0, 20.0, size=(500, 2))
    default = DistanceField.build(planner, sites)
    want = default.distances(pos, default.columns(sites))
    field = DistanceField.build(planner, sites, max_groups=2, pairs_per_pass=7)
    assert len(field.group_start_) == 3 and field.mixed_key_.size > 100  # lists by key
    assert (np.diff(field.mixed_key_) > 0).all()  # sorted, one row per pair
    got = _field_against_planner(planner, field, pos)
    assert np.array_equal(got, want)
    codes = field.table_[field.grid_.cells(pos)]
    assert (codes == field.mixed_code_).any() and (codes >= field.group_base_).any()
    for name, dtype in [("mixed_key_", np.int32), ("mixed_start_", np.int32),
                        ("group_start_", np.int32), ("entry_anchor_", np.int16)]:  # fmt: skip
        assert getattr(field, name).dtype == dtype, name  # the field's size (nbytes)
    pairs = int((default.table_ >= default.mixed_code_).sum())  # undecided (cell, site) pairs
    field = DistanceField.build(planner, sites, pairs_per_pass=pairs)  # one pass, exactly full
    assert np.array_equal(field.distances(pos, field.columns(sites)), want)


def test_positions_off_the_free_space_are_snapped_back_several_in_one_call():
    """Points beyond the arena, in the walls' margin or inside a box are snapped to the
    nearest free point (plus the distance to it), as the planner does, and several in one
    call keep their rows. (None of these reaches the exact fallback for points snapping
    leaves outside the cared-for cells: no test does, README run N.)"""
    planner = planner_with_sites(ARENAS["obstacles"])
    field = DistanceField.build(planner, planner.site_points())
    rng = np.random.default_rng(12)
    pos = rng.uniform(1.0, 19.0, size=(40, 2))
    odd = np.array([[-3.0, 5.0], [10.0, 10.0], [25.0, 25.0], [10.0, -0.5], [9.0, 11.0]])
    pos = np.insert(pos, [3, 3, 10, 20, 40], odd, axis=0)
    got = _field_against_planner(planner, field, pos)
    one_by_one = np.array([field.distances(p[None], field.columns(planner.site_points()))[0]
                           for p in pos])  # fmt: skip
    assert np.array_equal(got, one_by_one)


def test_a_closed_pocket_is_out_of_reach():
    """Four walls enclose a 4 m x 4 m pocket: from inside it, sites outside are at infinity
    (and from outside, a site inside it)."""
    ring = (
        ((6.0, 6.0), (14.0, 6.0), (14.0, 7.0), (6.0, 7.0)),
        ((6.0, 13.0), (14.0, 13.0), (14.0, 14.0), (6.0, 14.0)),
        ((6.0, 7.0), (7.0, 7.0), (7.0, 13.0), (6.0, 13.0)),
        ((13.0, 7.0), (14.0, 7.0), (14.0, 13.0), (13.0, 13.0)),
    )
    spatial = SpatialSpec(
        20.0, 20.0, ring, (((2.0, 2.0), (10.0, 10.0)),), DriveSpec(), clearance_m=0.1
    )
    planner = GridPlanner(spatial)
    sites = planner.site_points()
    field = DistanceField.build(planner, sites)
    pos = np.array([[10.0, 10.5], [9.0, 9.0], [2.0, 18.0], [18.0, 2.0]])
    got = field.distances(pos, field.columns(sites))
    inner = 0 if sites[0, 0] == 10.0 else 1
    outer = 1 - inner
    assert np.isinf(got[:2, outer]).all() and np.isfinite(got[:2, inner]).all()
    assert np.isinf(got[2:, inner]).all() and np.isfinite(got[2:, outer]).all()
    assert (field.table_ == field.inf_code_).any()


def test_build_time_is_measured_once():
    planner = planner_with_sites(ARENAS["obstacles"])
    t0 = time.perf_counter()
    field = DistanceField.build(planner, planner.site_points())
    wall = time.perf_counter() - t0
    assert 0 < field.build_s_ <= wall
    assert field.build_s_ == pytest.approx(sum(field.timings_.values()), abs=1e-9)


def test_a_field_too_large_is_refused_with_its_sizes(monkeypatch):
    planner = planner_with_sites(ARENAS["obstacles"])
    monkeypatch.setattr(DistanceField, "fits", staticmethod(lambda planner, n: False))
    with pytest.raises(ValueError, match=r"^\d+ vertices and 40 sites do not fit a distance"):
        DistanceField.build(planner, planner.site_points())


def test_columns_of_sites_the_field_does_not_know_are_minus_one():
    planner = planner_with_sites(ARENAS["open"])
    sites = planner.site_points()
    field = DistanceField.build(planner, sites[:5])
    cols = field.columns(np.concatenate([sites[[3, 0]], [[1.23, 4.56]], sites[[7]]]))
    assert cols.dtype == np.int64
    known = [int(np.flatnonzero((field.sites == s).all(axis=1))[0]) for s in sites[[3, 0]]]
    assert cols.tolist() == [*known, -1, -1]
