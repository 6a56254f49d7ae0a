"""The experiment loop: world -> snapshot -> cost model -> allocator -> world, round by round.

The paper protocol (SPEC §1) is two phases over one stream: the learning sets are played with
exploration and learning on, then the test sets are played greedily with everything learned
frozen. Completion ratios are measured on the test phase only. Invariants are checked every
round, always on; a violation stops the run with a message naming it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from allocation.costs import CostModel
from sim.scenario import Scenario
from sim.tasks import TaskStream
from sim.world import Completion, World


class InvariantError(RuntimeError):
    """A run broke one of the invariants every run must keep."""


@dataclass
class PhaseRecord:
    """What happened to the tasks of one phase (learning or test)."""

    task_ids: list[np.ndarray] = field(default_factory=list)
    assigned: list[np.ndarray] = field(default_factory=list)  # robot per task, -1 = lost
    bids: list[np.ndarray] = field(default_factory=list)  # winning bid per task (NaN if lost)
    completions: list[Completion] = field(default_factory=list)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if not self.task_ids:
            return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
        return np.concatenate(self.task_ids), np.concatenate(self.assigned)


@dataclass
class RunRecord:
    """Everything a run reports: per-phase task fates and per-round learning traces."""

    learn: PhaseRecord
    test: PhaseRecord
    space_initial: np.ndarray
    space_final: np.ndarray
    willing_final: np.ndarray  # (m, n) bool
    trace_time: list[int] = field(default_factory=list)  # global round counter
    trace_space: list[np.ndarray] = field(default_factory=list)  # (m,) per round
    trace_u: list[np.ndarray] = field(default_factory=list)  # (m, n) per round (ExpT only)
    trace_behaviour: list[np.ndarray] = field(default_factory=list)


def protocol_sets(scenario: Scenario) -> tuple[list[int], list[int]]:
    """Zero-based (learning, test) set indices: first learn_sets learn, last test_sets test."""
    s = scenario.stream
    return list(range(s.learn_sets)), list(scenario.test_set_indices())


def run_protocol(
    scenario: Scenario,
    stream: TaskStream,
    allocator,
    world: World,
    cost_model: CostModel,
    rng: np.random.Generator,
    *,
    phases: tuple[tuple[str, list[int]], ...] | None = None,
    trace: bool = True,
    on_round: Callable[[], None] | None = None,
) -> RunRecord:
    """Play the stream's sets through ``world`` with ``allocator`` and record what happened."""
    if phases is None:
        learn_sets, test_sets = protocol_sets(scenario)
        phases = (("learn", learn_sets), ("test", test_sets))
    world.reset(rng)
    record = RunRecord(
        PhaseRecord(),
        PhaseRecord(),
        allocator.learning_space().copy(),
        allocator.learning_space().copy(),
        allocator.willing().copy(),
    )
    interval = scenario.stream.announce_interval_s
    capable = scenario.capability_matrix()
    rounds = 0
    for phase_name, set_indices in phases:
        phase = record.learn if phase_name == "learn" else record.test
        for s in set_indices:
            allocator.begin_set(s, learning=phase_name == "learn")
            for batch in stream.batches(s):
                state = world.snapshot()
                willing = allocator.willing().copy()
                costs = cost_model.costs(state, batch)
                assignment, bids = allocator.allocate(state, batch, costs)
                _check_assignment(assignment, bids, batch, state.free, willing, capable)
                won = assignment >= 0
                won_bid = np.full(len(batch), np.nan)
                won_bid[won] = costs[assignment[won], np.flatnonzero(won)]
                world.apply(batch, assignment, won_bid)
                phase.task_ids.append(batch.ids)
                phase.assigned.append(assignment)
                phase.bids.append(won_bid)
                phase.completions.extend(world.advance(interval))
                rounds += 1
                if trace:
                    _trace(record, allocator, rounds)
                if on_round is not None:
                    on_round()
            phase.completions.extend(world.drain())
            allocator.end_set()
        _check_conservation(phase_name, phase)
    record.space_final = allocator.learning_space().copy()
    record.willing_final = allocator.willing().copy()
    space = np.array(
        [2 * int(row.sum()) ** scenario.learning.history for row in record.willing_final]
    )
    if allocator.learns and not np.array_equal(space, record.space_final):
        raise InvariantError("learning-space sizes differ from 2 * n**h of the robots' task sets")
    return record


def _trace(record: RunRecord, allocator, rounds: int) -> None:
    record.trace_time.append(rounds)
    record.trace_space.append(allocator.learning_space().copy())
    snap = allocator.experience_snapshot()
    if snap is not None:
        record.trace_u.append(snap[0].copy())
        record.trace_behaviour.append(snap[1])


def _check_assignment(assignment, bids, batch, free, willing, capable) -> None:
    robots = assignment[assignment >= 0]
    if not np.isfinite(bids[robots, np.flatnonzero(assignment >= 0)]).all():
        raise InvariantError("a robot was given a task it did not bid for")
    if np.unique(robots).size != robots.size:
        raise InvariantError("a robot was given more than one task in a round")
    if not free[robots].all():
        raise InvariantError("a busy robot was given a task")
    types = batch.types[assignment >= 0]
    if not capable[robots, types].all():
        raise InvariantError("a robot was given a task type it cannot do")
    if not willing[robots, types].all():
        raise InvariantError("a robot was given a task type it has refused")


def _check_conservation(name: str, phase: PhaseRecord) -> None:
    ids, assigned = phase.arrays()
    done = sorted(c.task_id for c in phase.completions)
    if done != sorted(ids[assigned >= 0].tolist()):
        raise InvariantError(f"{name} phase: allocated tasks and completed or failed tasks differ")
