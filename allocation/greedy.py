"""Greedy baseline: each task, high priority first, to the cheapest free capable robot.

Tasks are served one at a time in order (high-priority tasks first, then in announcement
order); each goes to the free, capable robot with the lowest cost that has not been given a
task in this round (ties: the lower robot index). Unlike the market's optimal assignment it
never revises an earlier choice, so a robot that is cheapest for two tasks serves the first
one and the second goes to the next-cheapest robot, or is lost.
"""

from __future__ import annotations

import numpy as np

from allocation.base import BaseAllocator
from sim.tasks import Batch
from sim.world import WorldState


def greedy_assignment(bids: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Sequential greedy over tasks ordered high priority first; returns robot per task or -1.

    Args:
        bids: (m, k) bid of robot j for task t; ``inf`` means no bid.
        high: (k,) True for high-priority tasks.
    """
    m, k = bids.shape
    out = np.full(k, -1, dtype=int)
    taken = np.zeros(m, dtype=bool)
    for t in np.argsort(~np.asarray(high, dtype=bool), kind="stable"):
        col = np.where(taken, np.inf, bids[:, t])
        j = int(np.argmin(col))
        if np.isfinite(col[j]):
            out[t] = j
            taken[j] = True
    return out


class GreedyAllocator(BaseAllocator):
    """``greedy``: every free capable robot bids its cost; tasks are served greedily."""

    name = "greedy"

    def allocate(
        self, state: WorldState, batch: Batch, costs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        bids = self.bids(state, costs)
        return greedy_assignment(bids, batch.high), bids
