"""The world: scenario types, task streams, abstract and pymunk worlds, recording, rendering.

Knows nothing of auctions or learning.
"""


def make_world(scenario):
    """The abstract world, or the pymunk world for scenarios with a [spatial] table."""
    if scenario.spatial is None:
        from sim.world import AbstractWorld

        return AbstractWorld(scenario)
    from sim.physics import PymunkWorld

    return PymunkWorld(scenario)
