"""Cost models: what a robot bids for a task (SPEC §5). One interface for every world."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from sim.scenario import Scenario
from sim.tasks import Batch
from sim.world import WorldState


class CostModel(Protocol):
    """Bid cost of each robot for each task of a batch: (m, k), ``inf`` where incapable."""

    name: str

    def costs(self, state: WorldState, batch: Batch) -> np.ndarray: ...


class AbstractCost:
    """c(R_j, T_i) from the scenario's table; positions are ignored."""

    name = "abstract"

    def __init__(self, scenario: Scenario) -> None:
        self.table_ = scenario.cost_matrix()

    def costs(self, state: WorldState, batch: Batch) -> np.ndarray:
        return self.table_[:, batch.types]


class DistanceCost:
    """Planned path length (m) from each robot's current position to each task, around obstacles."""

    name = "distance"

    def __init__(self, scenario: Scenario, planner) -> None:
        self.capable_ = scenario.capability_matrix()
        self.planner = planner

    def costs(self, state: WorldState, batch: Batch) -> np.ndarray:
        if state.positions is None:
            raise ValueError(
                "the distance cost model needs a spatial world (scenario has no [spatial])"
            )
        dist = self.planner.distances(state.positions, batch.sites)
        return np.where(self.capable_[:, batch.types], dist, np.inf)


class StraightLineCost:
    """Straight-line distance (m) from each robot to each task: the baseline that planned
    distances never go below (``mrta bench`` compares their cost per round); not a mission
    cost model, so not in ``COST_MODELS``."""

    name = "straight"

    def __init__(self, scenario: Scenario) -> None:
        self.capable_ = scenario.capability_matrix()

    def costs(self, state: WorldState, batch: Batch) -> np.ndarray:
        if state.positions is None:
            raise ValueError("straight-line costs need a spatial world (scenario has no [spatial])")
        z = state.positions @ np.array([1.0, 1j])
        dist = np.abs(z[:, None] - batch.sites @ np.array([1.0, 1j]))
        return np.where(self.capable_[:, batch.types], dist, np.inf)


class TimeCost(DistanceCost):
    """Estimated time to finish (s): path length / top speed + execution time."""

    name = "time"

    def __init__(self, scenario: Scenario, planner) -> None:
        super().__init__(scenario, planner)
        self.exec_time_s_ = np.asarray(scenario.exec_time_s, dtype=float)
        self.speed_mps_ = scenario.spatial.drive.max_speed_mps if scenario.spatial else 1.0

    def costs(self, state: WorldState, batch: Batch) -> np.ndarray:
        travel = super().costs(state, batch) / self.speed_mps_
        return travel + self.exec_time_s_[batch.types][None, :]


COST_MODELS = {"abstract": AbstractCost, "distance": DistanceCost, "time": TimeCost}


def make_cost_model(name: str, scenario: Scenario, planner=None) -> CostModel:
    """Build a cost model by name; spatial ones need the world's planner."""
    if name not in COST_MODELS:
        raise ValueError(f"unknown cost model {name!r}; choose one of {', '.join(COST_MODELS)}")
    if name == "abstract":
        return AbstractCost(scenario)
    if planner is None:
        raise ValueError(
            f"cost model {name!r} needs a spatial scenario (one with a [spatial] table)"
        )
    return COST_MODELS[name](scenario, planner)
