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

from sim.faults import FaultModel, build_faults, fault_seed_sequence
from sim.scenario import Scenario
from sim.tasks import Batch


@dataclass(frozen=True, slots=True)
class WorldState:
    """What allocators may read about the world at one instant."""

    time_s: float
    free: np.ndarray  # (m,) bool: robot has no task
    busy_until_s: np.ndarray  # (m,) float: estimated end of the current task (time_s if free)
    positions: np.ndarray | None = None  # (m, 2) m; None in the abstract world
    broken: np.ndarray | None = None  # (m,) bool: robot broken (never free); None: none can break

    def available(self) -> np.ndarray:
        """(m,) robots not broken (all of them in a world without faults)."""
        if self.broken is None:
            return np.ones(self.free.size, dtype=bool)
        return ~self.broken


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


@dataclass(frozen=True, slots=True)
class Abandon:
    """A task given up because its robot broke down (``sim.faults``)."""

    task_id: int
    robot: int
    t_alloc_s: float
    t_s: float  # when the robot broke
    bid: float


class World(Protocol):
    """Interface every world implements (abstract and pymunk): the loop, the environments and
    the checkpoints use only this.

    Attributes:
        scenario: the scenario the world was built for.
        faults: its robots' fault model (``sim.faults.FaultModel``), or None when no robot
            can break.
        planner: the arena's planner the distance and time cost models bid with (a
            ``sim.spatial.navigation.planning.GridPlanner``), or None in a world without space.
        recorder: a ``sim.recording.TrajectoryRecorder`` fed poses while the world runs, or
            None (a world without space records no poses).
    """

    scenario: Scenario
    faults: FaultModel | None
    planner: object | None
    recorder: object | None

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

    def take_abandoned(self) -> list[Abandon]:
        """The tasks given up since the last call because their robot broke, in order (always
        empty without faults)."""

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The world's whole state between task sets as named arrays (checkpoints)."""

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Put a state of :meth:`state_arrays` back."""


class AbstractWorld:
    """Time-only world: robot j doing a T_i task is busy for ``exec_time_s[i]`` seconds.

    With a ``[faults]`` table (``sim.faults``) a robot that breaks gives up its task (an
    :class:`Abandon`, collected with :meth:`take_abandoned`) and is neither free nor bid for
    until it is repaired; its estimated end of business is the end of the repair.

    A new world is reset with ``np.random.default_rng(0)``; the experiment loop resets it with
    the run's world generator.
    """

    planner = None  # no space: the abstract cost table alone
    recorder = None  # no poses to record

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.exec_time_s_ = np.asarray(scenario.exec_time_s, dtype=float)
        self.faults = build_faults(scenario)
        self.reset(np.random.default_rng(0))

    def reset(self, rng: np.random.Generator) -> None:
        m = self.scenario.n_robots
        self.time_s_ = 0.0
        self.busy_until_s_ = np.zeros(m)
        self.jobs_: dict[int, tuple[int, float, float]] = {}  # robot -> (task, t_alloc, bid)
        self.abandoned_: list[Abandon] = []
        if self.faults is not None:
            self.faults.reset(np.random.default_rng(fault_seed_sequence(rng)))

    def snapshot(self) -> WorldState:
        busy_until = np.maximum(self.busy_until_s_, self.time_s_)
        free = self.busy_until_s_ <= self.time_s_
        if self.faults is None:
            return WorldState(self.time_s_, free, busy_until)
        broken = self.faults.broken_now()
        repair = self.faults.broken_until_s
        fixing = broken & np.isfinite(repair)
        busy_until[fixing] = np.maximum(busy_until[fixing], repair[fixing])
        return WorldState(self.time_s_, free & ~broken, busy_until, None, broken)

    def take_abandoned(self) -> list[Abandon]:
        """Tasks abandoned since the last call, in the order their robots broke."""
        out, self.abandoned_ = self.abandoned_, []
        return out

    def apply(self, batch: Batch, assignment: np.ndarray, bids: np.ndarray) -> None:
        for t in np.flatnonzero(assignment >= 0):
            j = int(assignment[t])
            if j in self.jobs_:
                raise RuntimeError(f"invariant violated: robot {j} given a task while busy")
            self.busy_until_s_[j] = self.time_s_ + self.exec_time_s_[batch.types[t]]
            self.jobs_[j] = (int(batch.ids[t]), self.time_s_, float(bids[t]))

    def advance(self, duration_s: float) -> list[Completion]:
        if self.faults is not None:
            return self._advance_faults(self.time_s_ + duration_s)
        self.time_s_ += duration_s
        return self._collect(lambda j: self.busy_until_s_[j] <= self.time_s_)

    def drain(self) -> list[Completion]:
        if self.faults is not None:
            if not self.jobs_:
                return []
            # to the last end: a failure on the way abandons its task, the others end in time
            end = max(self.time_s_, max(float(self.busy_until_s_[j]) for j in self.jobs_))
            return self._advance_faults(end)
        self.time_s_ = max(self.time_s_, float(self.busy_until_s_.max(initial=0.0)))
        return self._collect(lambda j: True)

    def _advance_faults(self, end_s: float) -> list[Completion]:
        """Advance to ``end_s`` through every failure and repair on the way, in time order:
        the tasks that end by an event are done before it; a robot that breaks abandons its task."""
        out, faults = [], self.faults
        while True:
            t_next = faults.next_event_s()
            if t_next > end_s:
                break
            self.time_s_ = max(self.time_s_, t_next)
            out += self._collect(lambda j: self.busy_until_s_[j] <= self.time_s_)
            broke, _ = faults.step(t_next)
            for j in broke:
                if j in self.jobs_:
                    task, t_alloc, bid = self.jobs_.pop(j)
                    self.abandoned_.append(Abandon(task, j, t_alloc, self.time_s_, bid))
                    self.busy_until_s_[j] = self.time_s_
        self.time_s_ = max(self.time_s_, end_s)
        out += self._collect(lambda j: self.busy_until_s_[j] <= self.time_s_)
        return out

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Clock and busy times, for checkpoints taken between sets (no task in progress)."""
        if self.jobs_:
            raise RuntimeError("checkpoint requested while tasks are in progress")
        out = {"time_s": np.array(self.time_s_), "busy_until_s": self.busy_until_s_.copy()}
        if self.faults is not None:
            out.update({f"faults/{k}": v for k, v in self.faults.state_arrays().items()})
        return out

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        self.time_s_ = float(arrays["time_s"])
        self.busy_until_s_ = arrays["busy_until_s"].astype(float).copy()
        self.jobs_ = {}
        self.abandoned_ = []
        if self.faults is not None:
            pre = "faults/"
            self.faults.restore_arrays(
                {k[len(pre) :]: v for k, v in arrays.items() if k.startswith(pre)}
            )

    def _collect(self, done) -> list[Completion]:
        out = []
        for j in sorted(self.jobs_):
            if done(j):
                task, t_alloc, bid = self.jobs_.pop(j)
                out.append(Completion(task, j, t_alloc, float(self.busy_until_s_[j]), bid))
        return out
