"""Speed of the pymunk world: our whole loop in the units users pay, and against fixed physics.

For each size a synthetic arena is built (about 13 m^2 per robot, one box obstacle per ten
robots, task sites scattered in the free space). The robots are kept busy: every ``ROUND_S``
(10 s, the paper's announcement interval) as many tasks as there are free robots are announced
at random sites and auctioned (``mrta bench`` passes the market auction), so the measured loop is
allocation, physics, control, planning, task bookkeeping, contact sampling and recording. It is
reported as the real-time factor, as wall seconds per simulated robot-hour, and in steps of a
calibration space (``scenarios.bench.calibration``: the same contact-free space of as many robots
in every run), timed in the same process. The bare loop then steps the very same space (same
bodies, joints and contacts) with nothing around it (``bare_ratio``; its cost moves with the
world's contacts, which is why the calibration space is the yardstick).

The space sets its solver iterations by the contacts (``sim.spatial.contacts``: one iteration while
no contact touches, which is exact then, ten while one does), and the bare loop steps it as it is,
with ``Space.step``. For comparison with a space left at pymunk's defaults, the bare loop is timed
once more with ten iterations throughout (``bare10_steps_per_s``), and ``contact_share`` is the
share of the loop's physics steps that ended with a contact touching.
"""

from __future__ import annotations

import contextlib
import time

import numpy as np

from scenarios.bench.arena import bench_scenario
from scenarios.bench.calibration import calibration_step_s
from sim.recording import TrajectoryRecorder
from sim.spatial.world import PymunkWorld
from sim.tasks import Batch

DEFAULT_SIM_S = {10: 600.0, 100: 120.0, 1000: 30.0}  # a second or two of wall time each
ROUND_S = 10.0  # with an allocator: a round of announcements and an auction this often


def _run(
    world: PymunkWorld,
    sim_s: float,
    rng: np.random.Generator,
    allocate=None,
    clock=time.perf_counter,
) -> tuple[int, float]:
    """Keep the robots busy for ``sim_s`` simulated seconds; (physics steps, wall seconds by
    ``clock``).

    Without ``allocate`` every simulated second each free robot is sent to a random site.
    With it, rounds come every ``ROUND_S`` as in the task protocol: as many tasks as there
    are free robots are announced at random sites and ``allocate(batch) -> (assignment,
    bids)`` (the market auction in ``mrta bench``) hands them out."""
    sites = np.asarray(world.spatial.sites[0], dtype=float)
    next_id = 0
    steps0 = world.steps_
    wall0 = clock()
    step_s = 1.0 if allocate is None else ROUND_S
    while world.time_s < sim_s - 1e-9:
        free = np.flatnonzero(world.task_ < 0)
        if free.size:
            ids = np.arange(next_id, next_id + free.size)
            next_id += free.size
            pick = sites[rng.integers(0, len(sites), size=free.size)]
            batch = Batch(0, 0, ids, np.zeros(free.size, int), np.zeros(free.size, bool), pick)
            if allocate is None:
                world.apply(batch, free, np.zeros(free.size))
            else:
                assignment, bids = allocate(batch)
                won = np.maximum(assignment, 0)
                world.apply(batch, assignment, bids[won, np.arange(free.size)])
        world.advance(min(step_s, sim_s - world.time_s))
    return world.steps_ - steps0, clock() - wall0


