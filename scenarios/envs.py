"""Gymnasium entry points: compose a scenario file with the environments of ``learning``."""

from __future__ import annotations

from learning.gym_env import AllocationEnv
from scenarios.experiments.protocol import check_cost
from scenarios.loader import load_scenario
from sim.scenario import Scenario
from sim.scenario.overrides import apply_overrides


def make_allocation_env(
    scenario: str | Scenario = "paper",
    cost: str = "abstract",
    sets: str = "all",
    render_mode: str | None = None,
    overrides: tuple[tuple[str, object], ...] = (),
) -> AllocationEnv:
    """``gymnasium.make("mrta/Allocation-v0", scenario="paper")`` lands here.

    ``overrides``: settings to change, ``(("stream.n_sets", 3), ...)``, checked as a scenario
    file's are (:func:`sim.scenario.overrides.apply_overrides`).
    """
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    sc = apply_overrides(sc, overrides)
    check_cost(sc, cost)
    return AllocationEnv(sc, cost=cost, sets=sets, render_mode=render_mode)


def make_parallel_env(
    scenario: str | Scenario = "paper",
    cost: str = "abstract",
    sets: str = "all",
    render_mode: str | None = None,
    overrides: tuple[tuple[str, object], ...] = (),
):
    """The PettingZoo ``ParallelEnv`` of a scenario (needs ``pip install 'expt-mrta[marl]'``).

    Args:
        scenario: a bundled scenario name, a TOML path or a Scenario.
        cost: cost model the robots bid with (abstract, distance, time).
        sets: which sets an episode plays: all, learn, test, or protocol (learn then test).
        render_mode: None or "rgb_array".
        overrides: settings to change, ``(("stream.n_sets", 3), ...)``, checked as a scenario
            file's are.

    Returns:
        A :class:`learning.pz_env.AllocationParallelEnv`.
    """
    from learning.pz_env import AllocationParallelEnv

    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    sc = apply_overrides(sc, overrides)
    check_cost(sc, cost)
    return AllocationParallelEnv(sc, cost=cost, sets=sets, render_mode=render_mode)
