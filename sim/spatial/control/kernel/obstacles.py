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
def to_obstacle(z, edges):
    """From z (x + iy, m) to the nearest point of any obstacle edge (x + iy); inf without
    obstacles. Ties: the first edge."""
    best = complex(np.inf, 0.0)
    best_m = np.inf
    if edges.table.shape[0] > 0:
        fx = math.floor((z.real - edges.lo.real) * edges.inv)
        fy = math.floor((z.imag - edges.lo.imag) * edges.inv)
        if 0 <= fx < edges.nx and 0 <= fy < edges.ny:
            for k in edges.table[int(fy) * edges.nx + int(fx)]:
                best, best_m = _nearer(z, edges.cell_e0[k], edges.cell_d[k], best, best_m)
            return best
    for k in range(edges.e0.shape[0]):
        best, best_m = _nearer(z, edges.e0[k], edges.d[k], best, best_m)
    return best
