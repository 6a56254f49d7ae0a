"""Tabular Q-learning, the experience model, the QL-MRTA and ExpT-MRTA allocators, the loop
and the Gymnasium environment. The registry maps a name to an allocator class: a new
allocator is one class and one line here."""

from allocation.auction import MarketAllocator
from learning.exptmrta import ExpTAllocator
from learning.qlmrta import QLAllocator

ALLOCATORS = {"market": MarketAllocator, "ql": QLAllocator, "expt": ExpTAllocator}

__all__ = ["ALLOCATORS", "ExpTAllocator", "MarketAllocator", "QLAllocator"]
