"""The allocator interface every allocator implements, and a base class with its defaults.

An allocator sees one announcement round at a time: the world snapshot (which robots are free,
where they are), the batch of announced tasks (types, priorities, sites) and the cost matrix
the scenario's cost model computed for it. It returns, for every task, the robot that takes it
(or -1) and the bid matrix the auction saw. The experiment loop checks every round that a robot
gets at most one task, only while free, only a type it can do and is allowed to do, and only a
task it bid for (a finite bid).

Learning allocators (``learns = True``) are told when a task set begins and ends and whether it
is a learning set; everything they learn is theirs to keep. Checkpoints: an allocator that
defines ``checkpoint_state() -> (arrays, meta)`` and ``restore_checkpoint(arrays, meta)``
(plain numpy arrays and JSON-able metadata, no pickle) can be checkpointed with
``mrta run --checkpoint``; the built-in QL-MRTA and ExpT-MRTA are handled by
``learning.checkpoint``.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from sim.scenario import Scenario
from sim.tasks import Batch
from sim.world import WorldState


@runtime_checkable
class Allocator(Protocol):
    """What the experiment loop, the sweeps and the CLI need from an allocator."""

    name: str
    learns: bool

    def reset(self, rng: np.random.Generator) -> None:
        """Forget everything learned; ``rng`` is the allocator's own seeded generator."""

    def begin_set(self, set_index: int, learning: bool) -> None:
        """A task set starts; ``learning`` is False on the test sets (act greedily, frozen)."""

    def allocate(
        self, state: WorldState, batch: Batch, costs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """One round: (robot per task or -1, (m, k) bids with inf for no bid)."""

    def end_set(self) -> None:
        """The task set ended (every task in progress is done)."""

    def willing(self) -> np.ndarray:
        """(m, n) bool: the types each robot bids for."""

    def allowed(self) -> np.ndarray:
        """(m, n) bool: the types each robot may be given (the loop checks it every round)."""

    def learning_space(self) -> np.ndarray:
        """(m,) int: each robot's learning-space size (0 for allocators that do not learn)."""

    def experience_snapshot(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(TEM, behaviour) arrays for experience-based allocators, else None."""


class BaseAllocator:
    """Defaults for an allocator that learns nothing: subclass it and write ``allocate``.

    Every capable robot is willing and allowed, the learning space is zero, and the set
    hooks do nothing. ``self.scenario``, ``self.capable`` ((m, n) bool) and ``self.rng_`` are
    set for the subclass.
    """

    name = "base"
    learns = False

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.capable = scenario.capability_matrix()
        self.rng_ = np.random.default_rng(0)

    def reset(self, rng: np.random.Generator) -> None:
        self.rng_ = rng

    def begin_set(self, set_index: int, learning: bool) -> None:
        """No per-set state."""

    def end_set(self) -> None:
        """No per-set state."""

    def allocate(
        self, state: WorldState, batch: Batch, costs: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError(f"{type(self).__name__} must define allocate()")

    def willing(self) -> np.ndarray:
        return self.capable

    def allowed(self) -> np.ndarray:
        return self.willing()

    def learning_space(self) -> np.ndarray:
        return np.zeros(self.scenario.n_robots, dtype=np.int64)

    def experience_snapshot(self) -> None:
        return None

    def task_abandoned(self, robot: int, task_type: int) -> None:
        """Robot ``robot`` broke down and gave up its ``task_type`` task (``sim.faults``): the
        loop calls this, if the allocator has it, after the round in which it happened. The
        task itself is re-announced or lost by the loop; nothing to do by default."""

    def bids(self, state: WorldState, costs: np.ndarray) -> np.ndarray:
        """The market's bids: every free robot bids its cost (inf where it cannot)."""
        return np.where(state.free[:, None], costs, np.inf)
