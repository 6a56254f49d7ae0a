"""Ground truth from the grid itself: clearance of points and geodesic distances on free cells.

Independent of the polygons, these check them (and a planner built on them) against the cells:

- :class:`Clearance` says whether a point is on a free cell and how far it is from the nearest
  blocked cell's square or the map's edge (the arena's wall).
- :class:`GridReference` keeps the free cells whose centre has at least ``inflate_m`` of
  clearance (the places a robot centre may be, with robot radius + clearance as ``inflate_m``)
  and the shortest paths between them, Dijkstra (``scipy.sparse.csgraph``) over moves to the
  cells up to ``reach_cells`` away in every direction that is not a multiple of a shorter one.
  With more directions than the 8 neighbours the grid metric overestimates a straight line by
  at most 1 / cos(g / 2) - 1 for the widest angle g between two moves: 8.2 % for reach 1,
  2.7 % for 2, 1.3 % for 3, 0.76 % for 4. A move must stay on free cells all along.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from sim.maps.occupancy import OccupancyMap

_HALF_DIAGONAL = math.sqrt(0.5)  # a cell's half diagonal, in cells


@dataclass(frozen=True, slots=True, eq=False)
class Clearance:
    """Distance from points to the nearest blocked cell (its square) or the map's edge.

    Build it with :meth:`build`; ``tree`` indexes the centres of the blocked cells that touch a
    free cell (the only ones that can be nearest to a point off the blocked cells).
    """

    blocked: np.ndarray  # (ny, nx) bool
    resolution_m: float
    origin_xy: tuple[float, float]
    centres: np.ndarray  # (b, 2) m
    tree: cKDTree | None

    @classmethod
    def build(
        cls, blocked: np.ndarray, resolution_m: float, origin_xy: tuple[float, float]
    ) -> Clearance:
        """Index the boundary cells of ``blocked`` (row 0 at y = origin_y, as in the maps)."""
        blocked = np.asarray(blocked, dtype=bool)
        near_free = ndimage.binary_dilation(~blocked, structure=np.ones((3, 3), dtype=bool))
        j, i = np.nonzero(blocked & near_free)
        ox, oy = origin_xy
        centres = np.column_stack([ox + (i + 0.5) * resolution_m, oy + (j + 0.5) * resolution_m])
        tree = cKDTree(centres) if len(centres) else None
        return cls(blocked, float(resolution_m), tuple(origin_xy), centres, tree)

    @classmethod
    def from_map(cls, occ: OccupancyMap, *, blocked: np.ndarray | None = None) -> Clearance:
        """:meth:`build` for a map (its occupied and unknown cells, or ``blocked`` if given,
        e.g. ``sim.maps.cleaned_cells(occ).blocked``), in the map frame."""
        cells = occ.blocked if blocked is None else blocked
        return cls.build(cells, occ.resolution_m, occ.origin_xy)

    def query(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(on_free, clearance_m) for points (n, 2) m: whether each is on a free cell of the map,
        and its distance to the nearest blocked cell or the map's edge (0 if not on_free)."""
        pts = np.asarray(xy, dtype=float).reshape(-1, 2)
        res = self.resolution_m
        ny, nx = self.blocked.shape
        rel = (pts - np.asarray(self.origin_xy)) / res
        i, j = np.floor(rel[:, 0]).astype(np.int64), np.floor(rel[:, 1]).astype(np.int64)
        inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        on_free = inside.copy()
        on_free[inside] = ~self.blocked[j[inside], i[inside]]
        edge = np.minimum.reduce([rel[:, 0], nx - rel[:, 0], rel[:, 1], ny - rel[:, 1]]) * res
        out = np.where(on_free, np.maximum(edge, 0.0), 0.0)
        if self.tree is not None and on_free.any():
            k = np.flatnonzero(on_free)
            out[k] = np.minimum(out[k], self._to_cells(pts[k]))
        return on_free, out

    def _to_cells(self, pts: np.ndarray) -> np.ndarray:
        """Distance (m) of each point to the nearest indexed blocked square: the nearest few
        centres first, then every centre that could still be nearer, for the points that need
        it (a square is at most half a diagonal nearer than its centre)."""
        assert self.tree is not None
        half, slack = self.resolution_m / 2.0, self.resolution_m * _HALF_DIAGONAL
        k = min(9, len(self.centres))
        dist, idx = self.tree.query(pts, k=k)
        dist, idx = dist.reshape(len(pts), k), idx.reshape(len(pts), k)
        gap = np.abs(pts[:, None, :] - self.centres[idx]) - half
        best = np.linalg.norm(np.maximum(gap, 0.0), axis=2).min(axis=1)
        unsure = np.flatnonzero((dist[:, -1] < best + slack) & (k < len(self.centres)))
        for p in unsure.tolist():
            near = self.tree.query_ball_point(pts[p], best[p] + slack)
            gap = np.abs(pts[p] - self.centres[near]) - half
            best[p] = np.linalg.norm(np.maximum(gap, 0.0), axis=1).min()
        return best


