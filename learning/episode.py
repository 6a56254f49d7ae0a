"""The experiment loop: world -> snapshot -> cost model -> allocator -> world, round by round.

Every round is played by :func:`learning.rounds.play_round`; here ``decide`` is the allocator,
with the round's invariants checked and its lost tasks counted by cause.

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
from learning.fates import ABANDON_ENDS, FATES, FateError, FateLedger
from learning.rounds import Decide, drain, play_round
from sim.scenario import Scenario
from sim.tasks import Batch, TaskStream
from sim.world import Abandon, Completion, World, WorldState


class AllocatorFailure(RuntimeError):
    """An allocator's ``allocate`` raised or answered something that is not an allocation.

    ``str(err)`` is one line naming the allocator (class and module), the phase, set and round,
    and the problem; the original exception, if any, is ``err.__cause__``.
    """

    @classmethod
    def at(cls, allocator, where: dict, problem: str) -> AllocatorFailure:
        """The failure of ``allocator`` in the round ``where`` (phase, set, round)."""
        kind = type(allocator)
        place = f"{where.get('phase', '?')} phase, set {where.get('set', '?')}, "
        place += f"round {where.get('round', '?')}"
        return cls(f"allocator {kind.__name__} ({kind.__module__}), {place}: {problem}")


def _well_formed(answer, allocator, where: dict, m: int, k: int):
    """``(assignment, bids)`` from an allocator's answer, or AllocatorFailure saying what is
    wrong: not a pair, an assignment that is not k integers in -1..m-1, bids that are not
    (m, k) numbers (NaN is not a bid; inf is no bid)."""

    def bad(problem: str):
        return AllocatorFailure.at(allocator, where, problem)

    if not isinstance(answer, tuple | list) or len(answer) != 2:
        raise bad(f"allocate must return (assignment, bids), got {type(answer).__name__}")
    assignment, bids = answer
    try:
        assignment = np.asarray(assignment)
        bids = np.asarray(bids, dtype=float)
    except (TypeError, ValueError) as exc:
        raise bad(f"allocate returned arrays numpy cannot read ({exc})") from None
    if assignment.shape != (k,) or not np.issubdtype(assignment.dtype, np.integer):
        raise bad(
            f"the assignment must be {k} integers (one robot per task, -1: lost), "
            f"got shape {assignment.shape} of {assignment.dtype}"
        )
    out = assignment[(assignment < -1) | (assignment >= m)]
    if out.size:
        raise bad(f"the assignment names robot {int(out[0])}, outside -1..{m - 1}")
    if bids.shape != (m, k):
        raise bad(f"the bids must be a ({m}, {k}) array, got {bids.shape}")
    if np.isnan(bids).any():
        raise bad("the bids hold NaN (use inf for no bid)")
    return assignment.astype(np.int64, copy=False), bids


class InvariantError(RuntimeError):
    """A run broke one of the invariants every run must keep."""


FATE_COLUMNS = ("task_id", "fate", "abandons", "announced_s")


LOSS_CAUSES = ("no_capable_free", "capable_taken", "refused", "waited")
"""Why a task was lost, checked in this order when it was announced:

