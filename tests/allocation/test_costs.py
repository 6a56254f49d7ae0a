"""Cost models (SPEC §5) through their public interface, with a hand-built planner.

The planner stands in for the world's: it returns fixed path lengths, so these tests pin what
the cost models do with them (time = path length / top speed + execution time), whatever way
the real planner computes the lengths.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from allocation.costs import COST_MODELS, make_cost_model
from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.tasks import Batch
from sim.world import WorldState

INF = float("inf")
PATH_M = np.array([[4.0, 6.0, 1.0], [8.0, 10.0, 3.0]])  # robot x task, m


class FixedPlanner:
    """Returns ``PATH_M`` and checks it was asked about the robots and the batch's sites."""

    def __init__(self, positions: np.ndarray, sites: np.ndarray) -> None:
        self.positions, self.sites = positions, sites

    def distances(self, positions: np.ndarray, sites: np.ndarray) -> np.ndarray:
        np.testing.assert_array_equal(positions, self.positions)
        np.testing.assert_array_equal(sites, self.sites)
        return PATH_M.copy()


# top speed 25 rad/s * 0.08 m = 2 m/s
DRIVE = DriveSpec(max_wheel_speed_radps=25.0, wheel_radius_m=0.08)
SPATIAL = SpatialSpec(10.0, 10.0, (), (((5.0, 5.0),), ((6.0, 6.0),)), DRIVE)
ABSTRACT = Scenario(
    name="duo",
    task_types=("A", "B"),
    robots=(RobotSpec("R0", (0,)), RobotSpec("R1", (0, 1))),
    cost=((7.0, INF), (5.0, 9.0)),
    exec_time_s=(30.0, 12.0),
)
SPATIAL_SCENARIO = dataclasses.replace(
    ABSTRACT,
    robots=(RobotSpec("R0", (0,), (1.0, 1.0)), RobotSpec("R1", (0, 1), (2.0, 2.0))),
    spatial=SPATIAL,
)
POSITIONS = np.array([[1.0, 1.0], [2.0, 2.0]])
SITES = np.array([[5.0, 5.0], [6.0, 6.0], [5.0, 5.0]])
BATCH = Batch(0, 0, np.arange(3), np.array([0, 1, 0]), np.zeros(3, dtype=bool), SITES)
STATE = WorldState(0.0, np.ones(2, dtype=bool), np.zeros(2), POSITIONS)


def costs(name: str, scenario: Scenario) -> np.ndarray:
    model = make_cost_model(name, scenario, FixedPlanner(POSITIONS, SITES))
    assert model.name == name
    return model.costs(STATE, BATCH)


def test_time_cost_is_path_over_top_speed_plus_execution_time():
    # R0 cannot do B; A takes 30 s, B 12 s; 2 m/s
    expected = [[4 / 2 + 30, INF, 1 / 2 + 30], [8 / 2 + 30, 10 / 2 + 12, 3 / 2 + 30]]
    np.testing.assert_array_equal(costs("time", SPATIAL_SCENARIO), expected)


def test_time_cost_without_a_drive_assumes_one_metre_per_second():
    expected = [[4 + 30, INF, 1 + 30], [8 + 30, 10 + 12, 3 + 30]]
    np.testing.assert_array_equal(costs("time", ABSTRACT), expected)


def test_distance_cost_is_the_path_length_where_capable():
    np.testing.assert_array_equal(costs("distance", SPATIAL_SCENARIO), [[4, INF, 1], [8, 10, 3]])


def test_abstract_cost_is_the_table_whatever_the_positions():
    model = make_cost_model("abstract", SPATIAL_SCENARIO)
    np.testing.assert_array_equal(model.costs(STATE, BATCH), [[7, INF, 7], [5, 9, 5]])


@pytest.mark.parametrize("name", ["distance", "time"])
def test_spatial_cost_models_need_positions_and_a_planner(name):
    with pytest.raises(ValueError) as info:
        make_cost_model(name, SPATIAL_SCENARIO)
    assert (
        str(info.value)
        == f"cost model '{name}' needs a spatial scenario (one with a [spatial] table)"
    )
    model = make_cost_model(name, SPATIAL_SCENARIO, FixedPlanner(POSITIONS, SITES))
    abstract_state = WorldState(0.0, np.ones(2, dtype=bool), np.zeros(2))
    with pytest.raises(ValueError) as info:
        model.costs(abstract_state, BATCH)
    assert str(info.value) == (
        "the distance cost model needs a spatial world (scenario has no [spatial])"
    )


def test_unknown_cost_model_names_the_choices():
    with pytest.raises(ValueError) as info:
        make_cost_model("tiem", ABSTRACT)
    assert str(info.value) == "unknown cost model 'tiem'; choose one of abstract, distance, time"
    assert list(COST_MODELS) == ["abstract", "distance", "time"]
