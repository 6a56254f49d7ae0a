"""CBBA baseline: the consensus-based bundle algorithm (Choi, Brunet and How, IEEE T-RO 2009).

Every robot builds a bundle of at most ``bundle_length`` tasks greedily from its own scores,
outbidding the winning bids it believes in; then robots exchange winning bids, winners and
timestamps with their neighbours in a communication graph and resolve conflicts with the
paper's decision table (update, reset or leave, per task); a robot outbid on a task drops it and
every task it added after it. The two phases repeat until no robot's beliefs change. With a
connected graph and scores that do not grow with the bundle (ours are constant per task), it
converges to a conflict-free assignment within ``min(k, m * L) * D`` iterations (D: the graph's
diameter).

Scores put priority first, as the market does: a task is worth ``n + 1`` if high priority and 1
if low (n = the number of tasks), less its cost scaled below 1, so a robot always prefers any
high-priority task it can do, then the cheaper one. With ``bundle_length = 1`` (the
allocator's default: a robot does one task at a time and tasks do not queue) and a full graph
the result equals the sequential greedy by score.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from allocation.base import BaseAllocator
from allocation.sparse import cheapest_bidders
from sim.scenario import Scenario
from sim.tasks import Batch
from sim.world import WorldState

NONE = -1
REDUCE_ABOVE = 64  # free bidders above which a full graph keeps only the k cheapest per task


@dataclass(frozen=True, slots=True)
class CBBAResult:
    """Bundles, final winners and how many iterations consensus took."""

    winners: np.ndarray  # (k,) robot per task or -1 (best claim if robots could not agree)
    bundles: list[list[int]]  # per robot, tasks in the order they were added
    iterations: int
    converged: bool


def priority_scores(bids: np.ndarray, high: np.ndarray) -> np.ndarray:
    """Scores from bids: ``n + 1`` per high task, 1 per low one, less cost / scale (> 0).

    ``-inf`` where there is no bid (``inf`` or NaN).
    """
    ok = np.isfinite(bids)
    out = np.full(bids.shape, -np.inf)
    if not ok.any():
        return out
    k = bids.shape[1]
    scale = float(bids[ok].max()) * (k + 1) + 1.0
    worth = np.where(high, k + 1.0, 1.0)
    out[ok] = (worth[None, :] - np.where(ok, bids, 0.0) / scale)[ok]
    return out


def cbba(
    scores: np.ndarray,
    adjacency: np.ndarray | None = None,
    bundle_length: int = 1,
    max_iterations: int | None = None,
) -> CBBAResult:
    """Run CBBA on a score matrix.

    Args:
        scores: (m, k) score of robot i for task j, ``-inf`` where it cannot bid. Scores are
            constant per task (no path dependence), so marginal scores equal scores.
        adjacency: (m, m) bool, True where two robots hear each other (symmetric); None: all.
        bundle_length: L, the most tasks one robot may hold.
        max_iterations: stop after this many (default: 10 x the convergence bound).

    Returns:
        The winners per task (-1: nobody), each robot's bundle and the iterations used.
    """
    m, k = scores.shape
    adj = np.ones((m, m), dtype=bool) if adjacency is None else np.asarray(adjacency, bool)
    adj = adj | np.eye(m, dtype=bool)
    diameter = _diameter(adj)
    bound = max(1, min(k, m * bundle_length)) * max(diameter, 1)
    limit = 10 * bound + 10 if max_iterations is None else max_iterations
    y = np.zeros((m, k))  # robot i's belief of the winning score of task j
    z = np.full((m, k), NONE, dtype=int)  # robot i's belief of the winner of task j
    s = np.zeros((m, m))  # robot i's time stamp of the last information from robot k
    bundles: list[list[int]] = [[] for _ in range(m)]
    for it in range(1, limit + 1):
        before = (y.copy(), z.copy(), [b[:] for b in bundles])
        for i in range(m):
            _build_bundle(i, scores, y, z, bundles[i], bundle_length)
        y, z, s = _consensus(y, z, s, adj, it)
        for i in range(m):
            _release_outbid(i, y, z, bundles[i])
        if np.array_equal(before[0], y) and np.array_equal(before[1], z) and before[2] == bundles:
            return CBBAResult(_winners(scores, bundles), bundles, it, True)
    return CBBAResult(_winners(scores, bundles), bundles, limit, False)


def _winners(scores: np.ndarray, bundles: list[list[int]]) -> np.ndarray:
    """Winner per task. Robots that cannot hear each other (a disconnected graph) may both
    claim a task: the best claim wins (ties: the lower index), as if it had arrived first."""
    winners = np.full(scores.shape[1], NONE, dtype=int)
    for i, bundle in enumerate(bundles):
        for j in bundle:
            w = winners[j]
            if w == NONE or _beats(scores[i, j], i, scores[w, j], w):
                winners[j] = i
    return winners


def _beats(score_a: float, robot_a: int, score_b: float, robot_b: int) -> bool:
    """Does (score_a by robot_a) outbid (score_b by robot_b)? Ties: the lower index wins."""
    if robot_b == NONE:
        return True
    return score_a > score_b or (score_a == score_b and robot_a < robot_b)


def _build_bundle(i: int, scores, y, z, bundle: list[int], length: int) -> None:
    """Phase 1: add the best task this robot can outbid until the bundle is full."""
    while len(bundle) < length:
        best, best_j = -np.inf, NONE
        for j in range(scores.shape[1]):
            c = scores[i, j]
            if j in bundle or not np.isfinite(c) or not _beats(c, i, y[i, j], z[i, j]):
                continue
            if c > best:
                best, best_j = c, j
        if best_j == NONE:
            return
        bundle.append(best_j)
        y[i, best_j], z[i, best_j] = best, i


def _consensus(y, z, s, adj, now: int):
    """Phase 2: every robot applies the decision table to what each neighbour sent."""
    m, k = y.shape
    y_new, z_new, s_new = y.copy(), z.copy(), s.copy()
    for i in range(m):
        for n in np.flatnonzero(adj[i]):
            if n == i:
                continue
            s_new[i, n] = now
        for n in np.flatnonzero(adj[i]):
            if n == i:
                continue
            for j in range(k):
                act = _decide(i, n, j, y, z, s, y_new, z_new)
                if act == "update":
                    y_new[i, j], z_new[i, j] = y[n, j], z[n, j]
                elif act == "reset":
                    y_new[i, j], z_new[i, j] = 0.0, NONE
            others = np.ones(m, dtype=bool)
            others[[i, n]] = False
            s_new[i, others] = np.maximum(s_new[i, others], s[n, others])
    return y_new, z_new, s_new


def _decide(i: int, k_: int, j: int, y, z, s, y_i, z_i) -> str:
    """Choi et al. Table 1: receiver i, sender k_, task j -> 'update', 'reset' or 'leave'."""
    zk, zi = z[k_, j], z_i[i, j]
    yk, yi = y[k_, j], y_i[i, j]

    def newer(m_: int) -> bool:
        return s[k_, m_] > s[i, m_]

    if zk == k_:
        if zi == i:
            return "update" if _beats(yk, zk, yi, zi) else "leave"
        if zi == k_ or zi == NONE:
            return "update"
        return "update" if newer(zi) or _beats(yk, zk, yi, zi) else "leave"
    if zk == i:
        if zi == k_:
            return "reset"
        if zi not in (i, NONE) and newer(zi):
            return "reset"
        return "leave"
    if zk != NONE:  # the sender believes a third robot m wins
        m_ = zk
        if zi == i:
            return "update" if newer(m_) and _beats(yk, zk, yi, zi) else "leave"
        if zi == k_:
            return "update" if newer(m_) else "reset"
        if zi == m_:
            return "update" if newer(m_) else "leave"
        if zi == NONE:
            return "update" if newer(m_) else "leave"
        n_ = zi  # a fourth robot
        if newer(m_) and newer(n_):
            return "update"
        if newer(m_) and _beats(yk, zk, yi, zi):
            return "update"
        if newer(n_) and s[i, m_] > s[k_, m_]:
            return "reset"
        return "leave"
    # the sender believes nobody wins
    if zi == k_:
        return "update"
    if zi not in (i, NONE) and newer(zi):
        return "update"
    return "leave"


def _release_outbid(i: int, y, z, bundle: list[int]) -> None:
    """A robot outbid on a task drops it and every task it added after it."""
    for pos, j in enumerate(bundle):
        if z[i, j] != i:
            for later in bundle[pos + 1 :]:
                if z[i, later] == i:
                    y[i, later], z[i, later] = 0.0, NONE
            del bundle[pos:]
            return


def _diameter(adj: np.ndarray) -> int:
    """Longest shortest path (hops) of the communication graph; m if disconnected."""
    from scipy.sparse.csgraph import shortest_path

    d = shortest_path(adj.astype(float), unweighted=True)
    return int(d.max()) if np.isfinite(d).all() else adj.shape[0]


class CBBAAllocator(BaseAllocator):
    """``cbba``: free capable robots reach consensus on who takes which announced task.

    Bundle length 1 (a robot does one task at a time, tasks do not queue). The communication
    graph is full, or in a spatial world, when ``comm_radius_m`` > 0, robots within that many
    metres of each other (set it on the class or a subclass; 0 = full). Robots in different
    components of that graph can claim the same task; the best claim takes it and the other
    robot stays free (``last_conflicts_`` counts such tasks in the latest round).
    """

    name = "cbba"
    bundle_length = 1
    comm_radius_m = 0.0

    def __init__(self, scenario: Scenario) -> None:
        super().__init__(scenario)
        self.last_iterations_ = 0
        self.last_conflicts_ = 0

    def allocate(
        self, state: WorldState, batch: Batch, costs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        bids = self.bids(state, costs)
        out = np.full(len(batch), NONE, dtype=int)
        rows = np.flatnonzero(np.isfinite(bids).any(axis=1))
        spatial = self.comm_radius_m > 0 and state.positions is not None
        if not spatial and rows.size > REDUCE_ABOVE:
            rows = cheapest_bidders(bids)  # exact for a full graph (the greedy-by-score result)
        if rows.size == 0:
            return out, bids
        adjacency = None
        if spatial:
            p = state.positions[rows]
            gap = np.linalg.norm(p[:, None, :] - p[None, :, :], axis=-1)
            adjacency = gap <= self.comm_radius_m
        result = cbba(priority_scores(bids[rows], batch.high), adjacency, self.bundle_length)
        self.last_iterations_ = result.iterations
        claims = np.bincount([j for b in result.bundles for j in b], minlength=len(batch))
        self.last_conflicts_ = int((claims > 1).sum())
        won = result.winners >= 0
        out[won] = rows[result.winners[won]]
        return out, bids
