"""Progress off a terminal: plain periodic lines on stderr; none with --no-progress."""

from __future__ import annotations

import io

from scenarios.experiments.progress import PlainProgress, clock_text, progress_bar


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_plain_lines_at_the_start_every_interval_and_at_the_end():
    out, clock = io.StringIO(), Clock()
    bar = progress_bar(12, "compare paper_spatial", "run", stream=out, every_s=30.0, clock=clock)
    assert isinstance(bar, PlainProgress)  # a StringIO is not a terminal
    with bar:
        for step in range(12):
            clock.t += 10.0  # a run takes 10 s
            bar.update()
            if step == 5:
                assert out.getvalue().count("\n") == 3  # at 0 s, 30 s and 60 s
    lines = out.getvalue().splitlines()
    assert lines[0] == "mrta: compare paper_spatial: 0/12 runs (0%)"
    assert lines[1] == (
        "mrta: compare paper_spatial: 3/12 runs (25%), 30s so far, about 1m30s left"
    )
    assert lines[-1] == "mrta: compare paper_spatial: 12/12 runs (100%), 2m00s so far"
    assert len(lines) == 6  # 0, 30, 60, 90, 120 s, and the end (at 120 s too, once more)


def test_no_lines_with_no_progress():
    out = io.StringIO()
    with progress_bar(5, "run", stream=out, enabled=False) as bar:
        bar.update(5)
    assert out.getvalue() == ""
    assert (clock_text(59), clock_text(245), clock_text(7385)) == ("59s", "4m05s", "2h03m")