@dataclass(frozen=True, slots=True, eq=False)
class GridReference:
    """Shortest paths of a robot centre over a grid's free cells (see the module doc)."""

    free: np.ndarray  # (ny, nx) bool: cells whose centre has >= inflate_m of clearance
    node: np.ndarray  # (ny, nx) int64: graph node of each free cell, -1 elsewhere
    graph: csr_matrix
    resolution_m: float
    origin_xy: tuple[float, float]
    inflate_m: float
    reach_cells: int

    @classmethod
    def build(
        cls,
        blocked: np.ndarray,
        resolution_m: float,
        origin_xy: tuple[float, float],
        *,
        inflate_m: float,
        reach_cells: int = 3,
    ) -> GridReference:
        """Erode the free cells by ``inflate_m`` and join them by moves up to ``reach_cells``."""
        blocked = np.asarray(blocked, dtype=bool)
        free = eroded_free(blocked, resolution_m, origin_xy, inflate_m)
        node = np.full(free.shape, -1, dtype=np.int64)
        node[free] = np.arange(int(free.sum()))
        rows, cols, weights = [], [], []
        for dx, dy in moves(reach_cells):
            ok = _move_ok(free, dx, dy, reach_cells)
            j, i = np.nonzero(ok)
            rows.append(node[j, i])
            cols.append(node[j + dy, i + dx])
            weights.append(np.full(len(j), resolution_m * math.hypot(dx, dy)))
        n = int(free.sum())
        graph = coo_matrix(
            (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n)
        ).tocsr()
        return cls(free, node, graph, float(resolution_m), tuple(origin_xy), inflate_m, reach_cells)

    @classmethod
    def from_map(
        cls,
        occ: OccupancyMap,
        *,
        inflate_m: float,
        reach_cells: int = 3,
        blocked: np.ndarray | None = None,
    ) -> GridReference:
        """:meth:`build` for a map (blocked cells as :meth:`Clearance.from_map`), map frame."""
        cells = occ.blocked if blocked is None else blocked
        return cls.build(
            cells, occ.resolution_m, occ.origin_xy, inflate_m=inflate_m, reach_cells=reach_cells
        )

    def cells(self, xy: np.ndarray) -> np.ndarray:
        """(n,) graph node of the cell under each point (m), -1 if it is not an eroded free cell."""
        pts = np.asarray(xy, dtype=float).reshape(-1, 2)
        rel = (pts - np.asarray(self.origin_xy)) / self.resolution_m
        i, j = np.floor(rel[:, 0]).astype(np.int64), np.floor(rel[:, 1]).astype(np.int64)
        ny, nx = self.free.shape
        inside = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        out = np.full(len(pts), -1, dtype=np.int64)
        out[inside] = self.node[j[inside], i[inside]]
        return out

    def centres(self, nodes: np.ndarray) -> np.ndarray:
        """(n, 2) m: the centres of the cells of graph nodes."""
        j, i = np.nonzero(self.free)
        nodes = np.asarray(nodes, dtype=np.int64)
        ox, oy = self.origin_xy
        res = self.resolution_m
        return np.column_stack([ox + (i[nodes] + 0.5) * res, oy + (j[nodes] + 0.5) * res])

    def distances(self, sources: np.ndarray, targets: np.ndarray) -> np.ndarray:
        """(m, k) path length (m) from each source point to each target point: straight to its
        cell's centre, over the grid, straight on to the target; inf where a point is not on an
        eroded free cell or no path joins them."""
        src = np.asarray(sources, dtype=float).reshape(-1, 2)
        dst = np.asarray(targets, dtype=float).reshape(-1, 2)
        s_node, t_node = self.cells(src), self.cells(dst)
        out = np.full((len(src), len(dst)), np.inf)
        ok_s, ok_t = np.flatnonzero(s_node >= 0), np.flatnonzero(t_node >= 0)
        if not len(ok_s) or not len(ok_t):
            return out
        uniq, inv = np.unique(s_node[ok_s], return_inverse=True)
        field = dijkstra(self.graph, directed=False, indices=uniq)
        grid = field[inv.ravel()][:, t_node[ok_t]]
        s_end = np.linalg.norm(src[ok_s] - self.centres(s_node[ok_s]), axis=1)
        t_end = np.linalg.norm(dst[ok_t] - self.centres(t_node[ok_t]), axis=1)
        out[np.ix_(ok_s, ok_t)] = grid + s_end[:, None] + t_end[None, :]
        return out


