"""Progress of long commands on stderr: a tqdm bar on a terminal, plain lines elsewhere.

On a terminal a bar redraws in place (tqdm). Sent to a log, a pipe or CI, a command prints a
plain line now and then instead (``mrta: compare: 3/12 runs (25%), 1m02s so far, about 3m06s
left``): at the start, then at most every ``every_s`` seconds, and at the end, so a long run
sent to a file still says how far it is. ``--no-progress`` turns both off.
"""

from __future__ import annotations

import sys
import time
from typing import IO, Any


def progress_bar(total: int, desc: str, unit: str = "run", enabled: bool = True, **kw: Any):
    """A progress display over ``total`` steps: a tqdm bar on a terminal, :class:`PlainProgress`
    lines when stderr is not one, or nothing when ``enabled`` is False. All three have
    ``update(n=1)``, ``close()`` and work as a context manager.

    Args:
        total: steps to do.
        desc: what is being done (``compare paper_spatial``).
        unit: what a step is (``run``, ``round``, ``frame``).
        enabled: False for ``--no-progress``.
        **kw: for :class:`PlainProgress` (``stream``, ``every_s``, ``clock``), in tests.
    """
    stream = kw.pop("stream", None) or sys.stderr  # looked up now: tests swap sys.stderr
    if not enabled or total <= 0:
        return PlainProgress(total, desc, unit, stream=None)
    if _is_terminal(stream):
        from tqdm.auto import tqdm

        return tqdm(total=total, desc=desc, unit=unit, file=stream, dynamic_ncols=True, leave=False)
    return PlainProgress(total, desc, unit, stream=stream, **kw)


def _is_terminal(stream: IO[str]) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


class PlainProgress:
    """Progress as plain lines: ``mrta: <desc>: <done>/<total> <unit>s (<pct>), <elapsed> so
    far, about <left> left``, at the start, at most every ``every_s`` seconds, and at the end.

    Args:
        total: steps to do; desc, unit: as :func:`progress_bar`.
        stream: where lines go (None: nowhere, a disabled display; :func:`progress_bar`
            passes ``sys.stderr``).
        every_s: least time between two lines, s.
        clock: a monotonic clock in seconds (tests pass their own).
    """

    def __init__(
        self,
        total: int,
        desc: str,
        unit: str = "run",
        stream: IO[str] | None = None,
        every_s: float = 30.0,
        clock=time.monotonic,
    ) -> None:
        self.total, self.desc, self.unit = int(total), desc, unit
        self.stream, self.every_s, self.clock = stream, every_s, clock
        self.n = 0
        self.start_ = clock()
        self.last_ = self.start_
        self.closed = False
        self._line()

    def update(self, n: int = 1) -> None:
        """``n`` more steps done; a line if ``every_s`` passed since the last one."""
        self.n += n
        if self.stream is not None and self.clock() - self.last_ >= self.every_s:
            self._line()

    def close(self) -> None:
        """A last line (if any step was done since the first), once."""
        if not self.closed and self.n:
            self._line()
        self.closed = True

    def __enter__(self) -> PlainProgress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _line(self) -> None:
        if self.stream is None:
            return
        now = self.clock()
        self.last_ = now
        elapsed = now - self.start_
        done = min(self.n, self.total)
        pct = 100.0 * done / self.total if self.total else 100.0
        text = f"mrta: {self.desc}: {done}/{self.total} {self.unit}s ({pct:.0f}%)"
        if done:
            text += f", {clock_text(elapsed)} so far"
            if done < self.total:
                text += f", about {clock_text(elapsed / done * (self.total - done))} left"
        print(text, file=self.stream, flush=True)


def clock_text(seconds: float) -> str:
    """``3s``, ``4m05s``, ``2h03m``: a duration as a person reads it."""
    s = round(seconds)
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


def protocol_rounds(scenario) -> int:
    """Announcement rounds the paper protocol plays: learning sets, then test sets."""
    s = scenario.stream
    return (s.learn_sets + s.test_sets) * s.rounds_per_set