- ``no_capable_free``: no robot that can do the type was free;
- ``capable_taken``: every free capable robot was given another task of the same round;
- ``refused``: every free capable robot left over had refused the type;
- ``waited``: a free, willing, capable robot was left over but did not bid (QL-MRTA's wait).

A broken robot (``sim.faults``) is not free: a task only broken robots could do is lost as
``no_capable_free``. A re-announced task (its robot broke) that nobody takes is counted here once,
in the round it was lost; tasks dropped under the ``drop`` policy, or still waiting to be
re-announced when the set ended, were not lost at an announcement and are counted in
``PhaseRecord.abandon_ends`` instead (``learning.fates``).
"""


def loss_causes(
    lost_types: np.ndarray,
    free: np.ndarray,
    taken: np.ndarray,
    capable: np.ndarray,
    willing: np.ndarray,
) -> np.ndarray:
    """Counts of :data:`LOSS_CAUSES` over lost tasks of the given types (one round).

    Args:
        lost_types: (l,) type of every task of the round that nobody took.
        free: (m,) robots free when the round was announced.
        taken: (m,) robots given a task in this round.
        capable: (m, n) what each robot can do; ``willing``: what it had not refused.
    """
    can = capable[:, lost_types] & free[:, None]
    left = can & ~taken[:, None]
    will = left & willing[:, lost_types]
    none_free = ~can.any(axis=0)
    all_taken = ~none_free & ~left.any(axis=0)
    refused = ~none_free & ~all_taken & ~will.any(axis=0)
    waited = will.any(axis=0)
    return np.array([none_free.sum(), all_taken.sum(), refused.sum(), waited.sum()], np.int64)


@dataclass
class PhaseRecord:
    """What happened to the tasks of one phase (learning or test)."""

    task_ids: list[np.ndarray] = field(default_factory=list)
    assigned: list[np.ndarray] = field(default_factory=list)  # robot per task, -1 = lost
    bids: list[np.ndarray] = field(default_factory=list)  # winning bid per task (NaN if lost)
    completions: list[Completion] = field(default_factory=list)
    announced: int = 0  # counted, not kept, when run_protocol(keep=False)
    allocated: int = 0
    failed: int = 0
    lost_causes: np.ndarray = field(
        default_factory=lambda: np.zeros(len(LOSS_CAUSES), dtype=np.int64)
    )  # tasks lost, per LOSS_CAUSES
    fates: np.ndarray = field(
        default_factory=lambda: np.zeros(len(FATES), dtype=np.int64)
    )  # tasks per final fate (learning.fates.FATES), always counted
    abandon_ends: np.ndarray = field(
        default_factory=lambda: np.zeros(len(ABANDON_ENDS), dtype=np.int64)
    )  # abandonments re-announced, dropped, lost at the set's end
    abandons: list[Abandon] = field(default_factory=list)  # kept when keep=True
    fate_rows: list[tuple[int, str, int, float]] = field(default_factory=list)  # FATE_COLUMNS

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
    availability: np.ndarray | None = None  # (m,) share of the run each robot was not broken
    failures: np.ndarray | None = None  # (m,) breakdowns per robot (None: no faults)


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
    on_set_end: Callable[[int, int, RunRecord], None] | None = None,
    resume: tuple[int, int, RunRecord] | None = None,
    recorder=None,
    keep: bool = True,
) -> RunRecord:
    """Play the stream's sets through ``world`` with ``allocator`` and record what happened.

    Args:
        on_set_end: called as ``on_set_end(phase_index, next_set_position, record)`` after every
            set (checkpoints hook in here).
        resume: ``(phase_index, set_position, record)`` to continue a run whose allocator and
            world state were restored from a checkpoint written at that position.
        recorder: a ``sim.recording.TrajectoryRecorder`` told of announcements, allocations
            and completions (the world feeds it poses).
        keep: keep every task's fate in the record; False keeps only counts (long soaks run in
            constant memory; invariants are still checked set by set).
    """
    if phases is None:
        learn_sets, test_sets = protocol_sets(scenario)
        phases = (("learn", learn_sets), ("test", test_sets))
    if resume is None:
        world.reset(rng)
        record = RunRecord(
            PhaseRecord(),
            PhaseRecord(),
            allocator.learning_space().copy(),
            allocator.learning_space().copy(),
            allocator.willing().copy(),
        )
        start_phase, start_pos = 0, 0
    else:
        start_phase, start_pos, record = resume
    interval = scenario.stream.announce_interval_s
    capable = scenario.capability_matrix()
    policy = scenario.faults.policy
    abandoned_hook = getattr(allocator, "task_abandoned", None)
    rounds = len(record.trace_time)
    for pi, (phase_name, set_indices) in enumerate(phases):
        if pi < start_phase:
            continue
        phase = record.learn if phase_name == "learn" else record.test
        where = {"phase": phase_name}  # named in an allocator's failure
        decide = _checked(allocator, capable, phase.lost_causes, where)
        for pos, s in enumerate(set_indices):
            if pi == start_phase and pos < start_pos:
                continue
            allocator.begin_set(s, learning=phase_name == "learn")
            where.update(set=s, round=0)
            ids, assigned, bids, done = [], [], [], []
            ledger = FateLedger(policy, f"{phase_name} phase, set {s}")
            for batch in stream.batches(s):
                where["round"] = int(batch.round_index)
                batch = ledger.with_requeued(batch)
                played = play_round(world, batch, cost_model, decide, interval, recorder)
                _ledger_round(ledger, played, scenario, abandoned_hook)
                ids.append(batch.ids)
                assigned.append(played.assignment)
                bids.append(played.won_bid)
                done.extend(played.done)
                rounds += 1
                if trace:
                    _trace(record, allocator, rounds)
                if on_round is not None:
                    on_round()
            drained = drain(world, recorder)
            _ledger_events(ledger, drained, world.take_abandoned(), scenario, abandoned_hook)
            done.extend(drained)
            allocator.end_set()
            _check_set(phase_name, s, ids, assigned, done, allocator, scenario, ledger)
            try:
                counts = ledger.close()
            except FateError as err:
                raise InvariantError(str(err)) from None
            phase.fates += np.array([counts[f] for f in FATES], dtype=np.int64)
            phase.abandon_ends += np.array([ledger.ends[e] for e in ABANDON_ENDS], np.int64)
            if keep:
                phase.task_ids += ids
                phase.assigned += assigned
                phase.bids += bids
                phase.completions += done
                phase.abandons += ledger.abandons
                phase.fate_rows += [
                    (tid, info.fate, info.abandons, info.announced_s)
                    for tid, info in ledger.tasks.items()
                ]
            else:
                phase.announced += sum(a.size for a in assigned)
                phase.allocated += sum(int((a >= 0).sum()) for a in assigned)
                phase.failed += sum(not c.ok for c in done)
            if on_set_end is not None:
                on_set_end(pi, pos + 1, record)
    record.space_final = allocator.learning_space().copy()
    record.willing_final = allocator.willing().copy()
    faults = world.faults
    if faults is not None:
        record.availability = faults.availability(float(world.snapshot().time_s))
        record.failures = faults.failures.copy()
    return record


def _ledger_round(ledger: FateLedger, played, scenario: Scenario, hook) -> None:
    """Tell the set's ledger what one round announced, allocated, completed and abandoned."""
    try:
        ledger.announce(played.batch, played.state.time_s)
        ledger.allocate(played.batch.ids, played.assignment)
    except FateError as err:
        raise InvariantError(str(err)) from None
    _ledger_events(ledger, played.done, played.abandoned, scenario, hook)