def eroded_free(
    blocked: np.ndarray, resolution_m: float, origin_xy: tuple[float, float], inflate_m: float
) -> np.ndarray:
    """(ny, nx) True on free cells whose centre is at least ``inflate_m`` from every blocked
    cell's square and from the map's edge. Most cells are decided from the distance between
    cell centres (a square is 1/2 to sqrt(1/2) cells nearer than its centre); the few in
    between are measured exactly with :class:`Clearance`."""
    ny, nx = blocked.shape
    res = resolution_m
    j, i = np.mgrid[0:ny, 0:nx]
    edge = np.minimum.reduce([i + 0.5, nx - i - 0.5, j + 0.5, ny - j - 0.5]) * res
    if blocked.any():
        centre = ndimage.distance_transform_edt(~blocked) * res
    else:
        centre = np.full(blocked.shape, np.inf)
    sure = (~blocked) & (centre - _HALF_DIAGONAL * res >= inflate_m) & (edge >= inflate_m)
    maybe = (~blocked) & ~sure & (centre - 0.5 * res >= inflate_m) & (edge >= inflate_m)
    if maybe.any():
        jj, ii = np.nonzero(maybe)
        pts = np.column_stack([origin_xy[0] + (ii + 0.5) * res, origin_xy[1] + (jj + 0.5) * res])
        clear = Clearance.build(blocked, res, origin_xy).query(pts)[1]
        sure[jj, ii] = clear >= inflate_m
    return sure


def moves(reach_cells: int) -> list[tuple[int, int]]:
    """Grid moves (dx, dy) up to ``reach_cells`` in x and y, one per direction (gcd 1), each
    undirected move once (dx > 0, or dx = 0 and dy > 0)."""
    out = []
    for dx in range(0, reach_cells + 1):
        for dy in range(-reach_cells, reach_cells + 1):
            if (dx > 0 or dy > 0) and math.gcd(dx, dy) == 1:
                out.append((dx, dy))
    return out


def _move_ok(free: np.ndarray, dx: int, dy: int, reach: int) -> np.ndarray:
    """(ny, nx) True where the move (dx, dy) from that cell stays on free cells: its end and
    every cell the segment between the two centres passes over (sampled finely)."""
    ny, nx = free.shape
    ok = np.zeros_like(free)
    j0, j1 = max(0, -dy), ny - max(0, dy)
    i0, i1 = max(0, -dx), nx - max(0, dx)
    if j0 >= j1 or i0 >= i1:
        return ok
    ok[j0:j1, i0:i1] = free[j0:j1, i0:i1]
    t = np.linspace(0.0, 1.0, 8 * reach + 1)
    offsets = {(math.floor(0.5 + s * dx), math.floor(0.5 + s * dy)) for s in t.tolist()}
    offsets |= {(math.ceil(s * dx - 0.5), math.ceil(s * dy - 0.5)) for s in t.tolist()}
    for ox, oy in sorted(offsets):
        if (ox, oy) != (0, 0):
            ok[j0:j1, i0:i1] &= free[j0 + oy : j1 + oy, i0 + ox : i1 + ox]
    return ok
