"""Spatial cost models and the spatial benchmarks: straight lines, planned bids at scale."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from allocation.auction import (
    priority_cost_matrix,
    solve_priority_assignment,
    solve_priority_assignment_dense,
)
from allocation.costs import DistanceCost, StraightLineCost
from scenarios.bench.alloc import bench_assignment, bench_costs
from scenarios.bench.arena import bench_scenario
from sim.spatial.navigation.distfield import SHARED
from sim.spatial.navigation.planning import GridPlanner
from sim.tasks import Batch
from sim.world import WorldState


@pytest.fixture(scope="module")
def arena():
    scenario = bench_scenario(300, np.random.default_rng(0))
    return scenario, GridPlanner(scenario.spatial)


def state_and_batch(scenario, planner, rng, m, k):
    cand = rng.uniform(0, scenario.spatial.width_m, size=(4 * m, 2))
    xy = cand[planner.free(cand)][:m]
    sites = planner.site_points()[rng.integers(0, len(planner.site_points()), k)]
    batch = Batch(0, 0, np.arange(k), np.zeros(k, int), rng.random(k) < 0.35, sites)
    return WorldState(0.0, np.ones(m, dtype=bool), np.zeros(m), xy), batch


def test_straight_line_cost_is_the_euclidean_distance_and_a_lower_bound(arena):
    scenario, planner = arena
    state, batch = state_and_batch(scenario, planner, np.random.default_rng(1), 300, 7)
    straight = StraightLineCost(scenario).costs(state, batch)
    expect = np.linalg.norm(state.positions[:, None] - batch.sites[None], axis=2)
    np.testing.assert_allclose(straight, expect, rtol=1e-15)
    planned = DistanceCost(scenario, planner).costs(state, batch)  # 300 robots: the field
    assert (planned >= straight - 1e-9).all()
    assert (planned > straight + 1e-3).any()  # the boxes are in the way of some


def test_straight_line_cost_needs_positions(arena):
    scenario, _ = arena
    batch = Batch(0, 0, np.arange(1), np.zeros(1, int), np.zeros(1, bool), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="spatial"):
        StraightLineCost(scenario).costs(WorldState(0.0, np.ones(300, bool), np.zeros(300)), batch)


def test_planned_bids_of_a_busy_round_give_the_same_auction_as_exact_bids(arena):
    """1000 tasks over the 150 sites (repeats) for 300 robots: field bids == exact bids, so
    the auction's optimum is the same."""
    scenario, planner = arena
    state, batch = state_and_batch(scenario, planner, np.random.default_rng(2), 300, 300)
    fast = planner.distances(state.positions, batch.sites)
    exact = planner.exact_distances(state.positions, batch.sites)
    np.testing.assert_allclose(fast, exact, rtol=1e-12, atol=1e-9)
    a, b = solve_priority_assignment(fast, batch.high), solve_priority_assignment(exact, batch.high)
    assert (a >= 0).sum() == (b >= 0).sum()
    assert fast[a, np.arange(300)].sum() == pytest.approx(exact[b, np.arange(300)].sum(), rel=1e-12)


def test_priority_cost_matrix_is_what_the_dense_auction_solves():
    rng = np.random.default_rng(3)
    bids = np.where(rng.random((40, 25)) < 0.3, rng.uniform(1, 9, (40, 25)), np.inf)
    high = rng.random(25) < 0.35
    cost, rows, cols, ok = priority_cost_matrix(bids, high)
    r, c = linear_sum_assignment(cost)
    take = ok[r, c]
    expect = np.full(25, -1)
    expect[cols[c[take]]] = rows[r[take]]
    np.testing.assert_array_equal(solve_priority_assignment_dense(bids, high), expect)
    assert priority_cost_matrix(np.full((3, 2), np.inf), high[:2]) is None


def test_bench_costs_reports_every_cost_model_and_the_field():
    SHARED.clear()
    out = bench_costs(sizes=(10, 300), rounds={10: 3, 300: 3})
    assert list(out) == ["10", "300"]
    for row in out.values():
        for name in ("abstract", "straight", "distance", "time"):
            assert row[f"{name}_ms"] > 0
    assert "field_build_s" not in out["10"]  # 10 robots: exact bids, no field
    assert out["300"]["field_build_s"] > 0
    assert 0 < out["300"]["field_mib"] <= out["300"]["field_peak_mib"]


def test_bench_assignment_times_scipy_and_checks_lapjv_when_installed():
    out = bench_assignment(sizes=(30,), repeat=1)
    row = out["30"]
    assert row["scipy_dense_ms"] > 0 and row["scipy_sparse_ms"] > 0
    if importlib.util.find_spec("lap") is not None:
        assert row["same_dense"] == 1.0 and row["same_sparse"] == 1.0
        assert row["ratio_dense"] > 0
    else:
        assert "lapjv_dense_ms" not in row
