"""The classic hard cases of multi-robot motion, as small pymunk worlds to run and render.

Each case sends robots straight to goals of their own (one task type per robot, given at once,
no allocation) and measures how long until the last one has arrived, the contacts begun and the
closest two robot centres came:

- ``circle``: n robots on a 5 m circle swap to the antipodal points (the reference of the
  collision-avoidance issue: IR-SIM 2.12's RVO example, robots of radius 0.25 m, 1 m/s top
  speed, 60 Hz physics, brings 10 robots across in 17.8 s and 20 in 23.1 s without a contact).
- ``junction``: four robots 4 m from a crossing drive through it to the opposite arm.
- ``corridor``: two robots swap ends of a 4 m corridor 1.5 robot diameters wide (0.75 m).
- ``parked``: one robot drives a 10 m lane past a row of n robots at work beside it.
- ``site``: n robots on an 8 m circle are all sent to its centre, 2 s of work each (the site's
  queue lets them in as places free up).

The robots are the issue's: radius 0.25 m, 1 m/s top speed (``ONE_MPS``), arrival within 0.1 m.
``mrta hardcase`` runs them from the command line and draws a GIF.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim.recording import TrajectoryRecorder
from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.spatial.world import PymunkWorld
from sim.states import DRIVING, WORKING
from sim.tasks import Batch

LOOK_AHEAD_DEFAULT = SpatialSpec.__dataclass_fields__["look_ahead"].default

ONE_MPS = DriveSpec(max_wheel_speed_radps=12.5)  # 0.08 m wheels: 1 m/s top speed, radius 0.25 m
SITE_WORK_S = 2.0  # work per robot in the ``site`` case, s


def swap_world(
    starts,
    goals,
    size_m,
    control="auto",
    avoidance="orca",
    obstacles=(),
    headings_deg=None,
    drive: DriveSpec = ONE_MPS,
    look_ahead: str = LOOK_AHEAD_DEFAULT,
    check_layout: bool = True,
    settings: dict | None = None,
) -> PymunkWorld:
    """Robots at ``starts`` (m, 2), facing ``headings_deg`` (default +x), each sent at once to
    its own goal (one task type per robot, 1000 s of work: it stays there), in a ``size_m``
    arena with ``obstacles``, driving as ``drive``, with ``[spatial] look_ahead`` as given
    (``check_layout``: as :class:`sim.spatial.world.PymunkWorld`; ``settings``: more
    :class:`sim.scenario.SpatialSpec` fields, e.g. ``{"jams": JamSpec(pass_s=5.0)}``)."""
    n = len(starts)
    sp = SpatialSpec(
        size_m[0],
        size_m[1],
        tuple(obstacles),
        tuple((tuple(map(float, g)),) for g in goals),
        drive,
        arrive_tol_m=0.1,
        avoidance=avoidance,
        look_ahead=look_ahead,
        **(settings or {}),
    )
    heads = [0.0] * n if headings_deg is None else [float(a) for a in headings_deg]
    robots = tuple(
        RobotSpec(f"R{k}", (k,), tuple(map(float, starts[k])), heads[k]) for k in range(n)
    )
    types = tuple(f"T{k}" for k in range(n))
    sc = Scenario("swap", types, robots, ((1.0,) * n,) * n, (1000.0,) * n, spatial=sp)
    world = PymunkWorld(sc, control=control, check_layout=check_layout)
    world.reset(np.random.default_rng(0))
    batch = Batch(0, 0, np.arange(n), np.arange(n), np.zeros(n, bool), np.asarray(goals, float))
    world.apply(batch, np.arange(n), np.ones(n))
    return world


def time_to_all_arrive(world: PymunkWorld, limit_s: float, done=None, on_tick=None) -> float:
    """Simulated time at which every robot has arrived (no robot drives), or ``done(world)``
    holds, looked at every 0.1 s; inf if not within ``limit_s``. ``on_tick(world)`` runs after
    every 0.1 s."""
    done = done or (lambda w: not (w.fleet.state == DRIVING).any())
    while world.time_s < limit_s:
        world.advance(0.1)
        if on_tick is not None:
            on_tick(world)
        if done(world):
            return world.time_s
    return math.inf


def circle(n: int, radius_m: float = 5.0, centre=(7.0, 7.0)):
    """Starts of n robots evenly on a circle and their antipodal goals, (n, 2) each."""
    angle = 2.0 * math.pi * np.arange(n) / n
    starts = np.column_stack([np.cos(angle), np.sin(angle)]) * radius_m + centre
    return starts, 2.0 * np.asarray(centre) - starts


@dataclass(frozen=True)
class Case:
    """One hard case: its robot count (default, least, most) and how to build it."""

    about: str
    robots: int
    least: int
    most: int
    limit_s: float
    build: Callable  # (n, control, avoidance, nudge, look_ahead=) -> (world, done(world) or None)


def _circle(n, control, avoidance, nudge, **kw):
    starts, goals = circle(n)
    return swap_world(nudge(starts), goals, (14.0, 14.0), control, avoidance, **kw), None


def _junction(n, control, avoidance, nudge, **kw):
    c = np.array([6.0, 6.0])
    starts = c + np.array([[4.0, 0.0], [0.0, 4.0], [-4.0, 0.0], [0.0, -4.0]])
    return swap_world(nudge(starts), 2.0 * c - starts, (12.0, 12.0), control, avoidance, **kw), None


def _corridor(n, control, avoidance, nudge, **kw):
    half = 0.375
    walls = (
        ((4.0, 0.0), (8.0, 0.0), (8.0, 3.0 - half), (4.0, 3.0 - half)),
        ((4.0, 3.0 + half), (8.0, 3.0 + half), (8.0, 6.0), (4.0, 6.0)),
    )
    starts, goals = [(3.5, 3.0), (8.5, 3.0)], [(9.5, 3.0), (2.5, 3.0)]
    return swap_world(nudge(starts), goals, (12.0, 6.0), control, avoidance, walls, **kw), None


def _parked(n, control, avoidance, nudge, **kw):
    parked = [(3.0 + 0.7 * k, 3.6) for k in range(n - 1)]
    starts, goals = [(1.0, 3.0), *parked], [(3.0 + 0.7 * (n - 1) + 1.0, 3.0), *parked]
    width = goals[0][0] + 1.0
    return swap_world(nudge(starts), goals, (width, 6.0), control, avoidance, **kw), None


def _site(n, control, avoidance, nudge, **kw):
    centre = (10.0, 10.0)
    starts, _ = circle(n, 8.0, centre)
    world = swap_world(nudge(starts), [centre] * n, (20.0, 20.0), control, avoidance, **kw)
    world.jobs.exec_time_s[:] = SITE_WORK_S
    worked = np.zeros(n, dtype=bool)

    def done(w) -> bool:
        worked[w.fleet.state == WORKING] = True
        return bool(worked.all() and not (w.fleet.state == DRIVING).any())

    return world, done


CASES = {
    "circle": Case("n robots on a 5 m circle swap to antipodal points", 20, 2, 50, 60.0, _circle),
    "junction": Case("four robots cross at a junction", 4, 4, 4, 60.0, _junction),
    "corridor": Case("two robots swap ends of a corridor 0.75 m wide", 2, 2, 2, 120.0, _corridor),
    "parked": Case("a robot passes a row of n - 1 parked robots", 11, 2, 40, 60.0, _parked),
    "site": Case("n robots sent to one site, 2 s of work each", 30, 1, 60, 300.0, _site),
}


def run_case(
    name: str,
    robots: int | None = None,
    control: str = "auto",
    avoidance: str = "orca",
    limit_s: float | None = None,
    recorder: bool = False,
    on_tick=None,
    jitter_m: float = 0.0,
    seed: int = 0,
    look_ahead: str = LOOK_AHEAD_DEFAULT,
    settings: dict | None = None,
) -> dict:
    """Run hard case ``name`` with ``robots`` robots (the case's default if None),
    ``[spatial] look_ahead`` as given and ``settings`` (more :class:`sim.scenario.SpatialSpec`
    fields, e.g. ``{"jams": JamSpec(pass_s=5.0)}``; default: the bundled scenarios').

    ``jitter_m`` > 0 moves every start by a normal draw of that standard deviation (m, per
    coordinate, from ``numpy.random.default_rng(seed)``): the crowd cases are chaotic, and
    whether a run touches must not hang on the exact start (``mrta hardcase --jitter``).

    Returns:
        ``{"case", "robots", "avoidance", "look_ahead", "traffic" (the traffic rules "on" or
        "off" in this world), "control", "time_s" (inf: not all
        arrived within ``limit_s``), "still_driving", "robot_touch", "robot_impact", "wall_touch",
        "wall_impact", "closest_m" (closest two centres, sampled every 0.1 s), "failed",
        "jitter_m", "seed"}``,
        and ``"trajectory"`` (a ``sim.recording.Trajectory``) when ``recorder`` is set.

    Raises:
        ValueError: an unknown case or a robot count outside the case's range.
    """
    if name not in CASES:
        raise ValueError(f"unknown hard case {name!r}; choose from {', '.join(CASES)}")
    case = CASES[name]
    n = case.robots if robots is None else int(robots)
    if not case.least <= n <= case.most:
        fixed = case.least == case.most
        span = f"exactly {case.least}" if fixed else f"{case.least} to {case.most}"
        raise ValueError(f"hard case {name} takes {span} robots, got {n}")
    if not (math.isfinite(jitter_m) and jitter_m >= 0.0):
        raise ValueError(f"jitter must be a finite number >= 0 m, got {jitter_m}")
    rng = np.random.default_rng(seed)

    def nudge(starts):
        if jitter_m == 0.0:
            return starts
        starts = np.asarray(starts, dtype=float)
        return starts + rng.normal(0.0, jitter_m, starts.shape)

    world, done = case.build(n, control, avoidance, nudge, look_ahead=look_ahead, settings=settings)
    rec = None
    if recorder:
        sp = world.spatial
        names = [f"R{k}" for k in range(n)]
        rec = TrajectoryRecorder(
            (sp.width_m, sp.height_m), sp.obstacles, [f"T{k}" for k in range(n)], names
        )
        ids = np.arange(n)
        goals = np.array([per_type[0] for per_type in sp.sites], dtype=float)
        rec.announce(0.0, ids, ids, np.zeros(n, bool), goals)
        rec.allocate(0.0, ids, ids)
        rec.poses(0.0, world.poses()[0], world.poses()[1], world.fleet.state)
        world.recorder = rec
    closest = [math.inf]

    def tick(w) -> None:
        z = w.fleet.last_z_m
        d = np.abs(z[:, None] - z[None, :])
        d[np.diag_indices(len(z))] = np.inf
        closest[0] = min(closest[0], float(d.min()))
        if on_tick is not None:
            on_tick(w)

    t = time_to_all_arrive(world, case.limit_s if limit_s is None else limit_s, done, tick)
    if rec is not None:
        for k in range(n):  # every robot's task ends with the run (its work is not shown)
            rec.done(k, world.time_s)
    c = world.contacts
    out = {
        "case": name,
        "robots": n,
        "avoidance": avoidance,
        "look_ahead": look_ahead,
        "traffic": "on" if world.jobs.traffic is not None else "off",
        "control": world.control_kind,
        "time_s": t,
        "still_driving": int((world.fleet.state == DRIVING).sum()),
        "robot_touch": c.robot_hits - c.robot_impacts,
        "robot_impact": c.robot_impacts,
        "wall_touch": c.wall_hits - c.wall_impacts,
        "wall_impact": c.wall_impacts,
        "closest_m": closest[0],
        "failed": world.jobs.failures,
        "jitter_m": jitter_m,
        "seed": seed,
    }
    if rec is not None:
        out["trajectory"] = rec.finish()
    return out
