"""The ``[spatial]`` table of a scenario file: parsing and layout validation.

Everything that would make a spatial run fail or hang is caught here, at load time, with a
one-line message naming the key path: unknown keys, non-finite numbers, bad rates, obstacles that
are not convex or leave the arena, sites outside the arena, inside an obstacle or too close to one
for a robot centre, robots that start inside a wall or on top of each other, a task type without
sites, and sites that no capable robot can reach from its start (checked with the planner).

    [spatial]
    width_m = 20.0
    height_m = 20.0
    obstacles = [[[4, 4], [8, 4], [8, 6], [4, 6]]]   # convex polygons, m
    [spatial.sites]
    T1 = [[2.0, 3.0], [15.0, 4.0]]                    # one list of points per task type
    [spatial.drive]
    radius_m = 0.25                                   # sim.scenario.DriveSpec fields

and every ``[[robots]]`` table needs ``start = [x, y]``.
"""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
from scipy.spatial import cKDTree

from sim.scenario import DriveSpec, RobotSpec, SpatialSpec
from sim.spatial.jams import LOOK_AHEAD
from sim.spatial.law.orca import AVOIDANCE
from sim.spatial.navigation.planning import GridPlanner, polygon_signed_distance

_WORDS = {"avoidance": AVOIDANCE, "look_ahead": LOOK_AHEAD}  # string keys, allowed values
_NUMBERS = {
    f.name: f.default for f in fields(SpatialSpec) if f.name not in {"obstacles", "sites", *_WORDS}
}
_NUMBERS.pop("width_m")
_NUMBERS.pop("height_m")
_NUMBERS.pop("drive")
_KEYS = {"width_m", "height_m", "obstacles", "sites", "drive", *_NUMBERS, *_WORDS}
_POSITIVE = {"dt_s", "control_hz", "arrive_tol_m", "grid_res_m", "stuck_timeout_s"}  # > 0
MAX_GRID_CELLS = 4_000_000
MAX_SITES = 10_000
MAX_RECOVERIES = 1000  # beyond this a stuck robot would retry for hours of simulated time


def parse_spatial(v, doc: dict, types: list[str], robots: list[RobotSpec]) -> SpatialSpec:
    """Validate ``doc["spatial"]`` and the robots' starts; build the :class:`SpatialSpec`.

    Args:
        v: the loader's :class:`scenarios.loader.Validator` (its ``fail`` raises ScenarioError).
        doc: the whole parsed TOML document.
        types: task type names, in order.
        robots: the robots parsed so far (their ``start_xy`` may be None).
    """
    table = v.table(doc, "spatial")
    v.keys(table, "spatial", _KEYS)
    for key in ("width_m", "height_m"):
        v.check(key in table, f"spatial.{key}", "missing")
    width = v.number(table, "width_m", "spatial.width_m", lo=0.0, lo_open=True)
    height = v.number(table, "height_m", "spatial.height_m", lo=0.0, lo_open=True)
    values = {}
    for key, default in _NUMBERS.items():
        if key in table:
            values[key] = v.number(
                table,
                key,
                f"spatial.{key}",
                lo=0.0,
                lo_open=key in _POSITIVE,
                integer=isinstance(default, int),
            )
    for key, allowed in _WORDS.items():
        if key in table:
            word = table[key]
            if word not in allowed:
                choices = " or ".join(f'"{a}"' for a in allowed)
                v.fail(f"spatial.{key}", f"must be {choices}; got {word!r}")
            values[key] = word
    spec = SpatialSpec(width, height, (), (), **values)
    v.check(
        spec.dt_s <= 0.05, "spatial.dt_s", f"{spec.dt_s} s is too coarse for contacts (<= 0.05)"
    )
    v.check(
        spec.control_hz * spec.dt_s <= 1.0,
        "spatial.control_hz",
        f"control ({spec.control_hz:g} Hz) cannot run faster than physics (1/dt_s)",
    )
    v.check(spec.control_hz >= 2.0, "spatial.control_hz", "below 2 Hz robots overshoot their goals")
    if width * height / spec.grid_res_m**2 > MAX_GRID_CELLS:
        v.fail("spatial.grid_res_m", f"the grid would have more than {MAX_GRID_CELLS:,} cells")
    v.check(
        spec.max_recoveries <= MAX_RECOVERIES,
        "spatial.max_recoveries",
        f"must be <= {MAX_RECOVERIES}, got {spec.max_recoveries}",
    )
    v.check(spec.collision_slop_m < 0.05, "spatial.collision_slop_m", "must be below 0.05 m")
    drive = _drive(v, table)
    obstacles = _obstacles(v, table, width, height)
    sites = _sites(v, table, types)
    spec = SpatialSpec(width, height, obstacles, sites, drive, **values)
    starts = _starts(v, robots, spec)
    _check_sites(v, spec, types)
    _check_reachable(v, spec, types, robots, starts)
    return spec


