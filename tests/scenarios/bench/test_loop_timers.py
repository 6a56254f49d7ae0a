"""The bench's timers: what they add up, in which worlds, and that they leave nothing behind."""

from __future__ import annotations

import time

from scenarios.bench.loop import timed_period


class Period:
    """A control period that takes a known time and counts its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def period(self, t: float) -> None:
        self.calls += 1
        end = time.perf_counter() + 0.002
        while time.perf_counter() < end:
            pass


def test_timed_period_adds_every_instance_and_restores_the_class():
    original = Period.__dict__["period"]
    first, later = Period(), None
    with timed_period(Period) as spent:
        first.period(0.0)
        later = Period()  # built inside the block, as a world rebuilt at a set boundary is
        later.period(0.1)
        later.period(0.2)
        inside = spent[0]
    first.period(0.3)  # after the block: not counted
    assert 0.006 <= inside < 0.5
    assert spent[0] == inside
    assert (first.calls, later.calls) == (2, 2)
    assert Period.__dict__["period"] is original
