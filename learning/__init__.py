"""Tabular Q-learning, the experience model, the QL-MRTA and ExpT-MRTA allocators, the loop
and the Gymnasium environment.

The registry maps a name to an allocator class: a new allocator is one class and one line
here. Importing this package registers the Gymnasium id ``mrta/Allocation-v0`` (its entry
point, in the composing ``scenarios`` layer, loads the scenario file by name).
"""

import gymnasium

from allocation.auction import MarketAllocator
from learning.exptmrta import ExpTAllocator
from learning.qlmrta import QLAllocator

ALLOCATORS = {"market": MarketAllocator, "ql": QLAllocator, "expt": ExpTAllocator}

ENV_ID = "mrta/Allocation-v0"
if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="scenarios.envs:make_allocation_env")

__all__ = ["ALLOCATORS", "ENV_ID", "ExpTAllocator", "MarketAllocator", "QLAllocator"]