def _ledger_events(ledger: FateLedger, done, abandoned, scenario: Scenario, hook) -> None:
    """Completions and abandonments into the ledger; the allocator hears of each abandonment
    (``task_abandoned(robot, task_type)``, if it has that hook)."""
    try:
        for c in done:
            ledger.complete(c)
        for a in abandoned:
            ledger.abandon(a)
            if hook is not None:
                hook(a.robot, ledger.tasks[a.task_id].type)
    except FateError as err:
        raise InvariantError(str(err)) from None


def _checked(allocator, capable: np.ndarray, lost_causes: np.ndarray, where: dict) -> Decide:
    """The allocator's decision with the round's invariants checked and its losses counted
    (into ``lost_causes``, in place). The call into the allocator is a boundary: an exception
    or a malformed answer becomes an :class:`AllocatorFailure` naming the allocator and the
    round (``where``: phase, set and round, kept up to date by the caller)."""

    def decide(state: WorldState, batch: Batch, costs: np.ndarray):
        allowed = allocator.allowed().copy()
        willing = allocator.willing().copy()
        try:
            answer = allocator.allocate(state, batch, costs)
        except Exception as exc:
            raise AllocatorFailure.at(
                allocator, where, f"raised {type(exc).__name__}: {exc}"
            ) from exc
        assignment, bids = _well_formed(answer, allocator, where, state.free.size, len(batch))
        _check_assignment(assignment, bids, batch, state.free, allowed, capable, state.broken)
        won = assignment >= 0
        if not won.all():
            taken = np.zeros(state.free.size, dtype=bool)
            taken[assignment[won]] = True
            lost_causes[:] += loss_causes(batch.types[~won], state.free, taken, capable, willing)
        return assignment, bids

    return decide


