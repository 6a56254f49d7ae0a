"""The two control periods behind one interface: same state in, same commands out.

``ScalarControl`` (robot by robot in Python) and ``ArrayControl`` (numpy over the robots) are run
one period each from copies of the very same world state, period after period of a crowded run;
the shared formulas of ``sim.drive_law`` give the same numbers on floats as on arrays.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from sim import drive_law as law
from sim.control import (
    CONTROLS,
    SMALL_TEAM,
    ArrayControl,
    ControlParts,
    ScalarControl,
    control_kind,
)
from sim.fleet import FleetState
from sim.jobs import Jobs
from sim.physics import PymunkWorld
from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.tasks import Batch


def crowd(avoidance: str = "none") -> Scenario:
    """A head-on pair passing an obstacle between standing robots, and a crossing robot."""
    starts = [(4.5, 5.0), (19.0, 5.0), (9.0, 6.0), (9.0, 3.3), (6.0, 1.5), (13.0, 8.5)]
    sites = [(18.0, 5.0), (2.0, 5.0), (9.0, 6.0), (9.0, 3.3), (16.0, 8.0), (13.0, 8.5)]
    box = (((11.5, 5.6), (13.0, 5.6), (13.0, 7.2), (11.5, 7.2)),)
    sp = SpatialSpec(20.0, 10.0, box, (tuple(sites),), DriveSpec(), avoidance=avoidance)
    robots = tuple(RobotSpec(f"R{j + 1}", (0,), xy) for j, xy in enumerate(starts))
    return Scenario("crowd", ("A",), robots, ((1.0,),) * len(robots), (2.0,), spatial=sp)


class Probe:
    """A stand-in for ``Motors``: the world's poses of now in, commands dropped (pymunk is left
    as it is, so probing does not change the run)."""

    def __init__(self, motors) -> None:
        self.rob = motors.read().copy()

    def read(self) -> np.ndarray:
        return self.rob

    def write(self, *args) -> None:
        pass

    def write_one(self, *args) -> None:
        pass


def one_period(world: PymunkWorld, kind) -> tuple[FleetState, Jobs]:
    """One period of control ``kind`` from a copy of the world's state; its fleet and jobs."""
    fleet, schedule = copy.deepcopy(world.fleet), copy.deepcopy(world.schedule)
    follower = copy.deepcopy(world.follower)
    jobs = Jobs(
        fleet=fleet,
        schedule=schedule,
        clock=world.clock,
        follower=follower,
        planner=world.planner,
        controller=world.controller,
        spatial=world.spatial,
        exec_time_s=world.exec_time_s_,
        reach_m=world.reach_m_,
        bodies=world.motors.bodies,
        rng=copy.deepcopy(world.jobs.rng),
        keep_lists=True,
        clear_sites=world.jobs.clear_sites,
    )
    jobs.restore_arrays(copy.deepcopy(world.jobs.state_arrays()))  # site queues and slots too
    jobs.jams.around_s = world.jobs.jams.around_s.copy()
    motors = Probe(world.motors)
    parts = ControlParts(
        fleet,
        schedule,
        jobs,
        motors,
        follower,
        world.controller,
        world.spatial.arrive_tol_m,
        world.reach_m_,
        world.jobs.clear_sites,
    )
    kind(parts).period(world.time_s)
    return fleet, jobs


