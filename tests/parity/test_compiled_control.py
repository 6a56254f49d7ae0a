"""The compiled control period against today's numpy period, on states recorded from real runs.

Each scene is a real run of a bundled scenario (tasks handed to the free robots every second)
whose world runs the numpy period (``ArrayControl``, the reference). At every control period,
before the reference runs, a twin is made: a deep copy of everything a period reads and writes
(fleet, schedule, tasks, sites, jams, paths; the pymunk bodies and the planners shared, the motors
replaced by a recorder of the same read), and the compiled period (``CompiledControl``) runs on
it, events and all. Then the reference runs, and the two are compared robot by robot:

- the wheel commands (v and q = omega b / 2, m/s) within 1e-12, or 1e-9 for q of a robot that
  nearly stands (|v| < 1e-3 m/s: the direction of its velocity, and so its turn, is
  ill-conditioned), except for a robot whose velocity program had no solution: there the compiled
  period keeps the wall lines hard and breaks the robots' lines least (RVO2's linearProgram3),
  a rule of its own (``tests/sim/spatial/control/test_compiled_units.py`` tests it against its
  definition), and its commands are counted, not compared;
- the path left, progress, progress clock, odometer, task states and waypoints within 1e-12;
- the robot in each one's way, except where ORCA's speed for it is a rounding zero (below
  1e-12 m/s either way): the rule keys on that speed's sign (and so does a request to the
  robot in the way to make way, whose waypoints are then not compared).
"""

from __future__ import annotations

import copy

import numpy as np
import pytest

import sim.spatial.control.array as array_period
from scenarios.protocol import load_named
from sim.scenario.overrides import apply_overrides
from sim.spatial.control.array import ArrayControl
from sim.spatial.control.compiled import CompiledControl
from sim.spatial.law import orca as law
from sim.spatial.navigation.paths import PathFollower
from sim.spatial.world import PymunkWorld
from sim.tasks import Batch

# (scenario, avoidance, simulated seconds, more overrides): what avoidance on and off, a
# warehouse's lanes and shelves, a team of a hundred (the numpy period's k-d tree neighbours),
# the right-hand bias in meetings only and a wall line from every obstacle edge in reach exercise
MEETINGS = (("spatial.orca.bias_meet_deg", 30.0), ("spatial.orca.bias_stand_s", 1.0))
EDGES = (("spatial.orca.wall_lines", 4),)
SCENES = (
    ("paper_spatial", "orca", 60.0, ()),
    ("warehouse", "orca", 60.0, ()),
    ("paper_spatial", "none", 40.0, ()),
    ("large", "orca", 10.0, ()),
    ("warehouse", "orca", 30.0, MEETINGS),
    ("warehouse", "orca", 30.0, EDGES),
)
FIELDS = ("left_m", "progress_m", "t_progress_s", "moved_m", "state")


class RecordedMotors:
    """The motors of a twin: the same read as the world's this period, commands recorded."""

    def __init__(self, motors) -> None:
        self.flat = motors.flat.copy()
        self.bodies = motors.bodies
        self.written = None

    def read(self) -> None:
        return None

    def write(self, z, th, h, v, w) -> None:
        self.written = (np.array(v), np.array(w))


def twin_of(world: PymunkWorld):
    """A deep copy of the world's control parts (bodies, space and planners shared, motors
    recorded), and its motors."""
    parts = world.control.parts
    motors = RecordedMotors(parts.motors)
    jobs = parts.jobs
    memo = {id(parts.motors): motors, id(world.space): world.space}
    for shared in [*parts.motors.bodies, jobs.planner, jobs.base_planner]:
        memo[id(shared)] = shared
    for shared in (jobs.sites.planner, jobs.jams.planner):
        memo[id(shared)] = shared
    return copy.deepcopy(parts, memo), motors


