"""Brute force for the priority auction, shared by the auction tests."""

from __future__ import annotations

import itertools

import numpy as np
import pytest


def brute_force_best(bids: np.ndarray, high: np.ndarray) -> tuple[int, int, float]:
    """(high tasks, low tasks, total bid) of the best assignment, by enumerating all of them:
    most high-priority tasks, then most low-priority ones, then the lowest total bid."""
    m, k = bids.shape
    best = (0, 0, 0.0)
    for robots in itertools.product(range(-1, m), repeat=k):
        used = [r for r in robots if r >= 0]
        if len(used) != len(set(used)):
            continue
        if any(r >= 0 and not np.isfinite(bids[r, t]) for t, r in enumerate(robots)):
            continue
        taken = [t for t, r in enumerate(robots) if r >= 0]
        cand = (
            sum(bool(high[t]) for t in taken),
            sum(not high[t] for t in taken),
            float(sum(bids[robots[t], t] for t in taken)),
        )
        if (cand[0], cand[1], -round(cand[2], 9)) > (best[0], best[1], -round(best[2], 9)):
            best = cand
    return best


@pytest.fixture(scope="session")
def brute_force():
    return brute_force_best
