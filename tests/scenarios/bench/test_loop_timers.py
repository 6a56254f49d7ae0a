"""The bench's timers: what they add up, in which worlds, and that they leave nothing behind."""

from __future__ import annotations

import time

from scenarios.bench.loop import timed_parts, timed_period


def _spin(seconds: float) -> None:
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


class Period:
    """A control period that takes a known time and counts its calls."""

    def __init__(self) -> None:
        self.calls = 0

    def period(self, t: float) -> None:
        self.calls += 1
        _spin(0.002)


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


class Rules:
    """A rule of a control period that takes a known time and calls a site's work."""

    def __init__(self, sites) -> None:
        self.sites = sites

    def period(self, t: float) -> None:
        _spin(0.002)
        self.sites.queue(t)


class Sites:
    def queue(self, t: float) -> None:
        _spin(0.020)


class Controlled:
    """A control period that takes 1 ms of its own and calls the rules (2 ms, then 20 ms of
    site work)."""

    def __init__(self) -> None:
        self.rules = Rules(Sites())

    def period(self, t: float) -> None:
        _spin(0.001)
        self.rules.period(t)


def test_timed_parts_counts_each_part_without_the_parts_it_calls_and_restores_them():
    rules = (("traffic", Rules, ("period",)), ("sites", Sites, ("queue",)))
    originals = [cls.__dict__[name] for cls, name in ((Controlled, "period"), (Rules, "period"))]
    world = Controlled()
    with timed_parts(Controlled, rules) as spent:
        for k in range(3):
            world.period(0.1 * k)
        Sites().queue(1.0)  # outside a control period: site work all the same
        inside = dict(spent)
    world.period(2.0)  # after the block: not counted
    assert set(inside) == {"control", "traffic", "sites"}
    # each at least its own time, and far below what it would be with the parts it calls (at
    # least 69 ms for the control periods, 66 ms for the rules): a slow spell of the machine
    # adds to a part, but not some 60 ms to parts of 3 and 6 ms
    assert 0.003 <= inside["control"] < 0.060
    assert 0.006 <= inside["traffic"] < 0.060
    assert 0.080 <= inside["sites"] < 1.0
    assert spent == inside
    assert Controlled.__dict__["period"] is originals[0]
    assert Rules.__dict__["period"] is originals[1]