@pytest.mark.parametrize("avoidance", ["none", "orca"])
def test_both_controls_command_the_same_wheels_from_the_same_state(avoidance):
    """Period after period of a crowded run, both implementations get a copy of the same state
    and must command the same wheels, see the same robot in the way and start the same work;
    with ORCA too (its commands, the turn-first wheel limit, site queues)."""
    sc = crowd(avoidance)
    world = PymunkWorld(sc, control="scalar")  # exact free widths and the lists: both can run
    k = [0, 1, 4]
    sites = np.array(sc.spatial.sites[0], dtype=float)[k]
    batch = Batch(0, 0, np.arange(3), np.zeros(3, int), np.zeros(3, bool), sites)
    world.apply(batch, np.array(k), np.ones(3))
    blocked, nearest, done = 0, np.inf, []
    for _ in range(200):  # 20 s, a control period at a time
        (a, ja), (b, jb) = (one_period(world, kind) for kind in (ScalarControl, ArrayControl))
        np.testing.assert_allclose(a.v_cmd_mps, b.v_cmd_mps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.q_cmd_mps, b.q_cmd_mps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.near_m, b.near_m, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(a.blocker, b.blocker)
        np.testing.assert_array_equal(a.state, b.state)
        assert ja.done == jb.done
        blocked += int((a.blocker >= 0).sum())
        nearest = min(nearest, float(a.near_m.min()))
        done += world.advance(0.1)
    assert blocked > 20  # robots met: the proximity caps were at work ...
    if avoidance == "none":
        assert nearest < world.controller.keep_right_m  # ... and keep-right
    assert sorted(c.task_id for c in done if c.ok) == [0, 1, 2]  # arrivals and ends of work


def test_control_is_chosen_by_name_or_by_team_size():
    assert control_kind("auto", SMALL_TEAM) == "scalar"
    assert control_kind("auto", SMALL_TEAM + 1) == "array"
    assert control_kind("array", 3) == "array" and control_kind("scalar", 300) == "scalar"
    assert CONTROLS == {"array": ArrayControl, "scalar": ScalarControl}
    with pytest.raises(ValueError, match="'auto', 'array' or 'scalar'"):
        control_kind("vector", 3)
    world = PymunkWorld(crowd())
    assert world.control_kind == "scalar" and isinstance(world.control, ScalarControl)
    assert PymunkWorld(crowd(), control="array").control.name == "array"


def test_shared_formulas_give_the_same_numbers_on_floats_and_arrays():
    """Real-valued formulas: float by float with ``math`` equals elementwise with numpy, bit for
    bit (each case: the formula, its array arguments, then its constants for floats and for
    arrays)."""
    rng = np.random.default_rng(2)
    a, b, c, d = (rng.uniform(-2.0, 2.0, 2000) for _ in range(4))
    pos = rng.uniform(0.01, 3.0, 2000)
    cases = [
        (law.steer_speeds, (a, pos, pos), (3.0, -1.5, 1.2, math.sqrt), (3.0, -1.5, 1.2, np.sqrt)),
        (law.stopping_time_s, (a,), (0.1, 0.4), (0.1, 0.4)),
        (law.approach_cap_mps, (pos, pos), (3.0, 0.2, 0.04, math.sqrt), (3.0, 0.2, 0.04, np.sqrt)),
        (law.pair_share_m, (a, b, c), (), ()),
        (law.rim_speed_mps, (a, b), (), ()),
        (law.twist_from_rims, (a, b, c, d), (), ()),
        (law.on_arc, (a, b * 1e-4), (), ()),
        (law.goes_our_way, (a, b), (math.cos,), (np.cos,)),
    ]
    for fn, arrays, float_consts, array_consts in cases:
        rows = zip(*(x.tolist() for x in arrays), strict=True)
        ours = np.array([fn(*row, *float_consts) for row in rows])
        theirs = np.array(fn(*arrays, *array_consts))
        np.testing.assert_array_equal(ours.T, theirs, err_msg=fn.__name__)
    assert law.next_check_s(2.0, -1.0, 3.0) == 2.0 and law.next_check_s(2.0, 3.0, 3.0) == 3.0


def test_control_body_sits_at_the_centre_of_the_arc():
    """On an arc the control body stands still at z + i R h; straight it moves at v h."""
    z, h = 2.0 + 3.0j, np.exp(0.7j)
    v, w = 1.2, 0.6
    centre, vel = law.control_body(z, h, v, w, v / w)
    assert abs(centre - (z + 2.0 * 1j * h)) < 1e-12 and abs(vel) < 1e-12
    centre, vel = law.control_body(z, h, v, 0.0, 0.0)
    assert centre == z and vel == v * h
    zs, hs = np.array([z, z]), np.array([h, h])
    arr_centre, arr_vel = law.control_body(
        zs, hs, np.array([v, v]), np.array([w, 0.0]), np.array([v / w, 0.0])
    )
    np.testing.assert_allclose(arr_centre, [z + 2.0 * 1j * h, z], rtol=0, atol=1e-12)
    np.testing.assert_allclose(arr_vel, [0.0, v * h], rtol=0, atol=1e-12)


def test_under_avoidance_a_fast_turn_that_must_slow_takes_the_wheels_first():
    """DiffDriveController.limit with ``turn_first``: a robot turning faster than
    TURN_FIRST_RADPS that is told to stop turning while speeding up slows its turn by the full
    rim step and keeps its speed; a slower turn, a turn that grows, a robot ORCA steers, or the
    law without avoidance share the step between the wheels as before."""
    c = PymunkWorld(crowd()).controller
    s, hb = c.rim_step_mps, c.half_base_m
    q_fast, q_slow = 2.5 * hb, 0.99 * law.TURN_FIRST_RADPS * hb
    v0 = np.array([0.5, 0.5, 0.5, 0.5])
    q0 = np.array([q_fast, q_slow, q_fast, q_fast])
    want_v = np.full(4, 1.0)
    want_w = np.array([0.0, 0.0, 3.0, 0.0])  # robot 2's turn grows
    v, _, q = c.limit(want_v, want_w, v0, q0, True, np.array([3]))
    assert v[0] == 0.5 and q[0] == pytest.approx(q_fast - s, abs=1e-12)
    old_v, _, old_q = c.limit(want_v, want_w, v0, q0)
    assert old_v[0] > 0.5 and old_q[0] > q_fast - s  # without: speed first, turn lingers
    np.testing.assert_array_equal(v[1:], old_v[1:])
    np.testing.assert_array_equal(q[1:], old_q[1:])
