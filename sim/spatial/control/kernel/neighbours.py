"""Robots near a robot, compiled: a uniform grid filled by a counting sort.

The robots are binned on square cells at least as wide as the farthest distance any query asks
for, so every robot within that distance of a robot lies in its cell or one of the eight around
it. Building the grid is two passes over the robots (count per cell, then place them in cell
order); a query reads the nine cells. :func:`k_nearest` keeps the ``k`` nearest within a range
by insertion, as RVO2's ``Agent::insertAgentNeighbor`` does, with ties broken by the lower index
(the order of a stable sort by distance, as ``sim.spatial.law.orca.neighbour_table`` has it).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

MAX_CELLS_PER_ROBOT = 4  # cells are widened until there are at most this many per robot (+ 16)


class Grid(NamedTuple):
    """Robots binned on square cells (:func:`build_grid`).

    Attributes:
        x0, y0: lower-left corner of the grid, m; inv: 1 / cell side, 1/m; side: cell side, m.
        nx, ny: cells along x and y.
        start: (nx ny + 1,) where each cell's robots begin in ``order``.
        order: (m,) robot indices, cell by cell, ascending within a cell.
    """

    x0: float
    y0: float
    inv: float
    side: float
    nx: int
    ny: int
    start: np.ndarray
    order: np.ndarray


USABLE_M = 1e300  # a robot with a coordinate this large (or NaN) is binned at the grid's edge


@njit(cache=True)
def _bin(f, n):
    """``int(f)`` held to the columns (or rows) 0 .. n - 1 of a grid; NaN: 0. Converting NaN
    or an infinity to an integer is undefined, so neither ever is."""
    if not f >= 0.0:
        return 0
    if f >= n:
        return n - 1
    return int(f)


@njit(cache=True)
def build_grid(z, side_m):
    """Bin the robots at ``z`` (x + iy, m) on cells of at least ``side_m`` (> 0; not > 0 or
    NaN: one cell for all).

    The grid spans the robots whose coordinates are finite and below ``USABLE_M``; any other
    robot (a pose gone NaN or infinite) is binned in a cell at the grid's edge, so a broken
    pose can make its neighbours wrong but never reads or writes outside the tables."""
    m = z.shape[0]
    x0, y0, x1, y1 = np.inf, np.inf, -np.inf, -np.inf
    for i in range(m):
        x, y = z[i].real, z[i].imag
        if abs(x) < USABLE_M and abs(y) < USABLE_M:
            x0, x1 = min(x0, x), max(x1, x)
            y0, y1 = min(y0, y), max(y1, y)
    if x0 > x1:  # no robot (or none usable)
        x0 = y0 = x1 = y1 = 0.0
    side = side_m if side_m > 0.0 else np.inf
    limit = MAX_CELLS_PER_ROBOT * m + 16
    while True:
        fx, fy = (x1 - x0) / side, (y1 - y0) / side  # finite: the span is below 2 USABLE_M
        if fx < limit and fy < limit:
            nx = int(fx) + 1  # >= 1: truncation is the floor
            ny = int(fy) + 1
            if nx * ny <= limit:
                break
        side *= 2.0
    inv = 1.0 / side
    cell = np.empty(m, dtype=np.int64)
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    for i in range(m):
        cx = _bin((z[i].real - x0) * inv, nx)
        cy = _bin((z[i].imag - y0) * inv, ny)
        cell[i] = cy * nx + cx
        start[cell[i] + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    order = np.empty(m, dtype=np.int64)
    for i in range(m):
        order[fill[cell[i]]] = i
        fill[cell[i]] += 1
    return Grid(x0, y0, inv, side, nx, ny, start, order)


@njit(cache=True)
def _cell_span(grid, x, y):
    """The first and last cell columns and rows round the cell of (x, y)."""
    cx = _bin((x - grid.x0) * grid.inv, grid.nx)
    cy = _bin((y - grid.y0) * grid.inv, grid.ny)
    return max(cx - 1, 0), min(cx + 1, grid.nx - 1), max(cy - 1, 0), min(cy + 1, grid.ny - 1)


@njit(cache=True)
def near_robots(grid, z, i, out):
    """Every other robot in robot i's cell and the eight around it into ``out``; their count.
    Each robot within ``grid.side`` of robot i is among them."""
    ax, bx, ay, by = _cell_span(grid, z[i].real, z[i].imag)
    n = 0
    for cy in range(ay, by + 1):
        for c in range(cy * grid.nx + ax, cy * grid.nx + bx + 1):
            for s in range(grid.start[c], grid.start[c + 1]):
                k = grid.order[s]
                if k != i:
                    out[n] = k
                    n += 1
    return n


@njit(cache=True)
def k_nearest(grid, z, i, range_m, k_max, idx, dist, scratch):
    """The ``k_max`` robots nearest robot i closer than ``range_m`` (<= ``grid.side``), nearest
    first, ties by the lower index, into ``idx`` and their centre distances into ``dist``;
    their count. ``scratch``: (m,) int buffer."""
    n = near_robots(grid, z, i, scratch)
    count = 0
    far2 = range_m * range_m * (1.0 + 1e-9)  # surely out of range beyond (no hypot needed)
    for s in range(n):
        k = scratch[s]
        rel = z[k] - z[i]
        if rel.real * rel.real + rel.imag * rel.imag > far2:
            continue
        d = abs(rel)
        if not d < range_m:
            continue
        if count == k_max and not (
            d < dist[count - 1] or (d == dist[count - 1] and k < idx[count - 1])
        ):
            continue
        pos = count if count < k_max else k_max - 1
        while pos > 0 and (d < dist[pos - 1] or (d == dist[pos - 1] and k < idx[pos - 1])):
            if pos < k_max:
                dist[pos], idx[pos] = dist[pos - 1], idx[pos - 1]
            pos -= 1
        dist[pos], idx[pos] = d, k
        if count < k_max:
            count += 1
    return count
