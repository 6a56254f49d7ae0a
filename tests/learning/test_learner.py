"""The Q-learner's numbers: the update (alpha, gamma), terminal closes and the epsilon schedule."""

from __future__ import annotations

import numpy as np
import pytest

from learning.learner import Decision, QLearners
from learning.qtable import DO, WAIT, HistoryQTable
from sim.scenario import LearningSpec


class FixedRng:
    """Stands in for the exploration generator: fixed draws, and counts them."""

    def __init__(self, draw: float, action: int) -> None:
        self.draw, self.action, self.calls = draw, action, 0

    def random(self) -> float:
        self.calls += 1
        return self.draw

    def integers(self, n: int) -> int:
        assert n == 2
        return self.action


def learners(rng=None, **spec) -> QLearners:
    """One robot doing types 0 and 1, history 1 (state = current type)."""
    ql = QLearners(np.array([[True, True]]), LearningSpec(history=1, **spec))
    ql.reset(rng if rng is not None else np.random.default_rng(0))
    return ql


def test_update_moves_q_by_alpha_towards_reward_plus_target():
    table = HistoryQTable([0, 1], history=1)
    table.q_[1] = [2.0, -3.0]
    table.update(1, DO, reward=1.0, target=0.5, alpha=0.25)
    # 2 + 0.25 * (1 + 0.5 - 2) = 1.875; nothing else moves
    np.testing.assert_array_equal(table.q_, [[0.0, 0.0], [1.875, -3.0]])


def test_next_decision_closes_the_open_one_with_gamma_max_q_of_the_next_state():
    ql = learners(alpha=0.5, gamma=0.8)
    q = ql.tables_[0].q_
    q[0, WAIT] = 1.0
    q[1] = [3.0, 4.0]
    ql.open(0, Decision(0, WAIT, reward_scale=2.0), next_state=0)
    ql.credit(0, 1.0)
    ql.credit(0, 0.5)
    ql.open(0, Decision(1, DO), next_state=1)
    # r' = 2 * (1 + 0.5) = 3, target = 0.8 * max(3, 4) = 3.2: 1 + 0.5 * (3 + 3.2 - 1) = 3.6
    assert q[0, WAIT] == pytest.approx(3.6, rel=1e-12)
    np.testing.assert_array_equal(q[1], [3.0, 4.0])
    assert ql.pending_[0] == Decision(1, DO)


def test_end_of_a_learning_set_closes_as_terminal_and_a_test_set_learns_nothing():
    ql = learners(alpha=0.5, gamma=0.8)
    q = ql.tables_[0].q_
    q[1] = [3.0, 4.0]
    ql.begin_set(learning=True)
    ql.open(0, Decision(1, DO), next_state=1)
    ql.credit(0, 1.0)
    ql.end_set()
    assert q[1, DO] == pytest.approx(3.0 + 0.5 * (1.0 - 3.0), rel=1e-12)  # target 0: terminal
    assert ql.pending_ == [None]
    ql.begin_set(learning=False)
    ql.open(0, Decision(1, DO), next_state=1)
    ql.credit(0, 1.0)
    ql.end_set()
    assert q[1, DO] == 2.0 and ql.pending_ == [None]


def test_credit_without_an_open_decision_is_dropped():
    ql = learners()
    ql.credit(0, 5.0)
    assert ql.pending_ == [None]
    ql.end_set()
    np.testing.assert_array_equal(ql.tables_[0].q_, 0.0)


def test_epsilon_decays_once_per_learning_set_down_to_its_floor():
    ql = learners(epsilon_start=0.5, epsilon_end=0.1, epsilon_decay=0.5)
    assert ql.epsilon_ == 0.5
    seen = []
    for learning in (True, False, True, True, False, True, True):
        ql.begin_set(learning)
        assert ql.learning_ is learning
        seen.append(ql.epsilon_)
    # 0.5 * 0.5**k for the k-th learning set, never below 0.1; test sets change nothing
    assert seen == [0.5, 0.5, 0.25, 0.125, 0.125, 0.1, 0.1]
    assert ql.learning_sets_seen_ == 5


def test_explores_when_the_draw_is_below_epsilon_else_greedy():
    rng = FixedRng(draw=0.3, action=WAIT)
    ql = learners(rng)
    ql.push(0, 1)
    ql.epsilon_ = 0.3
    assert ql.decide(0) == (1, DO)  # 0.3 is not below 0.3: greedy, ties go to do
    rng.draw = 0.2999
    assert ql.decide(0) == (1, WAIT)  # explores: the generator's action
    ql.tables_[0].q_[1] = [0.0, 1.0]
    rng.draw = 0.5
    assert ql.decide(0) == (1, WAIT)  # greedy again, now towards wait


def test_test_sets_act_greedily_without_drawing():
    rng = FixedRng(draw=0.0, action=WAIT)
    ql = learners(rng, epsilon_start=1.0)
    ql.begin_set(learning=False)
    ql.push(0, 0)
    assert ql.decide(0) == (0, DO)
    assert rng.calls == 0


def test_refusing_a_type_keeps_an_open_decision_that_does_not_involve_it():
    ql = QLearners(np.array([[True, True, True]]), LearningSpec(history=2, alpha=0.5))
    ql.reset(np.random.default_rng(0))
    ql.push(0, 1)
    ql.push(0, 2)  # history (2, 1), current first
    s = ql.tables_[0].state()
    assert s == 2 * 3 + 1
    ql.open(0, Decision(s, DO), next_state=s)
    ql.credit(0, 1.0)
    ql.drop_type(0, 0)
    # alphabet (1, 2): digits 1 -> 0, 2 -> 1, so (2, 1) is 1 * 2 + 0 = 2
    assert ql.pending_[0] == Decision(2, DO, reward=1.0)
    ql.end_set()
    np.testing.assert_array_equal(ql.tables_[0].q_[:, DO], [0.0, 0.0, 0.5, 0.0])


def test_refusing_a_type_drops_an_open_decision_that_involves_it():
    ql = QLearners(np.array([[True, True, True]]), LearningSpec(history=2))
    ql.reset(np.random.default_rng(0))
    ql.push(0, 1)
    ql.push(0, 2)
    ql.open(0, Decision(ql.tables_[0].state(), DO), next_state=0)
    ql.drop_type(0, 1)
    assert ql.pending_ == [None]