def _trace(record: RunRecord, allocator, rounds: int) -> None:
    record.trace_time.append(rounds)
    record.trace_space.append(allocator.learning_space().copy())
    snap = allocator.experience_snapshot()
    if snap is not None:
        record.trace_u.append(snap[0].copy())
        record.trace_behaviour.append(snap[1])


def _check_assignment(assignment, bids, batch, free, allowed, capable, broken=None) -> None:
    robots = assignment[assignment >= 0]
    if not np.isfinite(bids[robots, np.flatnonzero(assignment >= 0)]).all():
        raise InvariantError("a robot was given a task it did not bid for")
    if np.unique(robots).size != robots.size:
        raise InvariantError("a robot was given more than one task in a round")
    if broken is not None and broken[robots].any():
        bad = int(robots[broken[robots]][0])
        raise InvariantError(f"broken robot {bad} was given a task")
    if not free[robots].all():
        raise InvariantError("a busy robot was given a task")
    types = batch.types[assignment >= 0]
    if not capable[robots, types].all():
        raise InvariantError("a robot was given a task type it cannot do")
    if not allowed[robots, types].all():
        raise InvariantError("a robot was given a task type it has refused")


def _check_set(name: str, s: int, ids, assigned, done, allocator, scenario, ledger=None) -> None:
    """Per-set invariants: each announced task allocated or lost once; every allocated task
    completed or failed with a reason; learning spaces equal 2 * n**h of the task sets.

    With abandoned tasks (robot faults) a task may be announced and allocated more than once:
    the two first checks are the ledger's then (``learning.fates``, at ``ledger.close()``)."""
    all_ids = np.concatenate(ids) if ids else np.zeros(0, dtype=int)
    taken = np.concatenate(assigned) >= 0 if assigned else np.zeros(0, dtype=bool)
    if ledger is None or not ledger.abandons:
        if np.unique(all_ids).size != all_ids.size:
            raise InvariantError(f"{name} phase, set {s}: a task was announced twice")
        finished = sorted(c.task_id for c in done)
        if finished != sorted(all_ids[taken].tolist()):
            raise InvariantError(
                f"{name} phase, set {s}: allocated tasks and completed or failed tasks differ"
            )
    if any(not c.ok and not c.reason for c in done):
        raise InvariantError(f"{name} phase, set {s}: a task failed without a reason")
    if allocator.learns:
        h = scenario.learning.history
        space = np.array([2 * int(row.sum()) ** h for row in allocator.willing()])
        if not np.array_equal(space, allocator.learning_space()):
            raise InvariantError(
                "learning-space sizes differ from 2 * n**h of the robots' task sets"
            )


COMPLETION_COLUMNS = (
    "task_id",
    "robot",
    "t_alloc_s",
    "t_done_s",
    "bid",
    "distance_m",
    "ok",
    "reason",
)


def record_arrays(record: RunRecord) -> dict[str, np.ndarray]:
    """A run record as flat arrays (for checkpoints): ``rec/<phase>/<column>`` and traces."""
    out: dict[str, np.ndarray] = {}
    for name in ("learn", "test"):
        phase: PhaseRecord = getattr(record, name)
        lengths = np.array([a.size for a in phase.task_ids], dtype=np.int64)
        ids, assigned = phase.arrays()
        out[f"rec/{name}/lengths"] = lengths
        out[f"rec/{name}/ids"] = ids
        out[f"rec/{name}/assigned"] = assigned
        out[f"rec/{name}/bids"] = np.concatenate(phase.bids) if phase.bids else np.zeros(0)
        out[f"rec/{name}/lost_causes"] = phase.lost_causes
        out[f"rec/{name}/fates"] = phase.fates
        out[f"rec/{name}/abandon_ends"] = phase.abandon_ends
        for col in ("task_id", "robot", "t_alloc_s", "t_s", "bid"):
            out[f"rec/{name}/a_{col}"] = np.array([getattr(a, col) for a in phase.abandons], float)
        rows = phase.fate_rows
        out[f"rec/{name}/f_task_id"] = np.array([r[0] for r in rows], dtype=np.int64)
        out[f"rec/{name}/f_fate"] = np.array([r[1] for r in rows], dtype=str)
        out[f"rec/{name}/f_abandons"] = np.array([r[2] for r in rows], dtype=np.int64)
        out[f"rec/{name}/f_announced_s"] = np.array([r[3] for r in rows], dtype=float)
        for col in COMPLETION_COLUMNS:
            values = [getattr(c, col) for c in phase.completions]
            out[f"rec/{name}/c_{col}"] = np.array(values, dtype=str if col == "reason" else float)
    out["rec/space_initial"] = record.space_initial
    out["rec/space_final"] = record.space_final
    out["rec/willing_final"] = record.willing_final
    out["rec/trace_time"] = np.array(record.trace_time, dtype=np.int64)
    m = record.space_initial.size
    n = record.willing_final.shape[1]
    out["rec/trace_space"] = np.array(record.trace_space, dtype=np.int64).reshape(-1, m)
    out["rec/trace_u"] = np.array(record.trace_u, dtype=float).reshape(-1, m, n)
    out["rec/trace_behaviour"] = np.array(record.trace_behaviour, dtype=np.int8).reshape(-1, m, n)
    return out


