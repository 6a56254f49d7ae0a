"""``scenarios.bench.relay``: jobs in threads that take turns, one at a time, each timed by its
own turns (a fake time source here, advanced by the jobs themselves)."""

from __future__ import annotations

import time

import pytest

from scenarios.bench.relay import Relay


class FakeTime:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def stepping(relay: Relay, clock: FakeTime, step_s: float, steps: int, seen: list):
    """A job: ``steps`` times, spend ``step_s`` and tick; then return its own clock."""

    def job():
        for _ in range(steps):
            clock.t += step_s
            relay.tick()
            seen.append(relay.clock())
        return relay.clock()

    return job


def test_jobs_alternate_and_each_clock_counts_only_its_own_turns():
    clock = FakeTime()
    relay = Relay(slice_s=0.0, now=clock)
    a, b = [], []
    out = relay.run([stepping(relay, clock, 1.0, 3, a), stepping(relay, clock, 10.0, 3, b)])
    assert out == [3.0, 30.0]
    assert a == [1.0, 2.0, 3.0] and b == [10.0, 20.0, 30.0]
    assert relay.turns == [0, 1, 0, 1, 0, 1, 0, 1]
    assert clock.t == 33.0


def test_a_turn_lasts_until_the_job_has_run_a_slice():
    """Steps of 1 s in slices of 2.5 s: a turn ends at the third tick of it; the longer job
    goes on alone once the other has ended."""
    clock = FakeTime()
    relay = Relay(slice_s=2.5, now=clock)
    out = relay.run([stepping(relay, clock, 1.0, 6, []), stepping(relay, clock, 1.0, 12, [])])
    assert out == [6.0, 12.0]
    assert relay.turns == [0, 1, 0, 1, 0, 1]


def test_no_two_jobs_run_at_once():
    """Each job marks itself the owner after its tick and sleeps (letting any thread that is
    not held back run): the owner is still itself when it wakes."""
    relay = Relay(slice_s=0.0)
    owner = [None]
    clashes = []

    def job(k):
        def run():
            for _ in range(20):
                relay.tick()
                owner[0] = k
                time.sleep(0.001)
                if owner[0] != k:
                    clashes.append(k)
            return k

        return run

    assert relay.run([job(k) for k in range(3)]) == [0, 1, 2]
    assert clashes == []
    assert relay.turns[:6] == [0, 1, 2, 0, 1, 2]


def test_an_error_ends_its_job_the_others_finish_then_it_is_raised():
    clock = FakeTime()
    relay = Relay(slice_s=0.0, now=clock)
    done = []

    def bad():
        relay.tick()
        raise ValueError("job 1 failed")

    def good():
        for _ in range(4):
            relay.tick()
        done.append(True)

    with pytest.raises(ValueError, match="job 1 failed"):
        relay.run([good, bad, good])
    assert done == [True, True]
    assert relay.turns == [0, 1, 2, 0, 1, 2, 0, 2, 0, 2, 0, 2]  # job 1 ends in its 2nd turn


def test_outside_a_job_tick_does_nothing_and_the_clock_is_the_time_source():
    clock = FakeTime()
    clock.t = 7.0
    relay = Relay(slice_s=0.0, now=clock)
    relay.tick()
    assert relay.clock() == 7.0 and relay.turns == []
    assert relay.run([]) == []


def test_ticking_adds_a_tick_to_a_method_and_restores_it_even_after_an_error():
    class Loop:
        def period(self):
            return "stepped"

    relay = Relay(slice_s=0.0)
    own = Loop.__dict__["period"]
    with pytest.raises(RuntimeError), relay.ticking(Loop, "period"):
        assert Loop.__dict__["period"] is not own
        out = relay.run([lambda: [Loop().period() for _ in range(3)], lambda: Loop().period()])
        assert out == [["stepped"] * 3, "stepped"]
        assert relay.turns == [0, 1, 0, 1, 0]  # job 0's third call: alone, its turn goes on
        raise RuntimeError
    assert Loop.__dict__["period"] is own


def test_running_counts_the_jobs_not_ended_yet():
    clock = FakeTime()
    relay = Relay(slice_s=0.0, now=clock)
    seen = []

    def job(steps):
        def run():
            for _ in range(steps):
                seen.append(relay.running())
                relay.tick()

        return run

    relay.run([job(1), job(3), job(2)])
    # turns 0, 1, 2; job 0 ends at its second; 1, 2 (job 2 waits in its last tick), 1
    assert seen == [3, 3, 3, 2, 2, 2]
    assert relay.running() == 0
