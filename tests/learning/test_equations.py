"""ExpT-MRTA's use of experience, pinned with hand-computed numbers (paper §5, eq. 8 and 9).

Three robots, each the only one for its own type (R0: A, R1: B, R2: C), so every robot bids
alone and its numbers are not mixed with anyone else's. R0 is eager (behaviour 1, TEM u = 1.5),
R1 hesitant (behaviour 1, u = 0.5), R2 regular (behaviour 0, with u = 1.25 that it must ignore).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from learning.experience import B0_REGULAR, B1_EAGER_HESITANT
from learning.exptmrta import ExpTAllocator
from learning.qlmrta import QLAllocator
from learning.qtable import DO, WAIT
from sim.scenario import LearningSpec, RobotSpec, Scenario
from sim.tasks import Batch
from sim.world import WorldState

INF = float("inf")
U = (1.5, 0.5, 1.25)  # TEM of R0 (eager), R1 (hesitant), R2 (regular) for their own type
BEHAVIOUR = (B1_EAGER_HESITANT, B1_EAGER_HESITANT, B0_REGULAR)
ALPHA = 0.5


def scenario(shared: bool = False) -> Scenario:
    """R0..R2 each do their own type; with ``shared`` all three also do type A."""
    caps = ((0,), (0, 1), (0, 2)) if shared else ((0,), (1,), (2,))
    cost = [[INF] * 3 for _ in range(3)]
    for j, cs in enumerate(caps):
        for i in cs:
            cost[j][i] = 1.0
    return Scenario(
        name="trio",
        task_types=("A", "B", "C"),
        robots=tuple(RobotSpec(f"R{j}", c) for j, c in enumerate(caps)),
        cost=tuple(map(tuple, cost)),
        exec_time_s=(10.0, 10.0, 10.0),
        learning=LearningSpec(
            alpha=ALPHA, gamma=0.9, epsilon_start=0.0, epsilon_end=0.0, history=1
        ),
    )


def experienced(alloc: ExpTAllocator, types: tuple[int, int, int]) -> ExpTAllocator:
    """Give robot j TEM U[j] and behaviour BEHAVIOUR[j] for ``types[j]`` (4 observations)."""
    ex = alloc.experience_
    for j, i in enumerate(types):
        ex.count_[j, i] = 4
        ex.v_sum_[j, i] = 4 * U[j]
        ex.behaviour_[j, i] = BEHAVIOUR[j]
    return alloc


def all_free() -> WorldState:
    return WorldState(0.0, np.ones(3, dtype=bool), np.zeros(3))


def batch(types, high) -> Batch:
    k = len(types)
    return Batch(0, 0, np.arange(k), np.array(types), np.array(high), np.full((k, 2), np.nan))


def test_eq8_bid_is_cost_over_tem_for_eager_and_hesitant_cost_for_regular():
    alloc = experienced(ExpTAllocator(scenario(shared=True)), (0, 0, 0))
    costs = np.array([[9.0], [4.0], [7.0]])
    assignment, bids = alloc.allocate(all_free(), batch([0], [True]), costs)
    # eager 9 / 1.5 = 6 goes down, hesitant 4 / 0.5 = 8 goes up, regular bids its cost 7
    np.testing.assert_array_equal(bids[:, 0], [6.0, 8.0, 7.0])
    # so the eager robot wins although its cost is the highest and the hesitant one's the lowest
    assert assignment.tolist() == [0]


def test_ql_mrta_bids_plain_cost_whatever_the_experience():
    alloc = QLAllocator(scenario(shared=True))
    costs = np.array([[9.0], [4.0], [7.0]])
    assignment, bids = alloc.allocate(all_free(), batch([0], [True]), costs)
    np.testing.assert_array_equal(bids[:, 0], [9.0, 4.0, 7.0])
    assert assignment.tolist() == [1]


def q_after_one_set(alloc: QLAllocator, prefer: int) -> np.ndarray:
    """Q(s, prefer) of each robot for its own type after one learning set:

    ``prefer = DO``: each robot bids for a low task of its type, wins it (reward_low = 1);
    ``prefer = WAIT``: each robot waits on a low task, then wins a high one (reward_high = 5).
    The set then ends, closing the decision as terminal: Q = alpha * r'.
    """
    alloc.begin_set(0, learning=True)
    if prefer == WAIT:
        for table in alloc.learner_.tables_:
            table.q_[:, DO] = -1.0  # greedy choice: wait
    costs = np.ones((3, 3))
    assignment, _ = alloc.allocate(all_free(), batch([0, 1, 2], [False] * 3), costs)
    assert assignment.tolist() == ([0, 1, 2] if prefer == DO else [-1, -1, -1])
    if prefer == WAIT:
        assignment, _ = alloc.allocate(all_free(), batch([0, 1, 2], [True] * 3), costs)
        assert assignment.tolist() == [0, 1, 2]
    alloc.end_set()
    return np.array([t.q_[0, prefer] for t in alloc.learner_.tables_])


def test_eq9_do_reward_is_scaled_by_tem():
    alloc = experienced(ExpTAllocator(scenario()), (0, 1, 2))
    q = q_after_one_set(alloc, DO)
    # alpha * u * r_low: eager 0.5 * 1.5 * 1, hesitant 0.5 * 0.5 * 1, regular 0.5 * 1 * 1
    np.testing.assert_allclose(q, [0.75, 0.25, 0.5], rtol=1e-12)


def test_eq9_wait_reward_is_divided_by_tem():
    alloc = experienced(ExpTAllocator(scenario()), (0, 1, 2))
    q = q_after_one_set(alloc, WAIT)
    # Q(s, wait) starts at 0; alpha * r_high / u: eager 0.5 * 5 / 1.5, hesitant 0.5 * 5 / 0.5,
    # regular 0.5 * 5
    np.testing.assert_allclose(q, [5 / 3, 5.0, 2.5], rtol=1e-12)


@pytest.mark.parametrize(("prefer", "expected"), [(DO, 0.5), (WAIT, 2.5)])
def test_ql_mrta_rewards_are_unscaled(prefer, expected):
    q = q_after_one_set(QLAllocator(scenario()), prefer)
    np.testing.assert_allclose(q, [expected] * 3, rtol=1e-12)


def test_refusal_is_logged_with_the_auction_count_and_shrinks_the_space():
    sc = scenario(shared=True)
    sc = dataclasses.replace(
        sc, experience=dataclasses.replace(sc.experience, delta_u=0.6, n_min=4, coverage_k=1)
    )
    alloc = experienced(ExpTAllocator(sc), (0, 0, 0))  # on A: R1 hesitant (u = 0.5)
    assert alloc.learning_space().tolist() == [2, 4, 4]
    alloc.begin_set(0, learning=True)
    alloc.allocate(all_free(), batch([0, 1], [True, True]), np.ones((3, 2)))
    # two auctions observed; R1's TEM on A stays below 0.6, R0 and R2 are above it
    assert alloc.refusal_log_ == [(2, 1, 0)]
    assert alloc.learning_space().tolist() == [2, 2, 4]
    assert alloc.initial_space_.tolist() == [2, 4, 4]  # the space it started from


def test_a_new_allocator_explores_as_one_reset_with_seed_0():
    sc = scenario(shared=True)
    sc = dataclasses.replace(sc, learning=dataclasses.replace(sc.learning, epsilon_start=1.0))
    fresh, reset = QLAllocator(sc), QLAllocator(sc)
    reset.reset(np.random.default_rng(0))
    rounds = [batch([0, 0, 1, 2], [False] * 4) for _ in range(8)]
    seen = []
    for alloc in (fresh, reset):
        alloc.begin_set(0, learning=True)
        seen.append([alloc.allocate(all_free(), b, np.ones((3, 4)))[1].tolist() for b in rounds])
    assert seen[0] == seen[1]
    assert len({str(bids) for bids in seen[0]}) > 1  # the draws do differ from round to round
