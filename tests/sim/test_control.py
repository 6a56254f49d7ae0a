"""The two control periods behind one interface: same state in, same commands out.

``ScalarControl`` (robot by robot in Python) and ``ArrayControl`` (numpy over the robots) are run
one period each from copies of the very same world state, period after period of a crowded run;
the shared formulas of ``sim.spatial.law.drive`` give the same numbers on floats as on arrays.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.spatial.control import (
    CONTROLS,
    SMALL_TEAM,
    ArrayControl,
    ControlParts,
    ScalarControl,
    control_kind,
)
from sim.spatial.fleet import FleetState
from sim.spatial.jobs import Jobs
from sim.spatial.law import drive as law
from sim.spatial.world import PymunkWorld
from sim.states import WORKING
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
        avoid=world.jobs.avoid,
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
        world.jobs.avoid,
    )
    kind(parts).period(world.time_s)
    return fleet, jobs


def to_next_period(world: PymunkWorld) -> None:
    """Step the world's physics to its next control period and stop before running it, so
    that the copies of :func:`one_period` run the very period the world runs next (after
    ``advance`` the world has already run the period at its time, and an event due then,
    such as the end of a back-off, would be spent before the copies see it)."""
    n = world.substeps - world.clock.steps % world.substeps
    world.contacts.run(n, world.dt_s)
    world.clock.steps += n
    world.goal_s_ = world.clock.steps * world.dt_s


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
    for _ in range(400):  # 20 s, a control period (0.05 s) at a time
        (a, ja), (b, jb) = (one_period(world, kind) for kind in (ScalarControl, ArrayControl))
        np.testing.assert_allclose(a.v_cmd_mps, b.v_cmd_mps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.q_cmd_mps, b.q_cmd_mps, rtol=0, atol=1e-9)
        np.testing.assert_allclose(a.near_m, b.near_m, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(a.blocker, b.blocker)
        np.testing.assert_array_equal(a.state, b.state)
        assert ja.done == jb.done
        blocked += int((a.blocker >= 0).sum())
        nearest = min(nearest, float(a.near_m.min()))
        world._control()  # the period both copies ran (``to_next_period``)
        done, world.jobs.done = done + world.jobs.done, []
        to_next_period(world)
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
        (
            law.approach_cap_mps,
            (pos, pos),
            (3.0, 0.2, 0.04, math.sqrt, 0.15),
            (3.0, 0.2, 0.04, np.sqrt, 0.15),
        ),
        (law.pair_share_m, (a, b, c), (), ()),
        (law.rim_speed_mps, (a, b), (), ()),
        (law.twist_from_rims, (a, b, c, d), (), ()),
        (law.on_arc, (a, b * 1e-4), (), ()),
        (law.goes_our_way, (a, b), (math.cos, 0.5), (np.cos, 0.5)),
    ]
    for fn, arrays, float_consts, array_consts in cases:
        rows = zip(*(x.tolist() for x in arrays), strict=True)
        ours = np.array([fn(*row, *float_consts) for row in rows])
        theirs = np.array(fn(*arrays, *array_consts))
        np.testing.assert_array_equal(ours.T, theirs, err_msg=fn.__name__)
    assert law.next_check_s(2.0, -1.0, 3.0) == 2.0 and law.next_check_s(2.0, 3.0, 3.0) == 3.0


def test_the_law_s_formulas_give_the_numbers_worked_by_hand():
    """Each formula of ``sim.spatial.law.drive`` on numbers worked out by hand (the parity test
    above runs them on random numbers but cannot see a wrong formula both sides share)."""
    assert law.steer_speeds(1.0, 2.0, 0.25, 3.0, -1.5, 1.2, math.sqrt) == (1.5, math.sqrt(2.65))
    # ORCA's preferred velocity: toward the aim, at the speed that still brakes within the gap
    pv = law.preferred_velocity(3 + 4j, 0.5, 0.0, 1.0, 1.5, math.sqrt, min)  # sqrt(0.5 * 2)
    assert abs(pv - (0.6 + 0.8j)) < 1e-12
    pv = law.preferred_velocity(3 + 4j, 2.0, 0.25, 0.5, 3.0, math.sqrt, min)  # sqrt(2.25)
    assert abs(pv - (0.9 + 1.2j)) < 1e-12
    pv = law.preferred_velocity(-6.0, 9.0, 0.0, 1.0, 1.5, math.sqrt, min)  # capped at the top
    assert abs(pv - (-1.5)) < 1e-12
    assert law.preferred_velocity(0j, 0.0, 0.0, 1.0, 1.5, math.sqrt, min) == 0
    tiny = law.preferred_velocity(1e-13 + 0j, 1e-13, 0.0, 1.0, 1.5, math.sqrt, min)
    assert tiny.real >= 0.0  # at its aim point a robot never prefers to move away from it
    assert law.stopping_time_s(-0.8, 0.1, 0.25) == pytest.approx(0.3, abs=1e-15)
    cap, creep = law.approach_cap_mps(0.5, 0.5, 3.0, 0.2, 0.04, math.sqrt, 0.15)
    assert cap == pytest.approx(math.sqrt(3.04) - 0.2, abs=1e-15) and creep == pytest.approx(0.3)
    assert law.pair_share_m(2.0, 0.5, 0.3) == (1.5, 0.9)
    assert law.rim_speed_mps(-0.4, 0.3) == pytest.approx(0.7, abs=1e-15)
    assert law.twist_from_rims(0.2, -0.1, 1.0, 0.5) == pytest.approx((1.05, 0.65), abs=1e-15)
    assert not law.on_arc(1.0, 1e-4) and law.on_arc(0.99, 1e-4)  # radius 1e4 m is straight
    # within 60 degrees of our heading goes our way; the difference counts, not the sum
    assert law.goes_our_way(1.0, 0.5, math.cos, 0.5)
    assert not law.goes_our_way(1.0, -0.5, math.cos, 0.5)


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
    ``turn_first_radps`` that is told to stop turning while speeding up slows its turn by the full
    rim step and keeps its speed; a slower turn, a turn that grows, a robot ORCA steers, or the
    law without avoidance share the step between the wheels as before."""
    c = PymunkWorld(crowd()).controller
    s, hb = c.rim_step_mps, c.half_base_m
    q_fast, q_slow = 2.5 * hb, 0.99 * c.turn_first_radps * hb
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


