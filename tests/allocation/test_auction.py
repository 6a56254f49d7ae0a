"""The priority auction against brute force, and priority honoured."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from allocation.auction import MarketAllocator, solve_priority_assignment
from sim.tasks import Batch
from sim.world import WorldState


def solution_key(assignment, bids, high):
    taken = np.flatnonzero(assignment >= 0)
    return (
        int(high[taken].sum()),
        int((~high[taken]).sum()),
        float(bids[assignment[taken], taken].sum()),
    )


@st.composite
def instances(draw):
    m = draw(st.integers(1, 5))
    k = draw(st.integers(1, 4))
    values = draw(
        st.lists(
            st.one_of(st.just(np.inf), st.integers(0, 20).map(float), st.floats(0.01, 50.0)),
            min_size=m * k,
            max_size=m * k,
        )
    )
    high = draw(st.lists(st.booleans(), min_size=k, max_size=k))
    return np.array(values).reshape(m, k), np.array(high, dtype=bool)


@settings(max_examples=300, deadline=None)
@given(instances())
def test_matches_brute_force(brute_force, instance):
    bids, high = instance
    assignment = solve_priority_assignment(bids, high)
    used = assignment[assignment >= 0]
    assert len(set(used.tolist())) == used.size  # at most one task per robot
    for t in np.flatnonzero(assignment >= 0):
        assert np.isfinite(bids[assignment[t], t])  # only real bids win
    got = solution_key(assignment, bids, high)
    want = brute_force(bids, high)
    assert got[:2] == want[:2]
    assert abs(got[2] - want[2]) < 1e-9


def test_high_priority_first_even_when_expensive():
    bids = np.array([[100.0, 1.0]])
    assert solve_priority_assignment(bids, np.array([True, False])).tolist() == [0, -1]


def test_more_low_tasks_beat_cheaper_bids():
    # Two robots, two low tasks: R0 is cheap for both; optimum takes both tasks.
    bids = np.array([[1.0, 1.0], [50.0, np.inf]])
    assert solve_priority_assignment(bids, np.array([False, False])).tolist() == [1, 0]


def test_no_bids_no_assignment():
    bids = np.full((3, 2), np.inf)
    assert solve_priority_assignment(bids, np.array([True, False])).tolist() == [-1, -1]


def test_market_robots_learn_nothing_and_bid_their_cost_when_free(tiny):
    alloc = MarketAllocator(tiny)
    space = alloc.learning_space()
    assert space.dtype == np.int64 and space.tolist() == [0, 0, 0]
    assert alloc.experience_snapshot() is None
    np.testing.assert_array_equal(alloc.willing(), tiny.capability_matrix())
    np.testing.assert_array_equal(alloc.allowed(), tiny.capability_matrix())
    state = WorldState(0.0, np.array([True, False, True]), np.zeros(3))
    batch = Batch(0, 0, np.arange(2), np.array([0, 1]), np.array([False, True]), np.zeros((2, 2)))
    costs = np.array([[1.0, np.inf], [0.5, 0.5], [np.inf, 3.0]])
    assignment, bids = alloc.allocate(state, batch, costs)
    np.testing.assert_array_equal(bids, [[1.0, np.inf], [np.inf, np.inf], [np.inf, 3.0]])
    assert assignment.tolist() == [0, 2]  # R2 is busy: its cheaper bids are not placed
