"""The two control periods behind one interface: same state in, same commands out.

``ScalarControl`` (robot by robot in Python) and ``ArrayControl`` (numpy over the robots) are run
one period each from copies of the very same world state, period after period of a crowded run
and of the hard cases; whole short runs through each give the same poses and commands; the
scalar speed caps toward obstacles equal the array ones."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from sim.scenario import DriveSpec, OrcaSpec
from sim.scenario.spatial import TrafficSpec
from sim.spatial.control import (
    ArrayControl,
    ControlParts,
    ScalarControl,
)
from sim.spatial.controller import DiffDriveController
from sim.spatial.fleet import FleetState
from sim.spatial.jobs import Jobs
from sim.spatial.world import PymunkWorld
from sim.states import WORKING
from sim.tasks import Batch
from tests.worlds import crowd_scenario, scenario, send


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


@pytest.mark.parametrize("avoidance", ["none", "orca", "orca-everywhere", "orca-nearest"])
def test_both_controls_command_the_same_wheels_from_the_same_state(avoidance):
    """Period after period of a crowded run, both implementations get a copy of the same state
    and must command the same wheels, see the same robot in the way and start the same work;
    with ORCA too (its commands, the turn-first wheel limit, site queues: by default its
    right-hand bias in meetings and a wall line per obstacle edge in reach; also with the bias
    everywhere, and with the nearest obstacle point alone)."""
    sc = crowd_scenario(avoidance.split("-")[0])
    more = {"everywhere": OrcaSpec(bias_meet_deg=180.0), "nearest": OrcaSpec(wall_lines=1)}
    orca = more.get(avoidance.split("-")[-1])
    if orca is not None:
        sc = dataclasses.replace(sc, spatial=dataclasses.replace(sc.spatial, orca=orca))
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
    assert world.control.parts.orca.wall_lines == (1 if avoidance.endswith("nearest") else 4)
    assert sorted(c.task_id for c in done if c.ok) == [0, 1, 2]  # arrivals and ends of work


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


@pytest.mark.slow
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
    made to back off blind at 3 s (``Jobs.recover``, as at a stuck timeout with no way round;
    the traffic rules off, which would hold it before the corridor) and replans after it;
    without avoidance the array period looks for robots touching one at the site among
    neighbour pairs (``dense_max`` set below the team, as beyond 64 robots).
    Each case must show what it is there for."""
    from scenarios.experiments.hardcases import CASES

    kw = {} if drive is None else {"drive": drive}
    if case == "corridor":
        kw["settings"] = {"traffic": TrafficSpec(rules="off")}
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


R = DriveSpec().radius_m


def test_small_team_and_array_control_periods_agree():
    """The scalar twin computes the same commands as the array code (up to rounding)."""
    starts = [(2.0, 2.0), (2.0, 8.0), (18.0, 5.0), (9.0, 1.0)]
    sites = [(17.0, 3.0), (10.0, 9.0), (4.0, 5.5), (9.5, 6.0)]
    box = (((8.0, 3.5), (11.0, 3.5), (11.0, 4.5), (8.0, 4.5)),)
    runs = []
    for control in ("scalar", "array"):
        world = PymunkWorld(scenario(starts, box, sites=sites), control=control)
        assert world.control_kind == control == world.control.name
        send(world, [0, 1, 2, 3], sites)
        done = world.advance(14.0)
        runs.append((world.poses()[0], sorted((c.task_id, c.ok) for c in done)))
    assert runs[0][1] == runs[1][1] and len(runs[0][1]) == 4
    assert np.abs(runs[0][0] - runs[1][0]).max() < 1e-6


def test_both_control_periods_agree_in_a_crowd_with_caps_and_keep_right():
    """A head-on pair passing beside an obstacle and between standing robots, and a crossing
    robot: the scalar and the array control period command the same wheels every period; the
    robots come within keep-right distance, so the proximity caps and keep-right act."""
    starts = [(4.5, 5.0), (19.0, 5.0), (9.0, 6.0), (9.0, 3.3), (6.0, 1.5), (13.0, 8.5)]
    sites = [(18.0, 5.0), (2.0, 5.0), (9.0, 6.0), (9.0, 3.3), (16.0, 8.0), (13.0, 8.5)]
    box = (((11.5, 5.6), (13.0, 5.6), (13.0, 7.2), (11.5, 7.2)),)
    logs = []
    for control in ("scalar", "array"):
        world = PymunkWorld(scenario(starts, box, sites=sites), control=control)
        send(world, [0, 1, 4], [sites[0], sites[1], sites[4]])
        log = []
        for _ in range(60):  # 6 s, one control period at a time
            world.advance(0.1)
            f = world.fleet
            log.append((f.v_cmd_mps.copy(), f.q_cmd_mps.copy(), f.near_m.copy()))
        logs.append(log)
    for (v0, q0, n0), (v1, q1, n1) in zip(*logs, strict=True):
        np.testing.assert_allclose(v0, v1, rtol=0, atol=1e-9)
        np.testing.assert_allclose(q0, q1, rtol=0, atol=1e-9)
        np.testing.assert_allclose(n0, n1, rtol=0, atol=1e-9)
    near = np.array([n for _, _, n in logs[0]])
    assert near.min() < DiffDriveController(DriveSpec(), 0.1).keep_right_m


def test_obstacle_caps_in_python_equal_the_array_version():
    """Robots off their path near obstacles and walls, driving or backing at any heading: the
    scalar speed cap toward the nearest obstacle equals ``DiffDriveController.wall_cap``."""
    box = (((5.0, 1.0), (7.0, 1.0), (7.0, 3.0), (5.0, 3.0)),)
    scalar = PymunkWorld(scenario([(1.0, 1.0)], box), control="scalar").control
    array = PymunkWorld(scenario([(1.0, 1.0)], box), control="array").control
    rng = np.random.default_rng(5)
    z = rng.uniform((4.2, 0.3), (7.8, 3.8), size=(3000, 2))  # around the box, near the wall
    z = z[(np.abs(z[:, 0] - 6.0) > 1.0 + R) | (np.abs(z[:, 1] - 2.0) > 1.0 + R)][:300]
    z = z @ np.array([1, 1j])
    h = np.exp(1j * rng.uniform(-np.pi, np.pi, 300))
    v = rng.uniform(-1.5, 1.5, 300)
    v[::7] = 0.0
    ours = v.tolist()
    scalar.obstacle_caps(z.tolist(), h.tolist(), ours, list(range(300)))
    theirs = v.copy()
    array.obstacle_caps(z, h.conj(), theirs, np.arange(300))
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12)
    assert (np.abs(theirs) < np.abs(v) - 0.1).sum() > 20  # many were capped