# ``prox_check_s`` is left out: the scalar period sleeps the proximity check while no robot that
# steers is near another, the array period only while no two robots are (the same commands).
SCHEDULE_FIELDS = (
    "next_end_s",
    "next_deadline_s",
    "stuck_check_s",
    "site_check_s",
    "n_backoff",
    "n_yield",
    "n_steer",
    "resting",
    "calm",
    "recovering",
    "state_list",
    "steer_list",
)


def assert_same_state(a: FleetState, ja: Jobs, b: FleetState, jb: Jobs, t: float) -> None:
    """Every array of the fleet, every field of the schedule, where each robot is on its path,
    the site queues and the completions of the two periods agree (to 1e-9 where the two
    implementations round differently: numbers, not flags or indices)."""
    for name in a.__dataclass_fields__:
        x, y = getattr(a, name), getattr(b, name)
        if not isinstance(x, np.ndarray):  # ``nobody``, never written
            continue
        if x.dtype.kind in "fc":
            np.testing.assert_allclose(x, y, rtol=0, atol=1e-9, err_msg=f"{name} at {t} s")
        else:
            np.testing.assert_array_equal(x, y, err_msg=f"{name} at {t} s")
    for name in SCHEDULE_FIELDS:
        x, y = getattr(ja.schedule, name), getattr(jb.schedule, name)
        if isinstance(x, float):
            assert x == pytest.approx(y, rel=0, abs=1e-9), (name, t)
        else:
            assert x == y, (name, t)
    np.testing.assert_array_equal(ja.follower.index, jb.follower.index)
    for name, x in ja.sites.state_arrays().items():
        np.testing.assert_array_equal(x, jb.sites.state_arrays()[name], err_msg=f"{name} at {t} s")
    assert ja.done == jb.done, t


# wheels that brake at 1.2 m/s^2 (every scenario's default brakes at 1.0, where 2 a = 2 / a)
BRISK = DriveSpec(max_wheel_speed_radps=12.5, max_wheel_accel_radps2=30.0)


@pytest.mark.parametrize(
    ("case", "robots", "seconds", "shows", "drive", "avoidance"),
    [
        ("site", 12, 40.0, ("held", "slotted", "yielding"), None, "orca"),  # a site's queue
        ("corridor", 2, 30.0, ("backing", "recovering"), None, "orca"),  # head-on, one lane
        ("parked", 6, 12.0, (), None, "orca"),  # passing robots at work
        ("junction", 4, 15.0, (), BRISK, "orca"),  # four robots cross, other wheels
        ("site", 12, 30.0, ("beside",), None, "none"),  # no queue: work beside the one there
    ],
)
def test_both_controls_leave_the_same_state_in_the_hard_cases(
    case, robots, seconds, shows, drive, avoidance
):
    """Beyond the commands: period after period of a hard case, both implementations leave the
    same fleet, schedule, path indices, site queues and completions. In the corridor robot 0 is
    made to back off blind at 3 s (``Jobs.recover``, as at a stuck timeout with no way round)
    and replans after it; without avoidance the array period looks for robots touching one at
    the site among neighbour pairs (``dense_max`` set below the team, as beyond 64 robots).
    Each case must show what it is there for."""
    from scenarios.experiments.hardcases import CASES

    kw = {} if drive is None else {"drive": drive}
    world, _ = CASES[case].build(robots, "scalar", avoidance, lambda s: np.asarray(s, float), **kw)
    if avoidance == "none":
        world.controller.dense_max = 4
    site = world.fleet.site.copy()
    seen = dict.fromkeys(("backing", "recovering", "held", "slotted", "yielding", "beside"), 0)
    period_s = world.substeps * world.dt_s
    for k in range(round(seconds / period_s)):
        if case == "corridor" and k == round(3.0 / period_s):
            world.jobs.recover(0, world.time_s)
        (a, ja), (b, jb) = (one_period(world, kind) for kind in (ScalarControl, ArrayControl))
        assert_same_state(a, ja, b, jb, world.time_s)
        world._control()  # the period both copies ran, now in the world itself
        world.jobs.done = []  # handed out, as ``advance`` does
        to_next_period(world)
        seen["backing"] += world.schedule.n_backoff
        seen["recovering"] += world.schedule.recovering
        seen["yielding"] += world.schedule.n_yield
        seen["held"] += int(world.jobs.sites.holding.sum())
        seen["slotted"] += int(world.jobs.sites.slotted.sum())
        working = world.fleet.state == WORKING
        seen["beside"] += int((working & (np.abs(world.fleet.last_z_m - site) > 0.3)).sum())
    assert all(seen[name] for name in shows), seen