def _drive(v, table: dict) -> DriveSpec:
    sub = v.table(table, "drive", where="spatial.drive")
    names = {f.name for f in fields(DriveSpec)}
    v.keys(sub, "spatial.drive", names)
    values = {k: v.number(sub, k, f"spatial.drive.{k}", lo=0.0, lo_open=True) for k in sub}
    drive = DriveSpec(**values)
    v.check(
        drive.wheel_base_m <= 2.0 * drive.radius_m,
        "spatial.drive.wheel_base_m",
        "wheels must fit inside the robot (wheel_base_m <= 2 * radius_m)",
    )
    return drive


def _point(v, val, where: str) -> tuple[float, float]:
    if not isinstance(val, list) or len(val) != 2:
        v.fail(where, "must be a point [x, y]")
    return (v.number(val, 0, f"{where}[0]"), v.number(val, 1, f"{where}[1]"))


def _obstacles(v, table: dict, width: float, height: float) -> tuple:
    raw = table.get("obstacles", [])
    if not isinstance(raw, list):
        v.fail("spatial.obstacles", "must be a list of polygons [[x, y], ...]")
    out = []
    for k, poly in enumerate(raw):
        where = f"spatial.obstacles[{k}]"
        if not isinstance(poly, list) or len(poly) < 3:
            v.fail(where, "must be a polygon of at least 3 points [[x, y], ...]")
        pts = np.array([_point(v, p, f"{where}[{i}]") for i, p in enumerate(poly)])
        for i, (x, y) in enumerate(pts):
            if not (0.0 <= x <= width and 0.0 <= y <= height):
                v.fail(f"{where}[{i}]", f"vertex ({x:g}, {y:g}) outside the arena")
        edge = np.roll(pts, -1, axis=0) - pts
        nxt = np.roll(edge, -1, axis=0)
        cross = edge[:, 0] * nxt[:, 1] - edge[:, 1] * nxt[:, 0]
        if not ((cross > 1e-12).all() or (cross < -1e-12).all()):
            v.fail(where, "must be convex, with no repeated or collinear vertices")
        if cross[0] < 0:
            pts = pts[::-1]  # counter-clockwise, as the planner expects
        turning = np.arctan2(cross, (edge * nxt).sum(axis=1))
        if abs(abs(turning.sum()) - 2 * math.pi) > 1e-6:
            v.fail(where, "must be a simple convex polygon (it winds more than once)")
        out.append(tuple(map(tuple, pts.tolist())))
    return tuple(out)


def _sites(v, table: dict, types: list[str]) -> tuple:
    sub = v.table(table, "sites", where="spatial.sites")
    not_a_type = f"unknown key: not one of the scenario's task types ({', '.join(types)})"
    v.keys(sub, "spatial.sites", set(types), problem=not_a_type)
    out = []
    for name in types:
        where = f"spatial.sites.{name}"
        if name not in sub:
            v.fail(where, "missing: every task type needs a list of site points [[x, y], ...]")
        pts = sub[name]
        if not isinstance(pts, list) or not pts:
            v.fail(where, "must be a non-empty list of points [[x, y], ...]")
        if len(pts) > MAX_SITES:
            v.fail(where, f"{len(pts)} sites, more than the {MAX_SITES} we support")
        out.append(tuple(_point(v, p, f"{where}[{i}]") for i, p in enumerate(pts)))
    return tuple(out)


