"""Task fates with robot faults: every announced task ends exactly once (issue 17, part 2).

A :class:`FateLedger` follows the tasks of one task set from announcement to their end. A task
is announced, then either lost at once (nobody took it) or allocated; an allocated task is
completed (``ok`` or failed with a reason, as before) or abandoned because its robot broke
(``sim.world.Abandon``). An abandoned task is re-announced in the next round of the set with its
id, type, priority and site (policy ``requeue``; its age is counted from its first
announcement), or lost at once (policy ``drop``); one still waiting to be re-announced when the
set ends is lost then. Its final fate is one of :data:`FATES`:

- ``done`` / ``failed``: completed (ok / failed with a reason), never abandoned;
- ``lost``: never allocated;
- ``abandoned_done`` / ``abandoned_failed``: abandoned at least once, then completed;
- ``abandoned_lost``: abandoned, then dropped, not taken when re-announced, or the set ended.

Every event is checked as it comes: a task announced while it is known and not waiting to be
re-announced, a completion or abandonment of a task that is not running, or a task without a
fate when the set ends raises :class:`FateError` naming the task. The ledger is always on (it
costs a few dictionary operations per task).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sim.tasks import Batch
from sim.world import Abandon, Completion

FATES = ("done", "failed", "lost", "abandoned_done", "abandoned_failed", "abandoned_lost")
ABANDON_ENDS = ("requeued", "dropped", "set_end")
"""What became of an abandonment: re-announced, lost at once (``drop``), lost at the set's end."""


class FateError(RuntimeError):
    """A task counted twice or vanished; the message names the task."""


@dataclass
class TaskInfo:
    """What the ledger knows of one task."""

    type: int
    high: bool
    site: tuple[float, float]
    announced_s: float  # first announcement: the age of a re-announced task counts from here
    state: str = "announced"  # announced | running | waiting (to be re-announced) | ended
    abandons: int = 0
    announcements: int = 0
    fate: str = ""


class FateLedger:
    """The fates of the tasks of one set.

    Args:
        policy: ``"requeue"`` or ``"drop"`` (``FaultSpec.policy``).
        label: names the set in error messages.
    """

    def __init__(self, policy: str = "requeue", label: str = "") -> None:
        self.policy = policy
        self.label = label
        self.tasks: dict[int, TaskInfo] = {}
        self.waiting: list[int] = []  # abandoned, to be re-announced, in abandonment order
        self.ends = dict.fromkeys(ABANDON_ENDS, 0)
        self.abandons: list[Abandon] = []

    def _fail(self, task: int, problem: str) -> None:
        raise FateError(f"{self.label}: task {task} {problem}")

    # -- the next round's batch ----------------------------------------------------------------
    def with_requeued(self, batch: Batch) -> Batch:
        """``batch`` with the tasks waiting to be re-announced appended (same id, type, priority
        and site); ``batch`` itself when none waits."""
        if not self.waiting:
            return batch
        info = [self.tasks[t] for t in self.waiting]
        ids = np.concatenate([batch.ids, np.array(self.waiting, dtype=batch.ids.dtype)])
        types = np.concatenate([batch.types, np.array([i.type for i in info], batch.types.dtype)])
        high = np.concatenate([batch.high, np.array([i.high for i in info], dtype=bool)])
        sites = np.concatenate([batch.sites.reshape(-1, 2), np.array([i.site for i in info])])
        return Batch(batch.set_index, batch.round_index, ids, types, high, sites)

    # -- events --------------------------------------------------------------------------------
    def announce(self, batch: Batch, t_s: float) -> None:
        """The tasks of ``batch`` are announced now (new ones and re-announced ones)."""
        sites = batch.sites.reshape(-1, 2).tolist()
        for k, tid in enumerate(batch.ids.tolist()):
            info = self.tasks.get(tid)
            if info is None:
                x, y = sites[k]
                info = TaskInfo(int(batch.types[k]), bool(batch.high[k]), (x, y), t_s)
                self.tasks[tid] = info
            elif info.state == "waiting":
                self.waiting.remove(tid)
                self.ends["requeued"] += 1
            else:
                self._fail(tid, f"announced again while {info.state} (counted twice)")
            info.state = "announced"
            info.announcements += 1
        if self.waiting:
            self._fail(self.waiting[0], "was abandoned and not re-announced (vanished)")

    def allocate(self, ids: np.ndarray, assignment: np.ndarray) -> None:
        """The round's outcome: ``assignment[t]`` is task t's robot, -1 if nobody took it."""
        for tid, robot in zip(ids.tolist(), np.asarray(assignment).tolist(), strict=True):
            info = self.tasks[tid]
            if info.state != "announced":
                self._fail(tid, f"allocated while {info.state}")
            if robot >= 0:
                info.state = "running"
            else:
                self._end(tid, "abandoned_lost" if info.abandons else "lost")

    def complete(self, c: Completion) -> None:
        """A running task ended (done, or failed with a reason)."""
        info = self.tasks.get(c.task_id)
        if info is None or info.state != "running":
            state = "never announced" if info is None else info.state
            self._fail(c.task_id, f"completed while {state} (counted twice or never allocated)")
        fate = "done" if c.ok else "failed"
        self._end(c.task_id, f"abandoned_{fate}" if info.abandons else fate)

    def abandon(self, a: Abandon) -> None:
        """A running task was given up because its robot broke."""
        info = self.tasks.get(a.task_id)
        if info is None or info.state != "running":
            state = "never announced" if info is None else info.state
            self._fail(a.task_id, f"abandoned while {state}")
        info.abandons += 1
        self.abandons.append(a)
        if self.policy == "drop":
            self.ends["dropped"] += 1
            self._end(a.task_id, "abandoned_lost")
        else:
            info.state = "waiting"
            self.waiting.append(a.task_id)

    def _end(self, tid: int, fate: str) -> None:
        info = self.tasks[tid]
        info.state, info.fate = "ended", fate

    def close(self) -> dict[str, int]:
        """The set is over: tasks still waiting are lost; every task must have its one fate.
        Returns the count of each fate."""
        for tid in self.waiting:
            self.ends["set_end"] += 1
            self._end(tid, "abandoned_lost")
        self.waiting = []
        counts = dict.fromkeys(FATES, 0)
        for tid, info in self.tasks.items():
            if info.state != "ended" or info.fate not in counts:
                self._fail(tid, f"has no fate at the end of the set (vanished while {info.state})")
            counts[info.fate] += 1
        return counts
