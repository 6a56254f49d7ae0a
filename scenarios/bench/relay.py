"""Loops run in turns, one at a time, so that a shared machine's swings of speed fall on all alike.

On the shared machine the bench was built on, the CPU's speed switches between two levels
nearly a factor of two apart, several times a second, so two loops of a few seconds timed one
after the other can differ by that much for no reason of their own. A :class:`Relay` runs
several jobs (the loops without and with avoidance) in threads that take turns: one job runs
while the others wait, and it passes the turn on once it has run ``slice_s`` (at the next
:meth:`Relay.tick`, which ``mrta bench`` calls once per control period). Each job's clock
(:meth:`Relay.clock`) counts only its own turns. Turns of a few tens of milliseconds give every
job the same mixture of quick and slow spells.

Python threads allocate from their own malloc arenas on glibc, which made the loop about a
quarter slower than in the main thread here; :meth:`Relay.run` therefore asks glibc for one
arena for the whole process first (``mallopt(M_ARENA_MAX, 1)``; skipped where there is no
glibc), and the jobs allocate as the main thread does.
"""

from __future__ import annotations

import contextlib
import ctypes
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

SLICE_S = 0.02  # a job passes the turn once it has run this long (wall seconds)
_M_ARENA_MAX = -8  # glibc's mallopt parameter number (malloc.h)


def one_heap() -> bool:
    """Ask glibc to serve every thread from one malloc arena (``M_ARENA_MAX`` = 1); True if
    it did (False where there is no glibc ``mallopt``)."""
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (AttributeError, OSError, TypeError):  # no glibc (macOS, musl, Windows)
        return False
    return bool(mallopt(_M_ARENA_MAX, 1))


class Relay:
    """Runs jobs in threads, one at a time, in turns of ``slice_s`` of their own time.

    Args:
        slice_s: a job passes the turn at the first :meth:`tick` after it has run this long
            (0: at every tick).
        now: the time source (seconds, ``time.perf_counter``; a test gives a fake one).

    Attributes:
        turns: the job of each turn, in order (the first job's first turn included).
    """

    def __init__(self, slice_s: float = SLICE_S, now: Callable[[], float] = time.perf_counter):
        self.slice_s, self.now = slice_s, now
        self.turns: list[int] = []
        self._cond = threading.Condition()
        self._mine = threading.local()
        self._turn = -1
        self._done: list[bool] = []
        self._spent: list[float] = []
        self._since: list[float] = []

    def run(self, jobs: Sequence[Callable[[], Any]]) -> list[Any]:
        """Run the jobs in turns, the first one first; their results, in order. A job that
        raises ends and passes the turn on; the others run to their end, then the first
        error (in job order) is raised."""
        n = len(jobs)
        self._done, self._spent, self._since = [False] * n, [0.0] * n, [0.0] * n
        results: list[Any] = [None] * n
        errors: list[BaseException | None] = [None] * n
        self.turns, self._turn = [], 0 if n else -1

        def work(k: int) -> None:
            self._mine.k = k
            try:
                self._wait(k)
                results[k] = jobs[k]()
            except BaseException as err:  # (re-raised in the caller's thread below)
                errors[k] = err
            finally:
                self._finish(k)

        one_heap()
        threads = [threading.Thread(target=work, args=(k,), daemon=True) for k in range(n)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        for err in errors:
            if err is not None:
                raise err
        return results

    def clock(self) -> float:
        """The calling job's own time so far (seconds of its turns); outside a job, ``now()``."""
        k = getattr(self._mine, "k", None)
        if k is None:
            return self.now()
        return self._spent[k] + self.now() - self._since[k]

    def running(self) -> int:
        """How many jobs have not ended yet (the caller's own included)."""
        return self._done.count(False)

    def tick(self) -> None:
        """Called by a job now and then: passes the turn on once this turn has run
        ``slice_s``, and returns when the job's turn comes again (at once if it is the only
        job left). Outside a job, nothing."""
        k = getattr(self._mine, "k", None)
        if k is None:
            return
        t = self.now()
        if t - self._since[k] < self.slice_s:
            return
        with self._cond:
            self._pass(k)
            self._spent[k] += t - self._since[k]
            if self._turn == k:  # the only job left: its turn goes on
                self._since[k] = t
                return
        self._wait(k)

    @contextlib.contextmanager
    def ticking(self, cls: type, method: str) -> Iterator[None]:
        """While the block runs, every call of ``cls.method`` ends with a :meth:`tick` (the
        class is restored after the block)."""
        inner = cls.__dict__[method]

        def ticked(*args, **kwargs):
            try:
                return inner(*args, **kwargs)
            finally:
                self.tick()

        setattr(cls, method, ticked)
        try:
            yield
        finally:
            setattr(cls, method, inner)

    def _pass(self, k: int) -> None:
        """Give the turn to the next job after k that has not ended (k itself if none has
        not); the caller holds the condition."""
        n = len(self._done)
        for step in range(1, n + 1):
            nxt = (k + step) % n
            if not self._done[nxt]:
                self._turn = nxt
                break
        self._cond.notify_all()

    def _wait(self, k: int) -> None:
        with self._cond:
            self._cond.wait_for(lambda: self._turn == k)
        self.turns.append(k)
        self._since[k] = self.now()

    def _finish(self, k: int) -> None:
        self._spent[k] += self.now() - self._since[k]
        with self._cond:
            self._done[k] = True
            self._pass(k)
