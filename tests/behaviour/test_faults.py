"""Broken robots in the pymunk world: a broken robot stops where it broke and the others plan
round it; a way only broken robots block is waited on until the repair, or fails with why.
The fault model itself (``sim.faults``) is in ``tests/sim/test_faults.py``."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from sim.scenario import DriveSpec, FaultSpec, RecoverySpec, RobotSpec, Scenario, SpatialSpec
from sim.spatial.world import PymunkWorld
from sim.states import DRIVING, IDLE
from sim.tasks import Batch

# the settings' defaults (sim.scenario), under the names these tests use
REPAIR_WAIT_S = RecoverySpec().repair_wait_s


def corridor(**faults) -> Scenario:
    """Two robots on the centre line of an empty 20 m x 6 m hall, R1 ahead of R2."""
    starts = ((8.0, 3.0), (3.0, 3.0))
    sp = SpatialSpec(20.0, 6.0, (), (((16.0, 3.0), (8.0, 3.0)),), DriveSpec())
    robots = tuple(RobotSpec(f"R{j + 1}", (0,), xy) for j, xy in enumerate(starts))
    return Scenario(
        "corridor", ("A",), robots, ((1.0,),) * 2, (2.0,), spatial=sp, faults=FaultSpec(**faults)
    )


@pytest.mark.parametrize("control", ["scalar", "array"])
def test_broken_robot_stops_and_the_other_plans_round_it(control):
    world = PymunkWorld(corridor(mttf_s=1e9, repair_s=1e6), control=control)
    world.reset(np.random.default_rng(0))
    world.faults.next_fail_s[:] = [2.0, np.inf]  # R1 breaks 2 s into its drive
    sites = np.array([[16.0, 3.0], [16.0, 3.0]])
    batch = Batch(0, 0, np.array([0]), np.zeros(1, int), np.zeros(1, bool), sites[:1])
    world.apply(batch, np.array([0]), np.ones(1))
    world.advance(2.0)
    (ab,) = world.take_abandoned()
    assert ab.robot == 0 and ab.task_id == 0
    assert world.fleet.state[0] == IDLE and world.fleet.task[0] == -1
    snap = world.snapshot()
    assert snap.broken.tolist() == [True, False] and not snap.free[0]
    world.advance(3.0)  # it brakes to a stop
    stop_xy = world.poses()[0][0].copy()
    # R2 is sent to the site straight beyond R1: its path goes round the broken robot
    batch = Batch(0, 1, np.array([1]), np.zeros(1, int), np.zeros(1, bool), sites[1:])
    world.apply(batch, np.array([1]), np.ones(1))
    plan = world.path_planner.path(world.poses()[0][1], sites[1])
    assert len(plan) > 2  # not the straight line through R1
    inflate = world.path_planner.inflate_m
    seg = _segment_distance(stop_xy, plan)
    assert seg >= inflate - 1e-6
    done = []
    for _ in range(60):
        done += world.advance(1.0)
        if done:
            break
    assert [(c.task_id, c.ok) for c in done] == [(1, True)], done
    assert np.linalg.norm(world.poses()[0][0] - stop_xy) < 0.05  # R1 stayed where it stopped
    assert world.take_abandoned() == []


def _segment_distance(p: np.ndarray, path: np.ndarray) -> float:
    """Least distance from point p to the polyline ``path``."""
    best = np.inf
    for a, b in itertools.pairwise(path):
        d = b - a
        t = np.clip(np.dot(p - a, d) / max(np.dot(d, d), 1e-12), 0.0, 1.0)
        best = min(best, float(np.linalg.norm(a + t * d - p)))
    return best


def _door_world(repair_s: float, control: str = "scalar") -> PymunkWorld:
    """A 20 m x 6 m hall cut by a wall at x = 12 m with a 1.2 m door (a single lane); R1
    stands in the door and breaks 0.5 s in; then R2, at (3, 3), is sent to (16, 3)."""
    wall = (
        ((11.8, 0.0), (12.2, 0.0), (12.2, 2.4), (11.8, 2.4)),
        ((11.8, 3.6), (12.2, 3.6), (12.2, 6.0), (11.8, 6.0)),
    )
    sp = SpatialSpec(20.0, 6.0, wall, (((16.0, 3.0), (19.0, 3.0)),), DriveSpec())
    robots = (RobotSpec("R1", (0,), (12.0, 3.0)), RobotSpec("R2", (0,), (3.0, 3.0)))
    faults = FaultSpec(mttf_s=1e9, repair_s=repair_s)
    sc = Scenario("door", ("A",), robots, ((1.0,),) * 2, (2.0,), spatial=sp, faults=faults)
    world = PymunkWorld(sc, control=control)
    world.reset(np.random.default_rng(0))
    world.faults.next_fail_s[:] = [0.5, np.inf]
    world.advance(1.0)
    assert world.snapshot().broken.tolist() == [True, False]
    send_one(world, 1, 7, (16.0, 3.0))
    return world


def send_one(world: PymunkWorld, robot: int, task: int, site) -> None:
    """Give robot ``robot`` the task ``task`` at ``site`` (a batch of one)."""
    batch = Batch(0, task, np.array([task]), np.zeros(1, int), np.zeros(1, bool), np.array([site]))
    world.apply(batch, np.array([robot]), np.ones(1))


@pytest.mark.parametrize("control", ["scalar", "array"])
def test_a_way_only_a_broken_robot_blocks_waits_for_the_repair_then_the_task_is_done(control):
    """The broken robot fills the door: the planner that knows where it stands finds no way,
    the scenario's planner does. R2 does not fail as unreachable: it waits where it is (drawn
    as waiting, no stuck clock) until the repair 20 s after the breakdown; then R1 is sent on
    through the door and R2 drives to its site and does the task."""
    from sim.states import WAITING, shown_states

    world = _door_world(20.0, control)
    f, jobs = world.fleet, world.jobs
    assert not len(world.path_planner.path((3.0, 3.0), (16.0, 3.0)))
    assert len(world.planner.path((3.0, 3.0), (16.0, 3.0)))
    assert jobs.blocked.tolist() == [False, True] and f.state[1] == DRIVING
    assert jobs.done == [] and jobs.failures == 0
    start = world.poses()[0][1].copy()
    done = world.advance(19.0)  # t = 20 s: still broken
    assert done == [] and jobs.blocked[1]
    assert shown_states(f.state, f.t_progress_s, world.time_s)[1] == WAITING
    assert np.linalg.norm(world.poses()[0][1] - start) < 0.05  # it held where it was
    done += world.advance(0.6)  # repaired at 20.5 s: R2 has its way again
    assert not jobs.blocked.any() and f.state[1] == DRIVING and done == []
    send_one(world, 0, 8, (19.0, 3.0))  # R1 leaves the door ahead of R2
    for _ in range(90):
        done += world.advance(1.0)
        if len(done) == 2:
            break
    assert sorted((c.task_id, c.robot, c.ok) for c in done) == [(7, 1, True), (8, 0, True)]
    assert min(c.t_done_s for c in done) > 20.5 + 2.0  # after the repair, and 2 s of work


def test_a_robot_lost_for_good_in_the_way_fails_the_task_with_why_after_the_wait():
    """Lost for good (no repair in sight), the task fails when its deadline, moved on by
    ``REPAIR_WAIT_S``, passes, with the reason: one failure, not a stuck robot."""

    world = _door_world(1e9)
    deadline = float(world.fleet.deadline_s[1])
    assert deadline > world.time_s + REPAIR_WAIT_S
    done = []
    while not done and world.time_s < deadline + 5.0:
        done += world.advance(10.0)
    (c,) = done
    assert (c.task_id, c.ok) == (7, False) and deadline <= c.t_done_s <= deadline + 0.2
    assert c.reason == "unreachable: broken robots in every way to its site until its deadline"
    assert world.jobs.failures == 1 and not world.jobs.blocked.any()


def test_only_broken_robots_make_a_robot_wait():
    """The robot waits only where the planner without broken robots has a way and the one with
    them has none; with no robot broken (or no faults) a task with no way fails as
    unreachable at once, as before (``tests/behaviour/test_physics.py``)."""
    world = _door_world(20.0)
    jobs = world.jobs
    assert jobs.blocked_by_broken((3.0, 3.0), (16.0, 3.0))
    jobs.broken[:] = False
    assert not jobs.blocked_by_broken((3.0, 3.0), (16.0, 3.0))
