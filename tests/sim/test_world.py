"""The abstract world (``sim.world.AbstractWorld``): each time and each fate it reports, worked
out by hand from execution times and a scripted fault schedule.

Faults are scripted on the real model: a mean time to failure of 1e12 s draws no failure of its
own within a test, and a test sets ``faults.next_fail_s`` to the failures it wants.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sim.faults import FaultSpec
from sim.tasks import Batch
from sim.world import Abandon, AbstractWorld, Completion, World, WorldState

NEVER = 1e12  # a mean time to failure that draws no failure within a test


def batch(ids, types) -> Batch:
    k = len(ids)
    return Batch(0, 0, np.array(ids), np.array(types), np.zeros(k, bool), np.full((k, 2), np.nan))


def faulty(tiny, fail_at, **spec) -> AbstractWorld:
    """``tiny`` (execution 15 s per task) with failures at ``fail_at`` (one time per robot)."""
    sc = dataclasses.replace(tiny, faults=FaultSpec(mttf_s=NEVER, **spec))
    world = AbstractWorld(sc)
    world.reset(np.random.default_rng(0))
    world.faults.next_fail_s[:] = fail_at
    return world


def test_a_task_keeps_its_robot_busy_for_the_execution_time_and_time_adds_up(tiny):
    world = AbstractWorld(dataclasses.replace(tiny, exec_time_s=(15.0, 4.0)))
    world.advance(2.5)
    world.apply(batch([7, 8], [0, 1]), np.array([1, 2]), np.array([3.5, 1.25]))
    snap = world.snapshot()
    assert snap.time_s == 2.5
    assert snap.free.tolist() == [True, False, False]
    assert snap.busy_until_s.tolist() == [2.5, 17.5, 6.5]  # a free robot: the time now
    assert snap.positions is None and snap.broken is None
    assert world.advance(3.0) == []  # 5.5 s: neither ends
    assert world.advance(1.0) == [Completion(8, 2, 2.5, 6.5, 1.25)]  # 6.5 s: ends exactly now
    assert world.snapshot().time_s == 6.5
    assert world.advance(20.0) == [Completion(7, 1, 2.5, 17.5, 3.5)]
    assert world.snapshot().time_s == 26.5


def test_completions_come_in_robot_order_with_what_the_robot_bid(tiny):
    world = AbstractWorld(tiny)
    world.apply(batch([5, 6, 4], [1, 0, 0]), np.array([2, 1, 0]), np.array([1.0, 2.0, 0.5]))
    done = world.advance(15.0)
    assert [(c.task_id, c.robot, c.bid, c.ok, c.reason) for c in done] == [
        (4, 0, 0.5, True, ""),
        (6, 1, 2.0, True, ""),
        (5, 2, 1.0, True, ""),
    ]


def test_a_robot_given_a_task_while_busy_is_an_invariant_error(tiny):
    world = AbstractWorld(tiny)
    world.apply(batch([1], [0]), np.array([0]), np.array([1.0]))
    busy = r"^invariant violated: robot 0 given a task while busy$"
    with pytest.raises(RuntimeError, match=busy):
        world.apply(batch([2], [0]), np.array([0]), np.array([1.0]))
    world.apply(batch([3, 4], [0, 1]), np.array([-1, 2]), np.array([np.nan, 1.0]))  # -1: lost
    assert sorted(c.task_id for c in world.drain()) == [1, 4]


def test_drain_ends_every_task_at_its_own_time_and_moves_the_clock_to_the_last(tiny):
    world = AbstractWorld(tiny)
    assert world.drain() == [] and world.snapshot().time_s == 0.0  # nothing running: no time
    world.apply(batch([1], [0]), np.array([0]), np.array([1.0]))
    world.advance(10.0)
    world.apply(batch([2], [1]), np.array([2]), np.array([1.0]))
    assert [(c.task_id, c.t_done_s) for c in world.drain()] == [(1, 15.0), (2, 25.0)]
    assert world.snapshot().time_s == 25.0
    assert world.drain() == [] and world.snapshot().time_s == 25.0


def test_available_is_every_robot_without_faults_and_the_unbroken_ones_with_them():
    free = np.array([True, False, True])
    plain = WorldState(0.0, free, np.zeros(3)).available()
    assert plain.dtype == bool and plain.tolist() == [True, True, True]
    broken = WorldState(0.0, free, np.zeros(3), None, np.array([False, True, False]))
    assert broken.available().tolist() == [True, False, True]


def test_a_world_without_faults_abandons_nothing_and_declares_the_world_interface(tiny):
    """The abstract world implements every member of ``World`` (no probe for optional
    capabilities): no planner, no recorder, no fault model without a [faults] table, and an
    empty list of abandoned tasks."""
    world = AbstractWorld(tiny)
    members = [n for n in vars(World) if not n.startswith("_")] + list(World.__annotations__)
    assert all(hasattr(world, n) for n in members), [n for n in members if not hasattr(world, n)]
    assert (world.planner, world.recorder, world.faults) == (None, None, None)
    assert world.take_abandoned() == []


def test_a_failure_exactly_at_the_end_of_an_advance_happens_in_it(tiny):
    world = faulty(tiny, [np.inf, 5.0, np.inf], repair_s=20.0)
    world.apply(batch([3], [0]), np.array([1]), np.array([2.0]))
    assert world.advance(5.0) == []
    assert world.take_abandoned() == [Abandon(3, 1, 0.0, 5.0, 2.0)]
    snap = world.snapshot()
    assert snap.broken.tolist() == [False, True, False]
    assert snap.free.tolist() == [True, False, True]
    assert snap.busy_until_s.tolist() == [5.0, 25.0, 5.0]  # busy until repaired


def test_a_task_that_ends_when_its_robot_breaks_is_done_not_abandoned(tiny):
    world = faulty(tiny, [15.0, np.inf, np.inf])
    world.apply(batch([9], [0]), np.array([0]), np.array([1.0]))
    assert world.advance(20.0) == [Completion(9, 0, 0.0, 15.0, 1.0)]
    assert world.take_abandoned() == []


def test_a_task_that_ended_before_its_robot_broke_is_done(tiny):
    world = faulty(tiny, [18.0, np.inf, np.inf])
    world.advance(1.0)
    world.apply(batch([9], [0]), np.array([0]), np.array([1.0]))
    assert world.advance(30.0) == [Completion(9, 0, 1.0, 16.0, 1.0)]
    assert world.take_abandoned() == []


def test_drain_with_faults_returns_the_tasks_done_before_and_after_a_failure(tiny):
    world = faulty(tiny, [np.inf, 6.0, np.inf], repair_s=4.0)
    world.apply(batch([1, 2], [0, 1]), np.array([0, 1]), np.array([1.0, 2.0]))
    world.advance(5.0)
    world.apply(batch([3], [1]), np.array([2]), np.array([3.0]))  # 5 s to 20 s
    done = world.drain()
    assert [(c.task_id, c.t_done_s) for c in done] == [(1, 15.0), (3, 20.0)]
    assert world.take_abandoned() == [Abandon(2, 1, 0.0, 6.0, 2.0)]
    assert world.snapshot().time_s == 20.0


def test_a_robot_lost_for_good_is_not_busy_until_forever(tiny):
    world = faulty(tiny, [np.inf, 5.0, np.inf], p_permanent=1.0)
    world.advance(10.0)
    snap = world.snapshot()
    assert snap.broken.tolist() == [False, True, False]
    assert snap.busy_until_s.tolist() == [10.0, 10.0, 10.0]  # never free, and no end to wait for
    assert snap.available().tolist() == [True, False, True]


def test_a_checkpoint_while_a_task_runs_is_refused(tiny):
    world = AbstractWorld(tiny)
    world.apply(batch([1], [0]), np.array([0]), np.array([1.0]))
    with pytest.raises(RuntimeError, match=r"^checkpoint requested while tasks are in progress$"):
        world.state_arrays()


def test_a_new_world_draws_its_faults_as_one_reset_with_seed_0(tiny):
    sc = dataclasses.replace(tiny, faults=FaultSpec(mttf_s=100.0))
    fresh, again = AbstractWorld(sc), AbstractWorld(sc)
    assert np.array_equal(fresh.faults.next_fail_s, again.faults.next_fail_s)
    again.reset(np.random.default_rng(0))
    assert np.array_equal(fresh.faults.next_fail_s, again.faults.next_fail_s)
    again.reset(np.random.default_rng(1))
    assert not np.array_equal(fresh.faults.next_fail_s, again.faults.next_fail_s)


def test_abstract_world_abandons_the_task_of_a_broken_robot(tiny):
    sc = dataclasses.replace(tiny, faults=FaultSpec(mttf_s=1e9, repair_s=20.0))
    world = AbstractWorld(sc)
    world.reset(np.random.default_rng(0))
    world.faults.next_fail_s[:] = [5.0, np.inf, np.inf]  # R1 breaks at 5 s
    batch = Batch(0, 0, np.array([10, 11]), np.array([0, 1]), np.zeros(2, bool), np.zeros((2, 2)))
    world.apply(batch, np.array([0, 2]), np.array([1.0, 1.0]))
    done = world.advance(10.0)
    assert [c.task_id for c in done] == []  # both take 15 s
    (ab,) = world.take_abandoned()
    assert (ab.task_id, ab.robot, ab.t_alloc_s, ab.t_s) == (10, 0, 0.0, 5.0)
    snap = world.snapshot()
    assert snap.broken.tolist() == [True, False, False]
    assert snap.free.tolist() == [False, True, False]
    assert snap.busy_until_s[0] == 25.0  # repaired at 5 + 20 s
    done = world.advance(10.0)
    assert [(c.task_id, c.robot, c.t_done_s) for c in done] == [(11, 2, 15.0)]
    world.advance(10.0)
    assert world.snapshot().free.tolist() == [True, True, True]
    assert world.take_abandoned() == []
