"""A map's blocked cells as a few convex polygons, for the planner and for pymunk.

``map_obstacles`` turns the cells a robot may not enter (occupied and unknown) into convex
counter-clockwise polygons in the map frame (metres):

1. *clean*: blocked blobs (8-connected) smaller than ``min_speck_m2`` are sensor noise and go;
   enclosed free pockets (4-connected) smaller than ``min_pocket_m2`` are filled; both counted;
2. *trace* the boundary of each blocked component along the cell edges (``sim.maps.contours``):
   one outline and one hole per enclosed free region, exact to the grid, a saddle (two blocked
   cells touching at a corner) cut by half a cell; blobs on the map's border close along it
   (the arena's walls stand beyond);
3. *simplify* a component's loops together by Douglas-Peucker to ``tolerance_m``, only ever
   adding to the blocked side and giving corners back wherever loops would touch or cross
   (``sim.maps.simplify``): gaps never widen and thin walls stay walls;
4. *decompose* each component, holes and all, into convex pieces (``sim.maps.decompose``): the
   holes are cut into the outline by two-way bridges, the polygon is ear-clipped, and
   Hertel-Mehlhorn merges the triangles into convex pieces across every shared edge (a
   component that is convex already is its own piece).

Why this way: the planner's cost grows with the number of obstacle corners, so the boundary is
simplified before it is split, and the split adds no corners. Decomposing per component with
bridges handles holes of any shape (the unknown band round tb3_sandbox's arena is one component
with the arena as its hole), with exact integer arithmetic, so there are no slivers, gaps or
near-collinear corners to patch. pymunk.autogeometry's marching squares would sample the grid
through a Python callback per cell, its outlines cut every corner (a rectangle gets eight), and
its convex decomposition is approximate (pieces may overlap the holes) and takes simple
polygons only, so holes would need the same bridging anyway.

Fidelity: the polygons' union covers every cleaned blocked cell (all of it, corners included)
and reaches at most ``tolerance_m`` + a quarter cell (a saddle's cut) beyond them; so a free
cell is covered only if its centre is within one cell plus ``tolerance_m`` of a blocked cell's
centre, and a blocked cell is always covered (the tests measure both directions).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from sim.maps.contours import Cleaned, clean_blocked, trace_loops
from sim.maps.decompose import convex_pieces
from sim.maps.lattice import turns
from sim.maps.occupancy import OccupancyMap
from sim.maps.simplify import simplify_loops

Polygon = tuple[tuple[float, float], ...]


@dataclass(frozen=True, slots=True, eq=False)
class MapGeometry:
    """Convex obstacles of a map and what cleaning dropped or filled.

    ``corners`` (V, 2) int64 holds every polygon's corners in half cells from the map's
    lower-left corner, ``starts`` (P + 1,) where each polygon begins in it: the exact form that
    is cached; ``polygons`` (map frame) and ``arena_polygons`` (the map's lower-left corner at
    (0, 0), so inside [0, width_m] x [0, height_m]) are derived from it.
    """

    corners: np.ndarray
    starts: np.ndarray
    resolution_m: float
    origin_xy: tuple[float, float]
    width_m: float
    height_m: float
    specks_dropped: int
    speck_area_m2: float
    pockets_filled: int
    pocket_area_m2: float
    min_speck_m2: float
    min_pocket_m2: float
    fill_detached: bool
    tolerance_m: float
    map_sha256: str
    polygons: tuple[Polygon, ...]  # convex, counter-clockwise, map frame, m
    arena_polygons: tuple[Polygon, ...]  # the same, shifted by -origin_xy

    @property
    def n_polygons(self) -> int:
        return len(self.starts) - 1

    @property
    def n_vertices(self) -> int:
        return len(self.corners)

    @classmethod
    def from_corners(
        cls, corners: np.ndarray, starts: np.ndarray, **fields: float | int | bool | str | tuple
    ) -> MapGeometry:
        """Build from the exact form (see the class doc); ``fields`` are the other attributes."""
        corners = np.asarray(corners, dtype=np.int64).reshape(-1, 2)
        starts = np.asarray(starts, dtype=np.int64).reshape(-1)
        corners.flags.writeable = False
        starts.flags.writeable = False
        res = float(fields["resolution_m"])
        ox, oy = fields["origin_xy"]
        local = (corners / 2.0) * res  # half cells are exact in binary, so x = i * res exactly
        pieces = [local[s:e] for s, e in itertools.pairwise(starts)]
        arena = tuple(tuple((float(x), float(y)) for x, y in p.tolist()) for p in pieces)
        world = tuple(tuple((ox + x, oy + y) for x, y in p) for p in arena)
        return cls(corners, starts, polygons=world, arena_polygons=arena, **fields)


def cleaned_cells(
    occ: OccupancyMap,
    *,
    min_speck_m2: float = 0.004,
    min_pocket_m2: float = 0.01,
    fill_detached: bool = False,
) -> Cleaned:
    """The blocked cells the polygons stand for (arguments as :func:`map_obstacles`)."""
    cell_m2 = occ.resolution_m**2
    return clean_blocked(
        occ.blocked, min_speck_m2 / cell_m2, min_pocket_m2 / cell_m2, fill_detached
    )


def map_obstacles(
    occ: OccupancyMap,
    *,
    min_speck_m2: float = 0.004,
    min_pocket_m2: float = 0.01,
    fill_detached: bool = False,
    tolerance_m: float = 0.05,
) -> MapGeometry:
    """Convex polygons covering the map's blocked cells (see the module doc).

    Args:
        occ: the map.
        min_speck_m2: blocked blobs of less area are noise and dropped (0.004 m2: a lone
            cell at 5 cm goes, the depot map's pillars of two cells stay).
        min_pocket_m2: enclosed free pockets of less area are filled.
        fill_detached: fill every free region (4-connected) but the largest as well: the
            floor robots drive on stays, regions no robot on it can reach (the inside of a
            closed rack outline, a strip behind the outer wall) become solid, with far fewer
            polygons. Counted with the pockets.
        tolerance_m: how far simplification may grow the blocked region (m, >= 0); it never
            shrinks it.

    Returns:
        The polygons and the counts of what cleaning changed.
    """
    if not tolerance_m >= 0:
        raise ValueError(f"tolerance_m must be >= 0, got {tolerance_m}")
    res = occ.resolution_m
    cleaned = cleaned_cells(
        occ, min_speck_m2=min_speck_m2, min_pocket_m2=min_pocket_m2, fill_detached=fill_detached
    )
    loops, n = trace_loops(cleaned.blocked)
    outline: dict[int, np.ndarray] = {}
    holes: dict[int, list[np.ndarray]] = {k: [] for k in range(1, n + 1)}
    for loop in loops:
        if loop.outer:
            outline[loop.component] = loop.points
        else:
            holes[loop.component].append(loop.points)
    tol = tolerance_m / (res / 2.0)
    pieces: list[np.ndarray] = []
    for k in sorted(outline):
        if not holes[k] and (turns(outline[k]) > 0).all():
            pieces.append(outline[k])  # convex already: simplifying could only cut it
            continue
        rings = simplify_loops([outline[k], *holes[k]], tol)
        pieces.extend(convex_pieces(rings[0], rings[1:]))
    sizes = [len(p) for p in pieces]
    corners = np.concatenate(pieces) if pieces else np.zeros((0, 2), dtype=np.int64)
    return MapGeometry.from_corners(
        corners,
        np.concatenate([[0], np.cumsum(sizes)]),
        resolution_m=res,
        origin_xy=occ.origin_xy,
        width_m=occ.width_m,
        height_m=occ.height_m,
        specks_dropped=cleaned.specks,
        speck_area_m2=cleaned.speck_cells * res**2,
        pockets_filled=cleaned.pockets,
        pocket_area_m2=cleaned.pocket_cells * res**2,
        min_speck_m2=min_speck_m2,
        min_pocket_m2=min_pocket_m2,
        fill_detached=fill_detached,
        tolerance_m=tolerance_m,
        map_sha256=occ.sha256,
    )
