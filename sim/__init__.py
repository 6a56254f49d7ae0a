"""The world: scenario types, task streams, abstract and pymunk worlds, recording, rendering.

Knows nothing of auctions or learning.
"""


def make_world(scenario, control: str = "auto"):
    """The abstract world, or the pymunk world for scenarios with a [spatial] table.

    ``control`` chooses the pymunk world's control period (``"auto"``, ``"array"`` or
    ``"scalar"``: see ``sim.spatial.world.PymunkWorld``); the abstract world has none.
    """
    if scenario.spatial is None:
        from sim.world import AbstractWorld

        return AbstractWorld(scenario)
    from sim.spatial.world import PymunkWorld

    return PymunkWorld(scenario, control=control)
