"""The world interface and the abstract (non-spatial) world.

A world is the only owner of physical state. The experiment loop asks it for a
``snapshot()``, hands the auction's result to ``apply()``, and lets time pass with
``advance()``. The abstract world has no positions: a robot is busy for its task's
execution time and then free again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from sim.scenario import Scenario
from sim.tasks import Batch


@dataclass(frozen=True, slots=True)
class WorldState:
    """What allocators may read about the world at one instant."""

    time_s: float
    free: np.ndarray  # (m,) bool: robot has no task
    busy_until_s: np.ndarray  # (m,) float: estimated end of the current task (time_s if free)
    positions: np.ndarray | None = None  # (m, 2) m; None in the abstract world


@dataclass(frozen=True, slots=True)
class Completion:
    """The fate of one allocated task."""

    task_id: int
    robot: int
    t_alloc_s: float
    t_done_s: float
    bid: float  # cost estimate the robot bid with (before ExpT scaling)
    distance_m: float = 0.0  # driven
    ok: bool = True
    reason: str = ""


class World(Protocol):
    """Interface every world implements (abstract and pymunk)."""

    scenario: Scenario

    def reset(self, rng: np.random.Generator) -> None:
        """Put robots at their start and free them."""

    def snapshot(self) -> WorldState:
        """The current state, as a value allocators cannot change."""

    def apply(self, batch: Batch, assignment: np.ndarray, bids: np.ndarray) -> None:
        """Start the allocated tasks: ``assignment[t]`` is the robot for task t, or -1."""

    def advance(self, duration_s: float) -> list[Completion]:
        """Let ``duration_s`` seconds pass; return the tasks that ended meanwhile."""

    def drain(self) -> list[Completion]:
        """Finish every task in progress (end of a task set); robots stay where they are."""


class AbstractWorld:
    """Time-only world: robot j doing a T_i task is busy for ``exec_time_s[i]`` seconds."""

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.exec_time_s_ = np.asarray(scenario.exec_time_s, dtype=float)
        self.reset(np.random.default_rng(0))

    def reset(self, rng: np.random.Generator) -> None:
        m = self.scenario.n_robots
        self.time_s_ = 0.0
        self.busy_until_s_ = np.zeros(m)
        self.jobs_: dict[int, tuple[int, float, float]] = {}  # robot -> (task, t_alloc, bid)

    def snapshot(self) -> WorldState:
        busy_until = np.maximum(self.busy_until_s_, self.time_s_)
        return WorldState(self.time_s_, self.busy_until_s_ <= self.time_s_, busy_until)

    def apply(self, batch: Batch, assignment: np.ndarray, bids: np.ndarray) -> None:
        for t in np.flatnonzero(assignment >= 0):
            j = int(assignment[t])
            if j in self.jobs_:
                raise RuntimeError(f"invariant violated: robot {j} given a task while busy")
            self.busy_until_s_[j] = self.time_s_ + self.exec_time_s_[batch.types[t]]
            self.jobs_[j] = (int(batch.ids[t]), self.time_s_, float(bids[t]))

    def advance(self, duration_s: float) -> list[Completion]:
        self.time_s_ += duration_s
        return self._collect(lambda j: self.busy_until_s_[j] <= self.time_s_)

    def drain(self) -> list[Completion]:
        self.time_s_ = max(self.time_s_, float(self.busy_until_s_.max(initial=0.0)))
        return self._collect(lambda j: True)

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Clock and busy times, for checkpoints taken between sets (no task in progress)."""
        if self.jobs_:
            raise RuntimeError("checkpoint requested while tasks are in progress")
        return {"time_s": np.array(self.time_s_), "busy_until_s": self.busy_until_s_.copy()}

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        self.time_s_ = float(arrays["time_s"])
        self.busy_until_s_ = arrays["busy_until_s"].astype(float).copy()
        self.jobs_ = {}

    def _collect(self, done) -> list[Completion]:
        out = []
        for j in sorted(self.jobs_):
            if done(j):
                task, t_alloc, bid = self.jobs_.pop(j)
                out.append(Completion(task, j, t_alloc, float(self.busy_until_s_[j]), bid))
        return out