class Programs:
    """Which robots' velocity programs had no solution in the numpy law this period, and
    ORCA's speeds (``steer_clear``'s commands before the caps)."""

    def __init__(self, monkeypatch) -> None:
        self.infeasible: set[int] = set()
        self.orca_v: dict[int, float] = {}
        self.rows = np.zeros(0, dtype=int)
        self.biased = [0, 0]  # robot-periods the bias rule let turn, and held straight
        self.walls = [0, 0]  # robot-periods with one obstacle line, and with more
        solve, rows_fn, walls_fn = law.solve, law.steer_rows, law.steer_walls
        meeting, points_fn = law.meeting, PathFollower.obstacle_points
        clear = array_period.steer_clear

        def solve_(normal, offset, pref, v_max):
            u = solve(normal, offset, pref, v_max)
            viol = (offset - (u[:, None] * normal.conj()).real).max(axis=1)
            bad = (viol > 1e-9) | (np.abs(u) > v_max * (1.0 + 1e-9))
            self.infeasible.update(self.rows[bad].tolist())
            return u

        def steer_rows_(z, h, rows, *args, **kw):
            self.rows = np.asarray(rows)
            return rows_fn(z, h, rows, *args, **kw)

        def steer_walls_(z, h, rows, v_plan, pref, radius_m, v_max, to_obstacle, lanes, p, pts):
            normal, offset = law.wall_lines(z, rows, radius_m, to_obstacle, lanes, p=p, points=pts)
            plan = (v_plan * h[rows])[:, None]
            self.rows = np.asarray(rows)[(offset - (plan * normal.conj()).real).max(axis=1) > 1e-9]
            return walls_fn(z, h, rows, v_plan, pref, radius_m, v_max, to_obstacle, lanes, p, pts)

        def points_(fol, z, reach_m, count):
            out = points_fn(fol, z, reach_m, count)
            more = np.isfinite(out[:, 1:]).any(axis=1)
            self.walls[0] += int((~more).sum())
            self.walls[1] += int(more.sum())
            return out

        def meeting_(*args, **kw):
            allow = meeting(*args, **kw)
            if allow is not None:
                self.biased[0] += int(allow.sum())
                self.biased[1] += int((~allow).sum())
            return allow

        def steer_clear_(*args, **kw):
            out = clear(*args, **kw)
            if out is not None:
                self.orca_v.update(zip(out[0].tolist(), out[1].tolist(), strict=True))
            return out

        monkeypatch.setattr(law, "solve", solve_)
        monkeypatch.setattr(law, "steer_rows", steer_rows_)
        monkeypatch.setattr(law, "steer_walls", steer_walls_)
        monkeypatch.setattr(law, "meeting", meeting_)
        monkeypatch.setattr(PathFollower, "obstacle_points", points_)
        monkeypatch.setattr(array_period, "steer_clear", steer_clear_)

    def clear(self) -> None:
        self.infeasible.clear()
        self.orca_v.clear()


def compare(world, twin, programs: Programs, tally: dict) -> list[str]:
    """What differs between the reference and the twin after one period (empty: nothing)."""
    f, g = world.fleet, twin.fleet
    skip = np.zeros(len(f.state), dtype=bool)
    skip[list(programs.infeasible)] = True
    tally["infeasible"] += int(skip.sum())
    out = []
    dv = np.abs(f.v_cmd_mps - g.v_cmd_mps)
    dq = np.abs(f.q_cmd_mps - g.q_cmd_mps)
    tol_q = np.where(np.abs(f.v_cmd_mps) < 1e-3, 1e-9, 1e-12)
    tally["worst_v"] = max(tally["worst_v"], float(dv[~skip].max(initial=0.0)))
    tally["worst_q"] = max(tally["worst_q"], float(dq[~skip].max(initial=0.0)))
    if ((dv > 1e-12) & ~skip).any() or ((dq > tol_q) & ~skip).any():
        out.append(f"commands differ by {dv[~skip].max():.2e}, {dq[~skip].max():.2e}")
    for name in FIELDS:
        a, b = getattr(f, name), getattr(g, name)
        if not np.allclose(a, b, rtol=0.0, atol=1e-12, equal_nan=True):
            out.append(f"{name} differs")
    other = (f.blocker != g.blocker).nonzero()[0].tolist()
    zero = [j for j in other if abs(programs.orca_v.get(j, 1.0)) < 1e-12]
    tally["zero_sign"] += len(zero)
    if len(zero) < len(other):
        out.append(f"robot in the way differs for {sorted(set(other) - set(zero))}")
    asked = np.zeros(len(f.state), dtype=bool)  # ... and asked to make way in one period only
    asked[[k for j in zero for k in (f.blocker[j], g.blocker[j]) if k >= 0]] = True
    waypoints = world.follower.index != twin.follower.index
    if (waypoints & ~asked).any() or (f.yielding != g.yielding)[~asked].any():
        out.append("waypoints differ")
    return out


