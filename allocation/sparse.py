"""Bidder reduction for the priority auction: with k tasks, k bidders per task are enough.

The auction of a round sees m robots and k announced tasks, with k <= 7 and m up to thousands.
Only a handful of the robots can matter to the optimum; :func:`cheapest_bidders` keeps them.
"""

from __future__ import annotations

import numpy as np


def cheapest_bidders(bids: np.ndarray, keep: int | None = None) -> np.ndarray:
    """Rows (robots) among the ``keep`` cheapest bidders of at least one task.

    With ``keep`` = k (the number of tasks, the default), solving the priority auction on these
    rows alone gives an assignment that is optimal for the whole bid matrix, for the
    lexicographic objective of :func:`allocation.auction.solve_priority_assignment` (most high
    tasks, then most low tasks, then least total bid).

    Proof. Let C_t be a set of ``min(k, b_t)`` cheapest bidders of task t (b_t = its number of
    bidders; among equal bids any choice will do) and take any optimal assignment A of the full
    matrix. Suppose A gives t to a robot r outside C_t. Then t has more than k bidders (else C_t
    holds them all), so |C_t| = k. The other k - 1 tasks use at most k - 1 robots and t uses r,
    which is not in C_t, so some r' in C_t is unused by A. Giving t to r' instead of r keeps
    every task's status (taken or not, high or low) and changes the total bid by
    bid(r', t) - bid(r, t) <= 0: the new assignment is still optimal, one more task is served
    from its C_t, and no other task changes. After at most k such exchanges every task is served
    from its C_t, so an optimum of the full problem lies inside the union of the C_t. Every
    assignment of the reduced problem is an assignment of the full one, so both optimal values
    are equal and every optimum of the reduced problem is an optimum of the full one. []

    The argument needs nothing about the bids beyond "cheaper is better for the tie-break", so it
    holds for any non-negative bids, ties included (only which of several equally good optima is
    returned may differ).

    Args:
        bids: (m, k) bids; ``inf`` or NaN means "no bid".
        keep: bidders kept per task; default k. Fewer than k can lose optimality.

    Returns:
        Sorted row indices, at most ``keep * k`` of them.
    """
    m, k = bids.shape
    keep = k if keep is None else int(keep)
    valid = np.isfinite(bids)
    if m <= keep:
        return np.flatnonzero(valid.any(axis=1))
    masked = bids if valid.all() else np.where(valid, bids, np.inf)
    # argpartition puts, in every column, ``keep`` entries no larger than all the others first:
    # exactly the C_t of the proof (which of equal bids lands inside does not matter).
    top = np.argpartition(masked, keep - 1, axis=0)[:keep]
    cols = np.broadcast_to(np.arange(k), top.shape)
    return np.unique(top[valid[top, cols]])
