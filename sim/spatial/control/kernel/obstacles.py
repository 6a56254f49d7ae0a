"""The nearest obstacle point of one robot, compiled: what ``PathFollower.to_obstacle`` returns.

The obstacles are the follower's edges, each a segment e0 -> e0 + d. With many edges the
follower keeps a grid (``sim.spatial.navigation.buckets.EdgeCells``) whose cells list the few
edges that can be nearest to a point in them; a point inside the grid looks at those only, one
outside it at every edge. Both give the same point, bit for bit (the same arithmetic per edge,
and the first of equal distances is the lowest index), as the follower's numpy query does.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit


class Edges(NamedTuple):
    """The obstacle edges and their grid, as the kernel reads them (``views.edges_of``).

    Attributes:
        e0, d: (E,) edge starts and directions (end minus start), x + iy, m.
        cell_e0, cell_d: the grid's copies with one far-away padding edge at the end.
        table: (cells, K) edge indices into ``cell_e0`` per cell (padding: the last index);
            (0, 0) without a grid.
        lo: the grid's lower-left corner, x + iy, m; inv: 1 / cell side, 1/m; nx, ny: cells.
        reach: (cells, K) indices into ``e0`` of the edges each cell can have in the reach of
            ``obstacle_points`` (padding -1); (0, 0) without one.
    """

    e0: np.ndarray
    d: np.ndarray
    cell_e0: np.ndarray
    cell_d: np.ndarray
    table: np.ndarray
    lo: complex
    inv: float
    nx: int
    ny: int
    reach: np.ndarray


@njit(cache=True)
def _nearer(z, e0, dk, best, best_m):
    """The point of edge e0 -> e0 + dk nearest z (x + iy from z) if nearer than ``best_m``,
    else ``best``; and its distance."""
    dd = (dk * dk.conjugate()).real
    t = ((z - e0) * dk.conjugate()).real / (dd if dd > 1e-24 else 1e-24)
    t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
    near = e0 + t * dk - z
    gap = abs(near)
    if gap < best_m:
        return near, gap
    return best, best_m


@njit(cache=True)
def _cell(z, edges):
    """The grid cell of z (row of the tables), -1 outside the grid."""
    fx = math.floor((z.real - edges.lo.real) * edges.inv)
    fy = math.floor((z.imag - edges.lo.imag) * edges.inv)
    if 0 <= fx < edges.nx and 0 <= fy < edges.ny:
        return int(fy) * edges.nx + int(fx)
    return -1


@njit(cache=True)
def to_obstacle(z, edges):
    """From z (x + iy, m) to the nearest point of any obstacle edge (x + iy); inf without
    obstacles. Ties: the first edge."""
    best = complex(np.inf, 0.0)
    best_m = np.inf
    row = _cell(z, edges) if edges.table.shape[0] > 0 else -1
    if row >= 0:
        for k in edges.table[row]:
            best, best_m = _nearer(z, edges.cell_e0[k], edges.cell_d[k], best, best_m)
        return best
    for k in range(edges.e0.shape[0]):
        best, best_m = _nearer(z, edges.e0[k], edges.d[k], best, best_m)
    return best


@njit(cache=True)
def obstacle_points(z, edges, reach_m, points, gaps, out):
    """The obstacle points of a robot at z that give it a wall line, into ``out`` (x + iy from
    z, nearest first; ``sim.spatial.navigation.paths.PathFollower.obstacle_points``): the
    nearest point of each edge within ``reach_m``, taken in order of distance (ties: the
    lower index) and kept unless it lies on or behind the line of a point kept before it (a
    corner of the face it stands beside, the far side of an obstacle), at most ``len(out)``.
    ``points``, ``gaps``: (E,) scratch. Returns how many."""
    n = 0
    row = _cell(z, edges) if edges.reach.shape[0] > 0 else -1
    count = edges.e0.shape[0] if row < 0 else edges.reach.shape[1]
    for s in range(count):  # every edge, or the cell's in ascending order: the same points
        k = s if row < 0 else edges.reach[row, s]
        if k < 0:
            break
        near, gap = _nearer(z, edges.e0[k], edges.d[k], 0j, reach_m)
        if gap < reach_m:
            points[n], gaps[n] = near, gap
            n += 1
    kept = 0
    while kept < out.shape[0]:
        best = -1
        for s in range(n):  # the nearest left; the first of equal distances
            if gaps[s] < np.inf and (best < 0 or gaps[s] < gaps[best]):
                best = s
        if best < 0:
            break
        q = points[best]
        gaps[best] = np.inf
        for j in range(kept):  # in front of every line kept: n_j . (q - q_j) > 0
            if ((q - out[j]) * (-out[j] / max(abs(out[j]), 1e-12)).conjugate()).real <= 1e-9:
                break
        else:
            out[kept] = q
            kept += 1
    return kept