def run_scene(name: str, avoidance: str, seconds: float, more: tuple, monkeypatch) -> dict:
    """Play the scene with the reference period; a compiled twin at every period."""
    scenario = apply_overrides(load_named(name), (("spatial.avoidance", avoidance), *more))
    rng = np.random.default_rng(7)
    world = PymunkWorld(scenario, control="array")
    world.reset(rng)
    programs = Programs(monkeypatch)
    tally = dict(periods=0, infeasible=0, zero_sign=0, worst_v=0.0, worst_q=0.0, failures=[])
    tally["biased"], tally["walls"] = programs.biased, programs.walls
    reference = ArrayControl.period

    def period(control, t: float) -> None:
        parts, motors = twin_of(world)
        world.motors.read()
        motors.flat[:] = world.motors.flat
        CompiledControl(parts).period(t)
        programs.clear()
        reference(control, t)
        tally["periods"] += 1
        differ = compare(world, parts, programs, tally)
        if differ:
            tally["failures"].append((t, differ))

    monkeypatch.setattr(ArrayControl, "period", period)
    types = len(scenario.task_types)
    next_id = 0
    while world.time_s < seconds - 1e-9:
        free = np.flatnonzero(world.task_ < 0)
        if free.size:
            kinds = rng.integers(0, types, size=free.size)
            sites = [scenario.spatial.sites[k] for k in kinds.tolist()]
            xy = np.array([s[rng.integers(0, len(s))] for s in sites], dtype=float)
            ids = np.arange(next_id, next_id + free.size)
            next_id += free.size
            batch = Batch(0, 0, ids, kinds, np.zeros(free.size, bool), xy)
            world.apply(batch, free, np.zeros(free.size))
        world.advance(1.0)
    return tally


@pytest.mark.parametrize(
    "scene",
    SCENES,
    ids=[f"{s[0]}-{s[1]}" + {MEETINGS: "-meetings", EDGES: "-edges"}.get(s[3], "") for s in SCENES],
)
def test_compiled_period_commands_what_the_numpy_period_commands(scene, monkeypatch, report_line):
    tally = run_scene(*scene, monkeypatch)
    name, avoidance, _, more = scene
    report_line(
        f"compiled vs numpy control period, {name} ({avoidance}): {tally['periods']} periods, "
        f"commands differ by at most {tally['worst_v']:.1e} (v) and {tally['worst_q']:.1e} (q) "
        f"m/s; {tally['infeasible']} robot-periods with an infeasible program (new rule, not "
        f"compared), {tally['zero_sign']} robots in the way keyed on a rounding zero"
        + (
            f"; bias in meetings: {tally['biased'][0]} turned, {tally['biased'][1]} not"
            * (more == MEETINGS)
        )
        + (
            f"; obstacle lines: {tally['walls'][0]} with one, {tally['walls'][1]} with more"
            * (more == EDGES)
        )
    )
    assert tally["periods"] > 5 * scene[2]  # 10 Hz, most periods not resting
    assert not tally["failures"], tally["failures"][:5]
    if more == MEETINGS:  # the rule decided both ways, and the compiled period followed it
        assert min(tally["biased"]) > 0, tally["biased"]
    if more == EDGES:  # robots with one wall line and with several, and the kernel followed
        assert min(tally["walls"]) > 0, tally["walls"]