def _inside_obstacle(spec: SpatialSpec, pts: np.ndarray, margin_m: float) -> np.ndarray:
    """(n,) index of the first obstacle nearer than ``margin_m`` to each point, or -1."""
    hit = np.full(len(pts), -1)
    for k, poly in reversed(list(enumerate(spec.obstacles))):
        near = polygon_signed_distance(pts, np.asarray(poly, dtype=float)) < margin_m
        hit[near] = k
    return hit


def _starts(v, robots: list[RobotSpec], spec: SpatialSpec) -> np.ndarray:
    r = spec.drive.radius_m
    for j, robot in enumerate(robots):
        if robot.start_xy is None:
            v.fail(f"robots[{j}].start", "missing: a spatial scenario needs start = [x, y]")
    starts = np.array([robot.start_xy for robot in robots], dtype=float)
    for j, (x, y) in enumerate(starts):
        if not (r <= x <= spec.width_m - r and r <= y <= spec.height_m - r):
            v.fail(
                f"robots[{j}].start",
                f"({x:g}, {y:g}) puts a robot of radius {r:g} m outside the arena or into a wall",
            )
    hit = _inside_obstacle(spec, starts, r)
    for j in np.flatnonzero(hit >= 0).tolist():
        v.fail(
            f"robots[{j}].start",
            f"({starts[j, 0]:g}, {starts[j, 1]:g}) overlaps or is inside "
            f"spatial.obstacles[{hit[j]}] (robot radius {r:g} m)",
        )
    pairs = cKDTree(starts).query_pairs(2.0 * r, output_type="ndarray")
    if len(pairs):
        a, b = sorted(pairs[np.lexsort(pairs.T[::-1])][0].tolist())
        gap = float(np.linalg.norm(starts[a] - starts[b]))
        v.fail(
            f"robots[{b}].start",
            f"overlaps robots[{a}] ({robots[a].name}): centres {gap:.3g} m apart, "
            f"need >= {2 * r:g} m",
        )
    return starts


def _check_sites(v, spec: SpatialSpec, types: list[str]) -> None:
    reach = spec.drive.radius_m + spec.clearance_m
    for i, pts in enumerate(spec.sites):
        arr = np.asarray(pts, dtype=float)
        for s, (x, y) in enumerate(arr):
            if not (0.0 <= x <= spec.width_m and 0.0 <= y <= spec.height_m):
                v.fail(f"spatial.sites.{types[i]}[{s}]", f"({x:g}, {y:g}) outside the arena")
        inside = _inside_obstacle(spec, arr, 0.0)
        near = _inside_obstacle(spec, arr, reach)
        far = np.array([spec.width_m - reach, spec.height_m - reach])
        wall = ((arr < reach) | (arr > far)).any(axis=1)
        for s in range(len(arr)):
            where = f"spatial.sites.{types[i]}[{s}]"
            xy = f"({arr[s, 0]:g}, {arr[s, 1]:g})"
            if inside[s] >= 0:
                v.fail(where, f"{xy} is inside spatial.obstacles[{inside[s]}]")
            if near[s] >= 0:
                v.fail(
                    where,
                    f"{xy} is within {reach:g} m (robot radius + clearance) of "
                    f"spatial.obstacles[{near[s]}]: no robot centre can get there",
                )
            if wall[s]:
                v.fail(where, f"{xy} is within {reach:g} m of the arena wall: unreachable")


def _check_reachable(v, spec, types, robots, starts) -> None:
    planner = GridPlanner(spec)
    for i, pts in enumerate(spec.sites):
        capable = [j for j, r in enumerate(robots) if i in r.capabilities]
        dist = planner.distances(starts[capable], np.asarray(pts, dtype=float))
        bad = np.argwhere(~np.isfinite(dist))
        if len(bad):
            jj, s = bad[0]
            j = capable[jj]
            v.fail(
                f"spatial.sites.{types[i]}[{s}]",
                f"unreachable from robots[{j}] ({robots[j].name}) starting at "
                f"({starts[j, 0]:g}, {starts[j, 1]:g})",
            )