def record_from_arrays(arrays: dict[str, np.ndarray]) -> RunRecord:
    """Inverse of :func:`record_arrays`."""
    phases = []
    for name in ("learn", "test"):
        cut = np.cumsum(arrays[f"rec/{name}/lengths"])[:-1]
        cols = {c: arrays[f"rec/{name}/c_{c}"] for c in COMPLETION_COLUMNS}
        completions = [
            Completion(
                int(cols["task_id"][k]),
                int(cols["robot"][k]),
                float(cols["t_alloc_s"][k]),
                float(cols["t_done_s"][k]),
                float(cols["bid"][k]),
                float(cols["distance_m"][k]),
                bool(cols["ok"][k]),
                str(cols["reason"][k]),
            )
            for k in range(cols["task_id"].size)
        ]
        n_rounds = arrays[f"rec/{name}/lengths"].size

        def split(a, cut=cut, n=n_rounds):
            return np.split(a, cut) if n else []

        phase = PhaseRecord(
            split(arrays[f"rec/{name}/ids"]),
            split(arrays[f"rec/{name}/assigned"]),
            split(arrays[f"rec/{name}/bids"]),
            completions,
        )
        causes = arrays.get(f"rec/{name}/lost_causes")  # absent in older checkpoints
        if causes is not None:
            phase.lost_causes = np.asarray(causes, dtype=np.int64)
        if f"rec/{name}/fates" in arrays:  # absent in checkpoints older than faults
            phase.fates = np.asarray(arrays[f"rec/{name}/fates"], dtype=np.int64)
            phase.abandon_ends = np.asarray(arrays[f"rec/{name}/abandon_ends"], dtype=np.int64)
            a = {
                c: arrays[f"rec/{name}/a_{c}"]
                for c in ("task_id", "robot", "t_alloc_s", "t_s", "bid")
            }
            phase.abandons = [
                Abandon(
                    int(a["task_id"][k]),
                    int(a["robot"][k]),
                    float(a["t_alloc_s"][k]),
                    float(a["t_s"][k]),
                    float(a["bid"][k]),
                )
                for k in range(a["task_id"].size)
            ]
            phase.fate_rows = [
                (int(t), str(f), int(n), float(at))
                for t, f, n, at in zip(
                    arrays[f"rec/{name}/f_task_id"].tolist(),
                    arrays[f"rec/{name}/f_fate"].tolist(),
                    arrays[f"rec/{name}/f_abandons"].tolist(),
                    arrays[f"rec/{name}/f_announced_s"].tolist(),
                    strict=True,
                )
            ]
        phases.append(phase)
    return RunRecord(
        phases[0],
        phases[1],
        arrays["rec/space_initial"],
        arrays["rec/space_final"],
        arrays["rec/willing_final"],
        arrays["rec/trace_time"].tolist(),
        list(arrays["rec/trace_space"]),
        list(arrays["rec/trace_u"]),
        list(arrays["rec/trace_behaviour"]),
    )
