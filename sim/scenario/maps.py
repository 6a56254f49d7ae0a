"""A ROS map as the arena of a scenario, for the file door and the Python door alike.

:func:`map_arena` reads a map_server map (its YAML file and image, ``sim.maps.load_map``) and
turns its occupied and unknown cells into convex obstacles (``sim.maps.cached_obstacles``).
The world's frame puts the map's lower-left corner at (0, 0); :meth:`MapArena.to_world` moves
points from the map's frame (as RViz shows them) into it, and
:meth:`sim.scenario.SpatialSpec.on_map` builds the ``[spatial]`` table of a scenario on the map
from points in the map's frame.

A :class:`sim.scenario.SpatialSpec` that names a map checks that its arena is that map's
(:func:`check_map_arena`), so a spec built in Python cannot name one map and hold another
arena. Maps are read once per process and file state (path, size, modification time).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sim.maps import MapError, cached_obstacles, load_map
from sim.scenario.schema import fail

MAP_KEY = "map"  # [spatial] map: a ROS map_server map as the arena (the file sets the arena)
_MEMO: dict[tuple, tuple[MapArena, Path, tuple | None]] = {}
_MEMO_SIZE = 8


@dataclass(frozen=True, slots=True)
class MapArena:
    """A ROS map as an arena: its size, its convex obstacles in the world's frame (the map's
    lower-left corner at (0, 0)), the map-frame position of that corner and the map's file."""

    width_m: float
    height_m: float
    polygons: tuple
    origin_xy: tuple[float, float]
    path: str  # the map's .yaml file, resolved

    def to_world(self, xy: Any) -> tuple[float, float]:
        """A point of the map's frame (m) in the world's frame."""
        return (float(xy[0]) - self.origin_xy[0], float(xy[1]) - self.origin_xy[1])


def shifted_point(p: Any, origin: tuple[float, float]) -> Any:
    """``p`` less ``origin`` if it is a point of two finite numbers, else as it is (the specs
    then refuse it with their own message)."""
    ok = isinstance(p, list | tuple) and len(p) == 2
    if not ok or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in p):
        return p
    return (p[0] - origin[0], p[1] - origin[1])


def shifted_points(pts: Any, origin: tuple[float, float], depth: int = 1) -> Any:
    """Every point of a list (``depth`` 1) or of a list of lists (2) less ``origin``."""
    if not isinstance(pts, list | tuple):
        return pts
    if depth == 1:
        return [shifted_point(p, origin) for p in pts]
    return [shifted_points(q, origin) for q in pts]


def map_arena(path: str | Path) -> MapArena:
    """Read a ROS map_server map (``.yaml`` and its image) as an arena; the geometry is cached
    on disk per map content, the arena in this process per file state.

    Raises:
        ScenarioError: the map cannot be read (one line naming the file and key).
    """
    resolved = Path(path).resolve()
    key = _file_state(resolved)
    hit = _MEMO.get(key) if key else None
    if hit is not None and _file_state(hit[1]) == hit[2]:
        return hit[0]
    try:
        occ = load_map(path)
        geometry = cached_obstacles(occ)
    except MapError as err:
        fail(f"spatial.{MAP_KEY}", str(err))
    polygons = tuple(tuple(map(tuple, p)) for p in geometry.arena_polygons)
    origin = (float(occ.origin_xy[0]), float(occ.origin_xy[1]))
    arena = MapArena(float(occ.width_m), float(occ.height_m), polygons, origin, str(resolved))
    image = Path(occ.meta.image).resolve()
    if key:
        while len(_MEMO) >= _MEMO_SIZE:
            _MEMO.pop(next(iter(_MEMO)))
        _MEMO[key] = (arena, image, _file_state(image))
    return arena


def check_map_arena(spec: Any) -> None:
    """ScenarioError unless the arena of a ``SpatialSpec`` that names a map is that map's: its
    size, and the map's polygons as the last obstacles (after any of the scenario's own)."""
    arena = map_arena(spec.map)
    name = Path(spec.map).name
    how = "build it with SpatialSpec.on_map(path, ...)"
    if (spec.width_m, spec.height_m) != (arena.width_m, arena.height_m):
        fail(
            f"spatial.{MAP_KEY}",
            f"{name} is {arena.width_m!r} x {arena.height_m!r} m but the arena is "
            f"{spec.width_m!r} x {spec.height_m!r} m: {how}",
        )
    n = len(arena.polygons)
    if n and spec.obstacles[-n:] != arena.polygons:
        fail(f"spatial.{MAP_KEY}", f"the obstacles do not end with the {n} of {name}: {how}")


def _file_state(path: Path) -> tuple | None:
    """(path, size, modification time) of a file, or None if it cannot be read."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (str(path), st.st_size, st.st_mtime_ns)
