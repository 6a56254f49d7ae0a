"""1000 robots: the scale scenario, the bidder reduction of the auction, one round at scale."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from allocation.auction import (
    REDUCE_ABOVE,
    MarketAllocator,
    solve_priority_assignment,
    solve_priority_assignment_dense,
)
from allocation.costs import make_cost_model
from allocation.sparse import cheapest_bidders
from learning.episode import run_protocol
from scenarios.bench.alloc import bench_alloc
from scenarios.loader import load_scenario
from sim.tasks import Batch, generate_stream
from sim.world import AbstractWorld, WorldState

DATA = Path(__file__).resolve().parents[2] / "scenarios" / "data"


@pytest.fixture(scope="module")
def scale():
    return load_scenario("scale1000")


def key(assignment, bids, high):
    """(high tasks taken, low tasks taken, total bid) of an assignment, checked for validity."""
    taken = np.flatnonzero(assignment >= 0)
    robots = assignment[taken]
    assert np.unique(robots).size == robots.size, "a robot got two tasks"
    assert np.isfinite(bids[robots, taken]).all(), "a task went to a robot that did not bid"
    return int(high[taken].sum()), int((~high[taken]).sum()), float(bids[robots, taken].sum())


def random_instance(rng, m, k, density, integer):
    bids = rng.integers(0, 6, (m, k)).astype(float) if integer else rng.uniform(0, 50, (m, k))
    bids[rng.random((m, k)) > density] = np.inf
    bids[rng.random((m, k)) < 0.01] = np.nan  # NaN is "no bid" too
    return bids, rng.random(k) < 0.35


def test_scale1000_loads_as_specified(scale):
    cap = scale.capability_matrix()
    assert (scale.n_robots, scale.n_types) == (1000, 50)
    assert cap.sum(axis=1).min() == 2 and cap.sum(axis=1).max() == 8
    assert cap.any(axis=0).all()
    assert scale.spatial is None
    assert scale.stream.batch_max == 7  # fits the envs' 7 slots
    assert np.isfinite(scale.cost_matrix()[cap]).all()


def test_scale1000_is_what_its_generator_writes():
    spec = importlib.util.spec_from_file_location("make_scale1000", DATA / "make_scale1000.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    assert gen.scale_toml() == (DATA / "scale1000.toml").read_text()


@pytest.mark.parametrize("integer", [False, True])
def test_reduced_auction_equals_full_on_large_instances(integer):
    rng = np.random.default_rng(7 + integer)
    for _ in range(40):
        m = int(rng.integers(REDUCE_ABOVE + 1, 3000))
        k = int(rng.integers(1, 8))
        bids, high = random_instance(rng, m, k, float(rng.choice([0.002, 0.02, 0.2, 1.0])), integer)
        got = solve_priority_assignment(bids, high)
        want = solve_priority_assignment_dense(bids, high)
        g, w = key(got, bids, high), key(want, bids, high)
        assert g[:2] == w[:2]
        assert g[2] == pytest.approx(w[2], abs=1e-9)
        if not integer:  # continuous bids: the optimum is unique, so the very same assignment
            assert got.tolist() == want.tolist()


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 7), st.integers(1, 3))
def test_k_cheapest_bidders_per_task_keep_the_optimum(brute_force, seed, m, k):
    rng = np.random.default_rng(seed)
    bids, high = random_instance(rng, m, k, 0.7, integer=True)
    rows = cheapest_bidders(bids)
    assert rows.size <= k * k
    sub = solve_priority_assignment_dense(bids[rows], high)
    full = np.full(k, -1)
    full[sub >= 0] = rows[sub[sub >= 0]]
    got, want = key(full, bids, high), brute_force(bids, high)
    assert got[:2] == want[:2] and got[2] == pytest.approx(want[2])


def test_fewer_than_k_bidders_per_task_can_lose_the_optimum():
    # R0 is the cheapest for both tasks; keeping only 1 bidder per task drops R1.
    bids = np.array([[1.0, 1.0], [2.0, np.inf]])
    assert cheapest_bidders(bids, keep=1).tolist() == [0]
    assert cheapest_bidders(bids).tolist() == [0, 1]
    assert solve_priority_assignment(bids, np.array([False, False])).tolist() == [1, 0]


def test_one_round_with_1000_free_bidders(scale):
    m = scale.n_robots
    rng = np.random.default_rng(3)
    types = rng.choice(scale.n_types, size=7, replace=False)
    high = np.array([True, False, True, False, False, True, False])
    batch = Batch(0, 0, np.arange(7), types, high, np.full((7, 2), np.nan))
    state = WorldState(0.0, np.ones(m, dtype=bool), np.zeros(m))
    costs = make_cost_model("abstract", scale).costs(state, batch)
    assignment, bids = MarketAllocator(scale).allocate(state, batch, costs)
    assert (assignment >= 0).all()  # ~100 capable robots per type: every task is taken
    assert scale.capability_matrix()[assignment, types].all()
    # ~100 bidders per task and integer costs 2-10: each task still gets a minimum-cost robot
    assert np.array_equal(costs[assignment, np.arange(7)], np.min(costs, axis=0))
    assert key(assignment, bids, high) == key(
        solve_priority_assignment_dense(bids, high), bids, high
    )


def test_market_protocol_at_scale_keeps_every_invariant(scale):
    stream_spec = dataclasses.replace(
        scale.stream, n_sets=2, rounds_per_set=40, learn_sets=1, test_sets=1
    )
    sc = dataclasses.replace(scale, stream=stream_spec)
    stream = generate_stream(sc, np.random.default_rng(0))
    rec = run_protocol(  # checks assignment validity and task conservation every round
        sc,
        stream,
        MarketAllocator(sc),
        AbstractWorld(sc),
        make_cost_model("abstract", sc),
        np.random.default_rng(1),
        trace=False,
    )
    ids, assigned = rec.test.arrays()
    assert ids.size == int((stream.set_index == 1).sum())
    assert (assigned >= 0).mean() > 0.95  # 40 rounds are far too few to load 1000 robots


@pytest.mark.slow
def test_bench_alloc_reports_every_size_and_allocator():
    from learning import ALLOCATORS

    out = bench_alloc(sizes=(10, 300), rounds=3, allocators=ALLOCATORS)
    assert list(out) == ["10", "300"]
    for size, row in out.items():
        assert row["robots"] == int(size) and row["tasks_per_round"] == 7
        for name in ("", "ql_", "expt_"):
            assert row[f"{name}ms_per_round"] > 0 and row[f"{name}peak_mib"] > 0
        assert row["auction_ms"] > 0 and row["auction_dense_ms"] > 0
    assert out["300"]["ql_peak_mib"] > out["10"]["ql_peak_mib"]  # Q-tables grow with the team
