"""Tabular Q-learning, the experience model, the QL-MRTA and ExpT-MRTA allocators, the loop
and the Gymnasium environment.

``BUILTIN_ALLOCATORS`` maps a built-in name to its class;
:func:`learning.registry.allocator_class` also finds allocators other packages register
(entry-point group ``expt_mrta.allocators``) and ``module:Class`` names (docs/allocators.md).

Importing this package registers the Gymnasium id ``mrta/Allocation-v0`` (its entry point, in
the composing ``scenarios`` layer, loads the scenario file by name).
"""

import gymnasium

from allocation.auction import MarketAllocator
from allocation.cbba import CBBAAllocator
from allocation.greedy import GreedyAllocator
from learning.exptmrta import ExpTAllocator
from learning.qlmrta import QLAllocator
from learning.registry import BUILTIN_ALLOCATORS, PAPER_ALLOCATORS, allocator_class

ALLOCATORS = BUILTIN_ALLOCATORS  # the name this table had before the baselines came

ENV_ID = "mrta/Allocation-v0"
if ENV_ID not in gymnasium.registry:
    gymnasium.register(id=ENV_ID, entry_point="scenarios.envs:make_allocation_env")

__all__ = [
    "ALLOCATORS",
    "BUILTIN_ALLOCATORS",
    "ENV_ID",
    "PAPER_ALLOCATORS",
    "CBBAAllocator",
    "ExpTAllocator",
    "GreedyAllocator",
    "MarketAllocator",
    "QLAllocator",
    "allocator_class",
]
