"""Cost models and auctions: read world snapshots, return assignments (no pymunk, no matplotlib)."""

from allocation.auction import MarketAllocator, solve_priority_assignment
from allocation.costs import COST_MODELS, CostModel, make_cost_model

__all__ = [
    "COST_MODELS",
    "CostModel",
    "MarketAllocator",
    "make_cost_model",
    "solve_priority_assignment",
]
