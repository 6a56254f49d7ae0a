"""Gymnasium entry points: compose a scenario file with the environments of ``learning``."""

from __future__ import annotations

from learning.gym_env import AllocationEnv
from scenarios.experiments.protocol import check_cost
from scenarios.loader import load_scenario
from sim.scenario import Scenario


def make_allocation_env(
    scenario: str | Scenario = "paper",
    cost: str = "abstract",
    sets: str = "all",
    render_mode: str | None = None,
) -> AllocationEnv:
    """``gymnasium.make("mrta/Allocation-v0", scenario="paper")`` lands here."""
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    check_cost(sc, cost)
    return AllocationEnv(sc, cost=cost, sets=sets, render_mode=render_mode)


def make_parallel_env(
    scenario: str | Scenario = "paper",
    cost: str = "abstract",
    sets: str = "all",
    render_mode: str | None = None,
):
    """The PettingZoo ``ParallelEnv`` of a scenario (needs ``pip install 'expt-mrta[marl]'``).

    Args:
        scenario: a bundled scenario name, a TOML path or a Scenario.
        cost: cost model the robots bid with (abstract, distance, time).
        sets: which sets an episode plays: all, learn, test, or protocol (learn then test).
        render_mode: None or "rgb_array".

    Returns:
        A :class:`learning.pz_env.AllocationParallelEnv`.
    """
    from learning.pz_env import AllocationParallelEnv

    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    check_cost(sc, cost)
    return AllocationParallelEnv(sc, cost=cost, sets=sets, render_mode=render_mode)
