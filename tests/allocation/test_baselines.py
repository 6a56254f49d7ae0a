"""Greedy and CBBA baselines: hand-built rounds, CBBA's guarantees on random instances."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from allocation.cbba import cbba, priority_scores
from allocation.greedy import greedy_assignment

INF = np.inf


def test_greedy_serves_high_priority_first_then_announcement_order():
    bids = np.array([[1.0, 2.0, 9.0], [3.0, 1.0, 9.0], [INF, INF, 4.0]])
    high = np.array([False, True, False])
    # task 1 (high) takes robot 1 (cost 1); task 0 then robot 0; task 2 only robot 2
    assert greedy_assignment(bids, high).tolist() == [0, 1, 2]


def test_greedy_never_revises_an_earlier_choice():
    """Robot 0 is cheapest for both tasks: task 0 takes it, task 1 gets the dearer robot 1,
    although giving task 1 to robot 0 and task 0 to robot 1 would cost 1 + 2 instead of 1 + 10."""
    bids = np.array([[1.0, 1.0], [2.0, 10.0]])
    assert greedy_assignment(bids, np.array([False, False])).tolist() == [0, 1]


def test_greedy_loses_a_task_when_its_only_bidder_is_taken():
    bids = np.array([[1.0, 5.0], [INF, INF]])
    assert greedy_assignment(bids, np.array([True, False])).tolist() == [0, -1]


def score_greedy(scores: np.ndarray) -> np.ndarray:
    """Sequential greedy by score (the known result of CBBA with L = 1 and a full graph):
    repeatedly give the best remaining (robot, task) pair; ties to the lower robot index."""
    m, k = scores.shape
    s = scores.copy()
    out = np.full(k, -1)
    while np.isfinite(s).any():
        flat = np.argmax(np.where(np.isfinite(s), s, -np.inf).T.ravel())  # task-major ties
        j, i = divmod(int(flat), m)
        best_i = min(np.flatnonzero(s[:, j] == s[i, j]))
        out[j] = best_i
        s[best_i, :] = -np.inf
        s[:, j] = -np.inf
    return out


def random_graph(rng, m: int) -> np.ndarray:
    """A connected random graph: a random spanning tree plus random extra edges."""
    adj = np.eye(m, dtype=bool)
    order = rng.permutation(m)
    for a in range(1, m):
        b = order[rng.integers(a)]
        adj[order[a], b] = adj[b, order[a]] = True
    extra = rng.random((m, m)) < 0.2
    return adj | extra | extra.T


def random_instance(rng, m: int, k: int):
    bids = np.round(rng.uniform(1, 10, (m, k)), 1)
    bids[rng.random((m, k)) < 0.25] = INF
    high = rng.random(k) < 0.35
    return bids, high


def conflict_free(result, scores, length: int) -> bool:
    taken = [j for b in result.bundles for j in b]
    ok_unique = len(taken) == len(set(taken))
    ok_length = all(len(b) <= length for b in result.bundles)
    ok_bids = all(np.isfinite(scores[i, j]) for i, b in enumerate(result.bundles) for j in b)
    ok_winners = all(result.winners[j] == i for i, b in enumerate(result.bundles) for j in b)
    return ok_unique and ok_length and ok_bids and ok_winners


@pytest.mark.parametrize("length", [1, 2, 3])
def test_cbba_converges_conflict_free_within_the_bound_on_random_graphs(length):
    rng = np.random.default_rng(100 + length)
    for _ in range(150):
        m, k = int(rng.integers(2, 8)), int(rng.integers(1, 8))
        bids, high = random_instance(rng, m, k)
        scores = priority_scores(bids, high)
        adj = random_graph(rng, m)
        from scipy.sparse.csgraph import shortest_path

        diameter = int(shortest_path(adj.astype(float), unweighted=True).max())
        result = cbba(scores, adj, length)
        assert result.converged
        # Choi et al.: within min(k, m L) x D rounds, plus one to see that nothing changed
        assert result.iterations <= min(k, m * length) * diameter + 1
        assert conflict_free(result, scores, length)
        # no task left open that some robot with room could still have taken
        room = [i for i, b in enumerate(result.bundles) if len(b) < length]
        for j in np.flatnonzero(result.winners < 0):
            assert not np.isfinite(scores[room, j]).any()


def test_cbba_with_a_full_graph_and_bundles_of_one_is_greedy_by_score():
    rng = np.random.default_rng(7)
    for _ in range(300):
        m, k = int(rng.integers(1, 9)), int(rng.integers(1, 8))
        bids, high = random_instance(rng, m, k)
        scores = priority_scores(bids, high)
        assert cbba(scores).winners.tolist() == score_greedy(scores).tolist()


def brute_force_score(scores: np.ndarray) -> float:
    """Best total score with at most one task per robot, by enumerating assignments."""
    m, k = scores.shape
    best = 0.0
    for robots in itertools.product(range(-1, m), repeat=k):
        used = [r for r in robots if r >= 0]
        if len(used) != len(set(used)):
            continue
        vals = [scores[r, t] for t, r in enumerate(robots) if r >= 0]
        if all(np.isfinite(vals)):
            best = max(best, float(sum(vals)))
    return best


def test_cbba_is_optimal_for_consistent_costs():
    """Additive costs c(j, t) = a_j + b_t, everyone capable, one priority: every assignment
    that serves all tasks has the same total, and CBBA serves them all, so it is optimal."""
    rng = np.random.default_rng(11)
    for _ in range(100):
        m, k = int(rng.integers(3, 6)), int(rng.integers(1, 4))
        bids = rng.uniform(1, 5, (m, 1)) + rng.uniform(1, 5, (1, k))
        scores = priority_scores(bids, np.zeros(k, dtype=bool))
        result = cbba(scores, random_graph(rng, m))
        got = sum(scores[i, j] for i, b in enumerate(result.bundles) for j in b)
        assert got == pytest.approx(brute_force_score(scores), abs=1e-9)


def test_cbba_total_score_against_the_optimum_on_1000_instances(report_line, brute_force):
    """CBBA (L = 1) is greedy: at least half the optimal score (Choi et al.'s bound for
    scores with diminishing marginal gain); the ratio's distribution goes to the test report."""
    rng = np.random.default_rng(2009)
    ratios, optimal, same_counts, cost_ratios = [], 0, 0, []
    for _ in range(1000):
        m, k = int(rng.integers(2, 6)), int(rng.integers(1, 5))
        bids, high = random_instance(rng, m, k)
        scores = priority_scores(bids, high)
        best = brute_force_score(scores)
        result = cbba(scores, random_graph(rng, m))
        got = sum(scores[i, j] for i, b in enumerate(result.bundles) for j in b)
        assert got <= best + 1e-9
        assert got >= 0.5 * best - 1e-9
        if best > 0:
            ratios.append(got / best)
            optimal += got >= best - 1e-9
        # in the market's terms: tasks served per priority, then the total bid
        opt_high, opt_low, opt_cost = brute_force(bids, high)
        won = result.winners >= 0
        mine = (int((won & high).sum()), int((won & ~high).sum()))
        assert mine[0] <= opt_high
        if mine == (opt_high, opt_low) and opt_cost > 0:
            same_counts += 1
            cost = float(bids[result.winners[won], np.flatnonzero(won)].sum())
            assert cost >= opt_cost - 1e-9
            cost_ratios.append(cost / opt_cost)
    ratios = np.array(ratios)
    report_line(
        f"CBBA (L=1) against the brute-force optimum, {ratios.size} random instances: "
        f"optimal in {optimal} ({optimal / ratios.size:.1%}), score ratio mean "
        f"{ratios.mean():.4f}, worst {ratios.min():.4f}; the optimum's count of high and low "
        f"tasks in {same_counts}, there total bid / optimal {np.mean(cost_ratios):.4f} on "
        f"average, worst {np.max(cost_ratios):.4f}"
    )
    assert ratios.mean() > 0.9


def test_cbba_in_a_spatial_world_hears_only_robots_within_its_radius(paper):
    """Two robots 30 m apart, both able to do the task: with a 10 m radius they cannot agree,
    both claim it, and the better claim (the cheaper robot) takes it; the other stays free."""
    from allocation.cbba import CBBAAllocator
    from sim.tasks import Batch
    from sim.world import WorldState

    class Local(CBBAAllocator):
        comm_radius_m = 10.0

    m = paper.n_robots
    costs = np.full((m, 1), INF)
    costs[[0, 1], 0] = [5.0, 3.0]
    positions = np.zeros((m, 2))
    positions[1] = (30.0, 0.0)
    state = WorldState(0.0, np.ones(m, bool), np.zeros(m), positions)
    batch = Batch(0, 0, np.arange(1), np.array([0]), np.array([True]), np.zeros((1, 2)))
    local = Local(paper)
    assignment, _ = local.allocate(state, batch, costs)
    assert assignment.tolist() == [1] and local.last_conflicts_ == 1
    full = CBBAAllocator(paper)
    assert full.allocate(state, batch, costs)[0].tolist() == [1] and full.last_conflicts_ == 0
