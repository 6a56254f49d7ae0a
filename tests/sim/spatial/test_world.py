"""The pymunk world (``sim.spatial.world.PymunkWorld``) as a unit: initial headings, the snapshot
the costs read, its state between sets (round trip, restore, rebuild) and how dropped spaces
are freed. Whole runs are in ``tests/behaviour/``."""

from __future__ import annotations

import numpy as np
import pytest

import scenarios.experiments.protocol as protocol
from allocation.costs import make_cost_model
from learning.rounds import play_round
from scenarios.experiments.protocol import RunSpec
from scenarios.loader import load_scenario
from sim.scenario import RobotSpec, Scenario, SpatialSpec
from sim.spatial.world import PymunkWorld
from sim.tasks import Batch
from tests.worlds import scenario, send, small_spatial_file


def world_with(headings) -> PymunkWorld:
    starts = [(2.0 + 2.0 * k, 2.0) for k in range(len(headings))]
    sp = SpatialSpec(10.0, 5.0, (), (tuple(starts),))
    robots = tuple(
        RobotSpec(f"R{k}", (0,), xy, h)
        for k, (xy, h) in enumerate(zip(starts, headings, strict=True))
    )
    sc = Scenario("h", ("A",), robots, ((1.0,),) * len(robots), (1.0,), spatial=sp)
    return PymunkWorld(sc)


def test_robots_start_at_their_stated_headings_and_keep_them_while_standing():
    world = world_with([0.0, 90.0, -135.0])
    _, th = world.poses()
    np.testing.assert_allclose(th, np.radians([0.0, 90.0, -135.0]))
    np.testing.assert_allclose(world.fleet.last_th_rad, th)
    world.advance(2.0)
    np.testing.assert_allclose(world.poses()[1], th, atol=1e-12)


def test_snapshot_positions_feed_the_distance_cost_and_the_nearer_robot_bids_less():
    starts = [(2.0, 5.0), (9.0, 5.0), (18.0, 1.0)]
    sc = scenario(starts, sites=[(14.0, 5.0)])
    world = PymunkWorld(sc)
    cost = make_cost_model("distance", sc, world.planner)
    state = world.snapshot()
    assert state.positions.shape == (3, 2) and state.free.all()
    batch = Batch(0, 0, np.array([0]), np.array([0]), np.array([True]), np.array([[14.0, 5.0]]))
    bids = cost.costs(state, batch)[:, 0]
    assert bids[1] < bids[0]
    assert bids[0] == pytest.approx(12.0)


def test_dropped_spaces_are_freed_once_they_hold_gc_robots_and_the_rest_at_once():
    """A set boundary drops the space (and every collaborator built with it). The space and
    its contact monitor wait for a garbage collection (pymunk's collision handlers and the
    space hold each other), which runs once the dropped spaces hold ``GC_ROBOTS`` robots; the
    task bookkeeping and the rest go at once, by reference counting."""
    import gc
    import weakref

    world = PymunkWorld(scenario([(2.0, 2.0), (5.0, 2.0), (8.0, 2.0)]), gc_robots=6)
    send(world, [0, 1], [(12.0, 2.0), (12.0, 6.0)])
    world.drain()  # their tasks done, the set ends: a 3-robot space dropped, not yet collected
    assert world.dropped_robots_ == 3
    world.gc_robots = 9  # from here, three 3-robot spaces
    gc.collect()
    gc.disable()
    try:
        first = [weakref.ref(world.space), weakref.ref(world.contacts)]
        rest = [weakref.ref(x) for x in (world.jobs, world.follower, world.motors, world.stalls)]
        world.rebuild()
        assert [r() is None for r in first] == [False, False]  # 6 robots dropped: kept
        assert [r() is None for r in rest] == [True] * 4
        second = weakref.ref(world.space)
        world.rebuild()  # 9 robots dropped: collected
        assert [r() is None for r in [*first, second]] == [True, True, True]
        assert world.dropped_robots_ == 0
        world.rebuild()
        assert world.dropped_robots_ == 3
    finally:
        gc.enable()


def test_world_state_round_trip_for_both_controls(tmp_path):
    path = small_spatial_file(tmp_path)
    sc = load_scenario(path)
    spec = RunSpec(str(path), "market", "distance", 3)
    for control in ("scalar", "array"):
        _, stream, _, cost, allocator, rng = protocol.build_run(spec)
        world = PymunkWorld(sc, control=control)
        world.reset(rng)
        for batch in list(stream.batches(0))[:4]:
            play_round(world, batch, cost, allocator.allocate, 10.0)
        assert (world.fleet.task >= 0).any()
        with pytest.raises(RuntimeError, match="in progress"):
            world.state_arrays()
        world.drain()
        first = world.state_arrays()
        assert int(first["clock/steps"]) == world.clock.steps > 0
        assert first["motors/robots"].shape == (10, 6)
        assert int(first["contacts/robot_hits"]) == world.contacts.robot_hits
        world.restore_arrays(first)
        second = world.state_arrays()
        assert first.keys() == second.keys()
        for key in first:
            np.testing.assert_array_equal(first[key], second[key], err_msg=f"{control}: {key}")


def test_restore_rebuilds_the_space_and_keeps_the_counts(tmp_path):
    sc = load_scenario(small_spatial_file(tmp_path))
    world = PymunkWorld(sc)
    world.reset(np.random.default_rng(0))
    state = world.state_arrays()
    state["motors/robots"][0, :2] = (4.5, 2.5)
    state["contacts/wall_hits"] = np.array(17)
    state["clock/steps"] = np.array(600)
    space = world.space
    world.restore_arrays(state)
    assert world.space is not space  # a fresh space: no cached contacts carried over
    assert world.contacts.wall_hits == 17 and world.contacts.touching == 0
    assert world.time_s == pytest.approx(600 * sc.spatial.dt_s)
    xy, _ = world.poses()
    assert tuple(xy[0]) == (4.5, 2.5)


def test_rebuild_frees_the_old_spaces_and_reuses_the_batch_buffers(tmp_path):
    """A soak rebuilds the space at every set end: the old spaces must be freed (a pymunk
    space and its collision handlers form a reference cycle: by a collection once the dropped
    spaces hold ``sim.spatial.world.GC_ROBOTS`` robots) and the batch buffers, whose C arrays pymunk
    never frees, reused; otherwise memory grows set by set."""
    import math
    import weakref

    import sim.spatial.world

    world = PymunkWorld(load_scenario(small_spatial_file(tmp_path)))
    world.reset(np.random.default_rng(0))
    buffers = (world.motors.buf_, world.contacts.buf_)
    old = [weakref.ref(world.space)]
    for _ in range(math.ceil(sim.spatial.world.GC_ROBOTS / world.scenario.n_robots)):
        world.rebuild()
        old.append(weakref.ref(world.space))
        assert (world.motors.buf_, world.contacts.buf_) == buffers
    assert all(r() is None for r in old[:-1]) and old[-1]() is world.space
