"""The priority auction against brute force, and priority honoured."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from allocation.auction import solve_priority_assignment


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
