"""A run's parts, built in one place for every door into the allocation loop.

The experiment protocol (``scenarios.experiments.protocol.build_run``, behind ``mrta run`` and
every sweep), the Gymnasium environment and the PettingZoo environment all build their world
and cost model with :func:`build_world` and draw a seed's task stream and generators with
:func:`seeded_stream`, so a seed means the same tasks and the same world through each of them.
"""

from __future__ import annotations

from allocation.costs import CostModel, make_cost_model
from learning.seeding import RunGenerators, run_generators
from sim import make_world
from sim.scenario import Scenario
from sim.tasks import TaskStream, generate_stream
from sim.world import World


def build_world(scenario: Scenario, cost: str) -> tuple[World, CostModel]:
    """The scenario's world (abstract, or pymunk with a ``[spatial]`` table) and the cost
    model its robots bid with (``abstract``, ``distance`` or ``time``: the last two plan on the
    world's own planner)."""
    world = make_world(scenario)
    return world, make_cost_model(cost, scenario, world.planner)


def seeded_stream(scenario: Scenario, seed: int) -> tuple[TaskStream, RunGenerators]:
    """The task stream of ``seed`` and the run's generators (stream, world, allocator), split
    from ``np.random.SeedSequence(seed)`` (:func:`learning.seeding.run_generators`)."""
    rngs = run_generators(seed)
    return generate_stream(scenario, rngs.stream), rngs


__all__ = ["build_world", "seeded_stream"]
