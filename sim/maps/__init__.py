"""ROS occupancy-grid maps as arenas: read a map_server map, turn its blocked cells into convex
polygons for the planner and pymunk, cache them, and measure distances on the grid itself.

    occ = load_map("scenarios/data/maps/depot.yaml")      # OccupancyMap: cells, resolution...
    geometry = cached_obstacles(occ)                       # MapGeometry: convex CCW polygons
    geometry.arena_polygons                                # in [0, width_m] x [0, height_m]

Modules: ``errors``, ``mapyaml`` (the YAML file), ``occupancy`` (the image, read as map_server
reads it), ``contours`` / ``simplify`` / ``decompose`` / ``geometry`` (cells to polygons, on the
exact integer predicates of ``lattice``), ``cache``, ``reference`` (clearance and grid
distances, for tests and validation), ``probe`` (a synthetic map and the time to prepare it).
It imports numpy, scipy and Pillow and nothing else of the project, so it sits at the bottom
of ``sim``.
"""

from __future__ import annotations

from sim.maps.cache import cached_obstacles, default_cache_dir
from sim.maps.errors import MapError
from sim.maps.geometry import MapGeometry, cleaned_cells, map_obstacles
from sim.maps.occupancy import FREE, OCCUPIED, UNKNOWN, OccupancyMap, load_map
from sim.maps.reference import Clearance, GridReference

__all__ = [
    "FREE",
    "OCCUPIED",
    "UNKNOWN",
    "Clearance",
    "GridReference",
    "MapError",
    "MapGeometry",
    "OccupancyMap",
    "cached_obstacles",
    "cleaned_cells",
    "default_cache_dir",
    "load_map",
    "map_obstacles",
]
