"""The straight-line cost and the priority auction's cost matrix on hand-built inputs."""

from __future__ import annotations

import re

import numpy as np
import pytest

from allocation.auction import priority_cost_matrix
from allocation.costs import StraightLineCost
from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.tasks import Batch
from sim.world import WorldState


def team() -> Scenario:
    """R1 does A and B, R2 only B; both stand in a 10 m x 10 m arena."""
    sp = SpatialSpec(10.0, 10.0, (), (((1.0, 1.0),), ((2.0, 2.0),)), DriveSpec())
    robots = (RobotSpec("R1", (0, 1), (1.0, 1.0)), RobotSpec("R2", (1,), (4.0, 5.0)))
    return Scenario("t", ("A", "B"), robots, ((1.0, 1.0), (np.inf, 1.0)), (1.0, 1.0), spatial=sp)


def test_straight_line_costs_are_distances_where_capable_and_inf_elsewhere():
    model = StraightLineCost(team())
    assert model.name == "straight"
    state = WorldState(0.0, np.ones(2, bool), np.zeros(2), np.array([[1.0, 1.0], [4.0, 5.0]]))
    sites = np.array([[4.0, 5.0], [1.0, 1.0], [7.0, 9.0]])
    batch = Batch(0, 0, np.arange(3), np.array([0, 1, 1]), np.zeros(3, bool), sites)
    costs = model.costs(state, batch)
    assert costs.tolist() == [[5.0, 0.0, 10.0], [np.inf, 5.0, 5.0]]


def test_straight_line_costs_without_positions_say_why():
    batch = Batch(0, 0, np.arange(1), np.zeros(1, int), np.zeros(1, bool), np.zeros((1, 2)))
    line = "straight-line costs need a spatial world (scenario has no [spatial])"
    with pytest.raises(ValueError, match=f"^{re.escape(line)}$"):
        StraightLineCost(team()).costs(WorldState(0.0, np.ones(2, bool), np.zeros(2)), batch)


def test_priority_cost_matrix_by_hand():
    """Robot 3 and task 2 have no bid and are left out; a pair without a bid costs 0."""
    inf = np.inf
    bids = np.array([[2.0, inf, inf], [inf, 4.0, inf], [1.0, 3.0, inf], [inf, inf, inf]])
    cost, rows, cols, ok = priority_cost_matrix(bids, np.array([True, False, True]))
    assert (rows.tolist(), cols.tolist()) == ([0, 1, 2], [0, 1])
    assert ok.tolist() == [[True, False], [False, True], [True, True]]
    scale = 4.0 * (2 + 1) + 1.0  # the largest bid x (pairs at most + 1) + 1
    worth = [2 + 1.0, 1.0]  # a high-priority task outweighs any number of low ones
    expect = [
        [-(worth[0] - 2.0 / scale), 0.0],
        [0.0, -(worth[1] - 4.0 / scale)],
        [-(worth[0] - 1.0 / scale), -(worth[1] - 3.0 / scale)],
    ]
    assert cost.tolist() == expect