def bench_sim(
    sizes: tuple[int, ...] = (10, 100, 1000),
    sim_seconds: float | dict[int, float] | None = None,
    seed: int = 0,
    control_hz: float = 10.0,
    allocator=None,
    avoidance: str = "none",
    control: str = "auto",
    traffic: str = "on",
    timed: bool = True,
    clock=time.perf_counter,
) -> dict[str, dict[str, float]]:
    """Measure the pymunk world's speed for each robot count.

    Args:
        sizes: robot counts.
        sim_seconds: simulated seconds per size (one number for all, a dict, or None for
            ``DEFAULT_SIM_S``).
        seed: each size's arena, task sites and tasks come from ``default_rng([seed, n])``
            (the same for every ``avoidance`` and ``traffic``, whatever ran before), the
            figures' samples (:func:`replan_report`, :func:`field_report`, :func:`_bids_ms`)
            from ``default_rng([seed, n, 1])``.
        control_hz: control rate (physics runs at 60 Hz).
        allocator: ``allocator(scenario, world)`` returns the ``allocate(batch)`` callable of
            :func:`_run` (the auction), or None to hand tasks out in order.
        avoidance: ``[spatial] avoidance`` of the arenas, "none" or "orca".
        traffic: their ``[spatial.traffic] rules`` (with avoidance on), "on" or "off".
        control: the world's control period (``PymunkWorld``'s ``control``).
        timed: time the parts of the loop (:func:`timed_parts` and the others) while it runs;
            False leaves the loop as users run it (the timers' keys are then absent).
        clock: the loop's wall clock (seconds; ``Relay.clock`` when loops take turns,
            ``scenarios.bench.relay``).

    Returns:
        ``{str(n): {"steps_per_s", "rtf", "s_per_robot_h", "calib_ratio", "calib_step_us",
        "sim_s", "wall_s", "bare_ratio", "bare_steps_per_s",
        "bare10_steps_per_s", "contact_share", "bids_ms", "avoid_share", "avoid_bare_ratio",
        "sites_share", "sites_bare_ratio", "control_share", "control_calib_ratio",
        "physics_calib_ratio", "parts_s", ...}}``: physics
        steps of the full loop per wall second, simulated / wall seconds, full-loop time per step
        over bare ``space.step`` time per step, the bare loop's steps per second (as the world sets
        the space, and with ten solver iterations throughout); wall seconds per simulated
        robot-hour, the loop's time per step in calibration steps (:func:`calibration_step_s` of n
        robots) and that step's time; the simulated and wall seconds of the timed loop;
        the share of loop steps with a contact touching, and the milliseconds the
        planned-distance bids of every robot on 7 tasks take (:func:`_bids_ms`); the share of
        the loop's time spent in collision avoidance (``sim.spatial.law.orca``) and that time per
        step over the bare step, and the same for the site work only avoidance brings
        (:func:`timed_sites`; avoidance inside the compiled control period is not timed
        apart: 0 there); the share of the loop's time in the control period as a whole
        (:func:`timed_period`: steering, avoidance, drive law, wheel limits) and that time per
        physics step in calibration steps; the loop's own physics steps in calibration steps
        (:func:`timed_physics`); the wall seconds of each part of the control periods
        (:func:`timed_parts`) and of the physics steps (``parts_s["physics"]``). If
        ``allocate`` keeps ``timings_`` (``bids_s``, ``auction_s``, ``rounds``), the timed
        rounds' ``round_bids_ms`` and ``round_auction_ms``;
        with avoidance, :func:`replan_report`; if the planner built its distance field,
        :func:`field_report`.
    """
    out = {}
    for n in sizes:
        rng, sample = np.random.default_rng([seed, n]), np.random.default_rng([seed, n, 1])
        if sim_seconds is None:
            sim_s = DEFAULT_SIM_S.get(n, max(10.0, 12000.0 / n))
        else:
            sim_s = sim_seconds[n] if isinstance(sim_seconds, dict) else float(sim_seconds)
        scenario = bench_scenario(
            n, rng, control_hz=control_hz, avoidance=avoidance, traffic=traffic
        )
        world = PymunkWorld(scenario, control=control)
        sp = scenario.spatial
        world.recorder = TrajectoryRecorder(
            (sp.width_m, sp.height_m),
            sp.obstacles,
            scenario.task_types,
            [r.name for r in scenario.robots],
        )
        world.reset(rng)
        allocate = None if allocator is None else allocator(scenario, world)
        warm_s = 2.0 if allocator is None else ROUND_S + 2.0  # first paths, distance fields
        _run(world, min(warm_s, sim_s), rng, allocate)
        touching0 = world.contacts.steps_touching
        counts0 = dict(getattr(allocate, "timings_", {}))
        with loop_timers(type(world.control), timed) as timers:
            steps, wall = _run(world, world.time_s + sim_s, rng, allocate, clock)
        counts = {k: v - counts0.get(k, 0) for k, v in getattr(allocate, "timings_", {}).items()}
        share = (world.contacts.steps_touching - touching0) / steps
        bare = bare_step_time(world, max(60, steps // 4))
        free = world.contacts.free_iterations
        try:  # the same with pymunk's default solver iterations throughout
            world.contacts.free_iterations = world.space.iterations = 10
            bare10 = bare_step_time(world, max(60, steps // 4))
        finally:
            world.contacts.free_iterations = free
        bids_ms = _bids_ms(world, sample)
        calib = calibration_step_s(n, max(60, min(steps // 4, 600)))
        out[str(n)] = {
            "steps_per_s": steps / wall,
            "rtf": steps * world.dt_s / wall,
            "s_per_robot_h": wall / (n * steps * world.dt_s / 3600.0),
            "calib_ratio": (wall / steps) / calib,
            "calib_step_us": 1e6 * calib,
            "sim_s": steps * world.dt_s,
            "wall_s": wall,
            "bare_ratio": (wall / steps) / bare,
            "bare_steps_per_s": 1.0 / bare,
            "bare10_steps_per_s": 1.0 / bare10,
            "contact_share": share,
            "bids_ms": bids_ms,
            **timer_figures(timers, wall, steps, bare, calib),
        }
        if counts.get("rounds"):
            rounds = counts["rounds"]
            out[str(n)]["rounds"] = rounds
            out[str(n)]["round_bids_ms"] = 1e3 * counts["bids_s"] / rounds
            out[str(n)]["round_auction_ms"] = 1e3 * counts["auction_s"] / rounds
        if avoidance != "none":
            out[str(n)].update(replan_report(world, sample))
        if world.planner.field_ is not None:
            out[str(n)].update(field_report(world.planner, world.poses()[0], sample))
    return out


def replan_report(world: PymunkWorld, rng: np.random.Generator, calls: int = 20) -> dict:
    """What the jam rule's re-plan round robots costs (``GridPlanner.path_around``): mean ms
    of ``calls`` re-plans, each of a random robot to a random task site round the robots
    within ``[spatial.jams] around_m`` of it, as the rule builds them (``replan_ms``: the arena's
    visibility and grown obstacles reused) and with the whole graph built afresh
    (``replan_fresh_ms``), the same calls in the same run."""
    z = world.fleet.last_z_m
    sites = np.asarray(world.spatial.sites[0], dtype=float)
    radius = world.spatial.drive.radius_m
    jobs = []
    for j in rng.integers(0, len(z), size=calls).tolist():
        close = np.abs(z - z[j]) < world.spatial.jams.around_m
        close[j] = False
        site = sites[rng.integers(0, len(sites))]
        jobs.append(((z[j].real, z[j].imag), tuple(site), z[close]))
    out = {}
    for key, reuse in (("replan_ms", True), ("replan_fresh_ms", False)):
        t0 = time.perf_counter()
        for start, site, robots in jobs:
            world.planner.path_around(start, site, robots, radius, reuse=reuse)
        out[key] = 1e3 * (time.perf_counter() - t0) / calls
    return out


def field_report(planner, xy: np.ndarray, rng: np.random.Generator, repeat: int = 5) -> dict:
    """What the planner's distance field cost and what it buys, for robots at ``xy``.

    Returns:
        ``field_build_s`` (and its ``field_fields_s``, ``field_raster_s``, ``field_refine_s``
        parts), ``field_mib`` (held), ``field_mixed_share`` (cell-site pairs left to an exact
        test); best of ``repeat`` ms of ``GridPlanner.distances`` for every robot to all the
        field's sites (``dist_all_ms``) and to 50 of them (``dist_50_ms``), numpy straight lines
        for the same (``straight_all_ms``, ``straight_50_ms``); and the largest difference
        (m) from the planner's exact query over 50 robots x all sites (``field_max_err_m``).
    """
    field = planner.field()
    sites = field.sites
    some = sites[np.sort(rng.choice(len(sites), size=min(50, len(sites)), replace=False))]
    z = xy @ np.array([1.0, 1j])

    def best(fn) -> float:
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return 1e3 * min(times)

    def straight(pts):
        zs = pts @ np.array([1.0, 1j])
        return lambda: np.abs(z[:, None] - zs[None, :])

    sample = xy[np.sort(rng.choice(len(xy), size=min(50, len(xy)), replace=False))]
    fast = field.distances(sample, field.columns(sites))
    exact = planner.exact_distances(sample, sites)
    both = np.isfinite(exact) & np.isfinite(fast)
    err = np.abs(fast - exact)[both].max(initial=0.0)
    if (np.isfinite(exact) != np.isfinite(fast)).any():
        err = np.inf
    return {
        "field_build_s": field.build_s_,
        **{f"field_{k}": v for k, v in field.timings_.items()},
        "field_mib": field.nbytes / 2**20,
        "field_mixed_share": float((field.table_ >= field.mixed_code_).mean()),
        "dist_all_ms": best(lambda: planner.distances(xy, sites)),
        "dist_50_ms": best(lambda: planner.distances(xy, some)),
        "straight_all_ms": best(straight(sites)),
        "straight_50_ms": best(straight(some)),
        "field_max_err_m": float(err),
    }


def _bids_ms(world: PymunkWorld, rng: np.random.Generator, tasks: int = 7) -> float:
    """Milliseconds for the planned-distance bids of every robot on ``tasks`` random sites
    (``GridPlanner.distances``, what the ``distance`` cost model does each round); best of 3."""
    sites = np.asarray(world.spatial.sites[0], dtype=float)
    pick = sites[rng.integers(0, len(sites), size=tasks)]
    xy, _ = world.poses()
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        world.planner.distances(xy, pick)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def bare_step_time(world: PymunkWorld, n: int) -> float:
    """Seconds per bare ``space.step`` over ``n`` steps of the world's space."""
    step, dt = world.space.step, world.dt_s
    t0 = time.perf_counter()
    for _ in range(n):
        step(dt)
    return (time.perf_counter() - t0) / n


if __name__ == "__main__":
    for size, row in bench_sim().items():
        print(size, {k: round(v, 2) for k, v in row.items()})


@contextlib.contextmanager
def loop_timers(control: type, timed: bool = True):
    """The bench's timers round a loop (:func:`timed_avoidance`, :func:`timed_sites`,
    :func:`timed_period`, :func:`timed_parts`, :func:`timed_physics`), or none with ``timed``
    False. Yields ``(avoid_s, sites_s, control_s, parts_s, physics_s)``, or None untimed. The
    timers cost the loop with avoidance more than the loop without (more of its calls are
    timed), so the price of avoidance is measured untimed
    (:func:`scenarios.bench.run.bench_sim_part`)."""
    if not timed:
        yield None
        return
    with (
        timed_avoidance() as avoid_s,
        timed_sites() as sites_s,
        timed_period(control) as control_s,
        timed_parts(control) as parts_s,
        timed_physics() as physics_s,
    ):
        yield avoid_s, sites_s, control_s, parts_s, physics_s


def timer_figures(timers, wall: float, steps: int, bare: float, calib: float) -> dict:
    """The figures of :func:`loop_timers` after a loop of ``wall`` seconds and ``steps``
    physics steps (``bare``, ``calib``: a bare and a calibration step, s); none untimed."""
    if timers is None:
        return {}
    avoid_s, sites_s, control_s, parts_s, physics_s = timers
    return {
        "avoid_share": avoid_s[0] / wall,
        "avoid_bare_ratio": (avoid_s[0] / steps) / bare,
        "sites_share": sites_s[0] / wall,
        "sites_bare_ratio": (sites_s[0] / steps) / bare,
        "control_share": control_s[0] / wall,
        "control_calib_ratio": (control_s[0] / steps) / calib,
        "physics_calib_ratio": (physics_s[0] / steps) / calib,
        "parts_s": {**parts_s, "physics": physics_s[0]},
    }


@contextlib.contextmanager
def timed_physics():
    """Time the loop's own physics steps (``ContactMonitor.run``: chipmunk's step with the
    solver iterations the contacts set, and the overlap reads after a step with a contact)
    while the block runs, in every world; yields a one-item list whose entry is the wall
    seconds spent in them so far. Unlike the bare loop's steps, these are the steps the loop
    took, under the commands it gave."""
    from sim.spatial.contacts import ContactMonitor

    with _timing(ContactMonitor, "run") as spent:
        yield spent


@contextlib.contextmanager
def timed_avoidance():
    """Time every collision-avoidance call of both control periods while the block runs
    (``sim.spatial.control.avoidance.steer_clear`` among robots and ``wall_clear`` toward walls, as
    the two periods hold them); yields a one-item list whose entry is the wall seconds spent
    in them so far."""
    import sim.spatial.control.array as array_period
    import sim.spatial.control.scalar as scalar_period

    spent = [0.0]

    def timer(inner):
        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                spent[0] += time.perf_counter() - t0

        return timed

    names = ("steer_clear", "wall_clear")
    inners = [getattr(array_period, name) for name in names]
    for name, inner in zip(names, inners, strict=True):
        setattr(array_period, name, timer(inner))
        setattr(scalar_period, name, getattr(array_period, name))
    try:
        yield spent
    finally:
        for name, inner in zip(names, inners, strict=True):
            setattr(array_period, name, inner)
            setattr(scalar_period, name, inner)


@contextlib.contextmanager
def timed_period(kind: type):
    """Time every call of ``kind.period`` (a control period class: the whole period, steering,
    collision avoidance, drive law, wheel limits) while the block runs, in every world built
    meanwhile; yields a one-item list whose entry is the wall seconds spent in it so far."""
    with _timing(kind, "period") as spent:
        yield spent


@contextlib.contextmanager
def _timing(cls: type, name: str):
    """Time every call of the method ``cls.name`` while the block runs, in every instance;
    yields a one-item list whose entry is the wall seconds spent in it so far. The class's
    own method is put back after the block."""
    spent = [0.0]
    inner = cls.__dict__[name]

    def timed(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t0

    setattr(cls, name, timed)
    try:
        yield spent
    finally:
        setattr(cls, name, inner)


# :func:`timed_parts`, then :func:`timed_physics`: the parts of the loop reported apart
TIMED_PARTS = ("control", "traffic", "jams", "sites", "physics")
JAM_RULES = ("look_ahead", "standing_near", "pass_workers", "break_jams")


def world_rules() -> tuple:
    """The parts of a control period beside the control period itself: (part, class, method
    names)."""
    from sim.spatial.jams import Jams
    from sim.spatial.sites import Sites
    from sim.spatial.traffic.rules import Traffic

    return (
        ("traffic", Traffic, ("period",)),
        ("jams", Jams, JAM_RULES),
        ("sites", Sites, ("queue", "take_slots", "leave")),
    )


@contextlib.contextmanager
def timed_parts(control: type, rules: tuple | None = None):
    """Time a control period's parts while the block runs, each without the parts it calls
    (the site work the control period's end of work does counts as site work, not as control):
    ``control`` (``control.period``: steering, ORCA, the drive law, the wheel limits, the
    events between its stages), ``traffic`` (the traffic rules, ``Traffic.period``), ``jams``
    (look-ahead and the jam rules: ``Jams.look_ahead``, ``standing_near``, ``pass_workers``,
    ``break_jams``) and ``sites`` (site queues, service slots, leaving a site:
    ``Sites.queue``, ``take_slots``, ``leave``). ``rules``: (part, class, method names) for the
    parts other than ``control`` (default :func:`world_rules`). Yields ``{part: wall seconds
    so far}``; the classes are restored after the block."""
    rules = world_rules() if rules is None else rules
    spent = dict.fromkeys([part for part, *_ in rules], 0.0)
    spent["control"] = 0.0
    stack: list[list[float]] = []  # the time of the parts each open call called, s

    def timer(part, inner):
        def timed(*args, **kwargs):
            inside = [0.0]
            stack.append(inside)
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                took = time.perf_counter() - t0
                stack.pop()
                spent[part] += took - inside[0]
                if stack:
                    stack[-1][0] += took

        return timed

    methods = [("control", control, "period")]
    for part, cls, names in rules:
        methods += [(part, cls, method) for method in names]
    inners = [cls.__dict__[method] for _, cls, method in methods]
    for (part, cls, method), inner in zip(methods, inners, strict=True):
        setattr(cls, method, timer(part, inner))
    try:
        yield spent
    finally:
        for (_, cls, method), inner in zip(methods, inners, strict=True):
            setattr(cls, method, inner)


@contextlib.contextmanager
def timed_sites():
    """Time the site work that exists only with collision avoidance on (site queues, service
    slots, robots driving clear of a service point: ``sim.spatial.sites.Sites.queue``,
    ``take_slots``, ``leave``; going round robots at work and jams seen at once:
    ``sim.spatial.jams.Jams.pass_workers``, ``break_jams``) while the block runs; yields a one-item
    list whose entry is the wall seconds spent in them so far (a call inside another timed one is
    counted once)."""
    from sim.spatial.jams import Jams
    from sim.spatial.sites import Sites

    spent, depth = [0.0], [0]
    methods = [(Sites, name) for name in ("queue", "take_slots", "leave")]
    methods += [(Jams, name) for name in ("pass_workers", "break_jams")]
    inners = [cls.__dict__[name] for cls, name in methods]

    def timer(inner):
        def timed(*args, **kwargs):
            if depth[0]:
                return inner(*args, **kwargs)
            depth[0] += 1
            t0 = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                spent[0] += time.perf_counter() - t0
                depth[0] -= 1

        return timed

    for (cls, name), inner in zip(methods, inners, strict=True):
        setattr(cls, name, timer(inner))
    try:
        yield spent
    finally:
        for (cls, name), inner in zip(methods, inners, strict=True):
            setattr(cls, name, inner)
