"""Learning-space accounting: the paper's 3498, 550 and 512 -> 162 -> 32, exactly."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from learning import QLAllocator
from learning.qlmrta import joint_log10
from learning.qtable import DO, WAIT, HistoryQTable, space_size
from scenarios.experiments.reference import PAPER_TABLE2

TABLE1 = {  # paper Table 1, typed in again independently of scenarios/data/paper.toml
    "R1": "T1 T3 T4 T6",
    "R2": "T1 T2 T5 T7 T8",
    "R3": "T4 T6 T7",
    "R4": "T4 T8",
    "R5": "T2 T5 T7 T8",
    "R6": "T1 T2",
    "R7": "T3 T6 T7",
    "R8": "T2 T5 T8",
    "R9": "T2 T6 T7",
    "R10": "T3 T4 T5 T8",
}


def test_paper_scenario_is_table_1(paper):
    for robot in paper.robots:
        assert [paper.task_types[i] for i in robot.capabilities] == TABLE1[robot.name].split()


def test_table1_learning_space_is_3498(paper):
    alloc = QLAllocator(paper)
    assert int(alloc.learning_space().sum()) == 3498


def test_table2_learning_space_is_550():
    assert sum(space_size(len(kept), 4) for kept in PAPER_TABLE2.values()) == 550


def test_r5_space_512_then_162_then_32():
    table = HistoryQTable([1, 4, 6, 7], history=4)  # T2, T5, T7, T8
    assert table.size == 512 and table.q_.size == 512
    table = table.without(6)  # refuse T7
    assert table.size == 162 and table.q_.size == 162
    table = table.without(4)  # refuse T5
    assert table.size == 32 and table.q_.size == 32
    assert table.alphabet_ == [1, 7]


def test_joint_space_is_the_product_over_robots(paper):
    per_robot = QLAllocator(paper).learning_space()
    expected = sum(math.log10(x) for x in per_robot.tolist())
    assert joint_log10(per_robot) == pytest.approx(expected)
    assert 23.0 < joint_log10(per_robot) < 23.2  # about 10^23 for Table 1


def test_joint_space_of_small_and_empty_teams():
    assert joint_log10(np.array([1, 100])) == 2.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no log10(0): a robot without a space says -inf at once
        assert joint_log10(np.array([0, 0, 0])) == -math.inf
        assert joint_log10(np.array([512, 0])) == -math.inf


def test_history_is_padded_with_the_current_type():
    table = HistoryQTable([3, 5, 9], history=4)
    table.push(5)
    assert table.decode(np.array([table.state()])).tolist() == [[5, 5, 5, 5]]
    table.push(9)
    table.push(3)
    assert table.decode(np.array([table.state()])).tolist() == [[3, 9, 5, 3]]
    for t in (5, 5, 9):
        table.push(t)
    assert table.decode(np.array([table.state()])).tolist() == [[9, 5, 5, 3]]  # only the last 4


def test_refusal_keeps_surviving_values_and_drops_the_type_from_history():
    table = HistoryQTable([0, 1, 2], history=2)
    table.q_[:, DO] = np.arange(9)
    table.q_[:, WAIT] = -np.arange(9)
    for t in (2, 1):
        table.push(t)  # history: current 1, then 2
    smaller = table.without(2)
    for state in range(smaller.q_.shape[0]):
        types = smaller.decode(np.array([state]))[0]
        old = table.encode(types)
        assert smaller.q_[state].tolist() == table.q_[old].tolist()
    assert smaller.recent_ == [1]
    assert smaller.decode(np.array([smaller.state()])).tolist() == [[1, 1]]  # padded, no new symbol
