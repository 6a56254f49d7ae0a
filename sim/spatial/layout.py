"""Is the arena's layout usable? Robots' starts, task sites and reachability, checked once.

Everything that would make a spatial run fail or hang is caught before any round runs, with a
one-line :class:`sim.scenario.ScenarioError` naming the key: a robot that starts outside the
arena, inside an obstacle or on top of another robot; a site inside an obstacle or too close to
one (or to the arena wall) for a robot centre; a site that no capable robot can reach from its
start (checked with the planner). The loader calls :func:`check_layout` on every scenario file,
and the pymunk world on every scenario it is built with (a scenario built in Python too).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from sim.scenario import Scenario, SpatialSpec
from sim.scenario.schema import fail
from sim.spatial.navigation.planning import GridPlanner, polygon_signed_distance


class Frame:
    """How messages show points and obstacles: in the frame of the file (a ROS map's, shifted
    by ``origin``) and with the obstacles from ``own`` on named as the map's."""

    def __init__(self, origin: tuple[float, float] = (0.0, 0.0), own: int | None = None):
        self.origin, self.own = origin, own

    def xy(self, x: float, y: float) -> str:
        """A point of the world as the file gives it."""
        return f"({x + self.origin[0]:g}, {y + self.origin[1]:g})"

    def obstacle(self, k: int) -> str:
        """Obstacle ``k`` by the name the file knows it by."""
        if self.own is not None and k >= self.own:
            return "an occupied or unknown cell of spatial.map"
        return f"spatial.obstacles[{k}]"


def check_layout(
    scenario: Scenario, planner: GridPlanner | None = None, frame: Frame | None = None
) -> None:
    """Raise ScenarioError for the first start or site that makes the layout unusable.

    Args:
        scenario: a scenario with a ``spatial`` table (no check without one).
        planner: the arena's planner, if the caller has one (else one is built).
        frame: how messages name points and obstacles (default: as the world holds them).
    """
    spec = scenario.spatial
    if spec is None:
        return
    frame = frame or Frame()
    starts = _starts(scenario, spec, frame)
    _sites(spec, scenario.task_types, frame)
    _reachable(scenario, spec, starts, planner or GridPlanner(spec), frame)


def inside_obstacle(spec: SpatialSpec, pts: np.ndarray, margin_m: float) -> np.ndarray:
    """(n,) index of the first obstacle nearer than ``margin_m`` to each point, or -1."""
    hit = np.full(len(pts), -1)
    for k, poly in reversed(list(enumerate(spec.obstacles))):
        near = polygon_signed_distance(pts, np.asarray(poly, dtype=float)) < margin_m
        hit[near] = k
    return hit


def _starts(scenario: Scenario, spec: SpatialSpec, frame: Frame) -> np.ndarray:
    robots = scenario.robots
    r = spec.drive.radius_m
    starts = np.array([robot.start_xy for robot in robots], dtype=float)
    for j, (x, y) in enumerate(starts):
        if not (r <= x <= spec.width_m - r and r <= y <= spec.height_m - r):
            fail(
                f"robots[{j}].start",
                f"{frame.xy(x, y)} puts a robot of radius {r:g} m outside the arena or into a wall",
            )
    for margin in (r, r + spec.clearance_m):  # inside an obstacle first, then too close to one
        hit = inside_obstacle(spec, starts, margin)
        bad = np.flatnonzero(hit >= 0)
        if not bad.size:
            continue
        j = int(bad[0])
        where, xy, what = f"robots[{j}].start", frame.xy(*starts[j]), frame.obstacle(hit[j])
        if margin == r:
            fail(where, f"{xy} overlaps or is inside {what} (robot radius {r:g} m)")
        fail(
            where,
            f"{xy} is within {margin:g} m (robot radius + clearance) of {what}: "
            "the planner keeps robot centres farther away",
        )
    pairs = cKDTree(starts).query_pairs(2.0 * r, output_type="ndarray")
    if len(pairs):  # touching (centres exactly two radii apart) is allowed
        gaps = np.linalg.norm(starts[pairs[:, 0]] - starts[pairs[:, 1]], axis=1)
        pairs = pairs[gaps < 2.0 * r]
    if len(pairs):
        a, b = sorted(pairs[np.lexsort(pairs.T[::-1])][0].tolist())
        gap = float(np.linalg.norm(starts[a] - starts[b]))
        fail(
            f"robots[{b}].start",
            f"overlaps robots[{a}] ({robots[a].name}): centres {gap:.3g} m apart, "
            f"need >= {2 * r:g} m",
        )
    return starts


def _sites(spec: SpatialSpec, types: tuple[str, ...], frame: Frame) -> None:
    reach = spec.drive.radius_m + spec.clearance_m
    for i, pts in enumerate(spec.sites):
        arr = np.asarray(pts, dtype=float)
        inside = inside_obstacle(spec, arr, 0.0)
        near = inside_obstacle(spec, arr, reach)
        far = np.array([spec.width_m - reach, spec.height_m - reach])
        wall = ((arr < reach) | (arr > far)).any(axis=1)
        for s in range(len(arr)):
            where = f"spatial.sites.{types[i]}[{s}]"
            xy = frame.xy(*arr[s])
            if inside[s] >= 0:
                fail(where, f"{xy} is inside {frame.obstacle(inside[s])}")
            if near[s] >= 0:
                fail(
                    where,
                    f"{xy} is within {reach:g} m (robot radius + clearance) of "
                    f"{frame.obstacle(near[s])}: no robot centre can get there",
                )
            if wall[s]:
                fail(where, f"{xy} is within {reach:g} m of the arena wall: unreachable")


def _reachable(scenario: Scenario, spec, starts, planner: GridPlanner, frame: Frame) -> None:
    robots, types = scenario.robots, scenario.task_types
    for i, pts in enumerate(spec.sites):
        capable = [j for j, r in enumerate(robots) if i in r.capabilities]
        dist = planner.distances(starts[capable], np.asarray(pts, dtype=float))
        bad = np.argwhere(~np.isfinite(dist))
        if len(bad):
            jj, s = bad[0]
            j = capable[jj]
            fail(
                f"spatial.sites.{types[i]}[{s}]",
                f"unreachable from robots[{j}] ({robots[j].name}) starting at "
                f"{frame.xy(*starts[j])}",
            )
