"""An obstacle grown by the planner's margin, compiled: :func:`grown_shape` is
``planning.inflate`` followed by ``planning.halfplanes`` in one call.

:meth:`GridPlanner.path_around <sim.spatial.navigation.planning.GridPlanner.path_around>` grows
an octagon for every robot it plans round, once per robot position; in numpy that is some forty
calls on arrays of eight rows. The arithmetic here is numpy's, term by term and in the same
order (no fused multiply-add: numba fuses only with ``fastmath``), so the grown corners, normals
and offsets are the numpy functions' bit for bit (tests/sim/spatial/navigation/test_shapes.py),
which the numpy functions stay to check. A degenerate polygon (a corner repeated) gives
numpy's NaNs, not an error (``error_model="numpy"``: IEEE division, as numpy divides).
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _halfplanes(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``planning.halfplanes``: outward unit normals (E, 2) and offsets (E,) of a convex CCW
    polygon (E, 2)."""
    n = poly.shape[0]
    normal = np.empty((n, 2))
    offset = np.empty(n)
    for k in range(n):
        nxt = k + 1 if k + 1 < n else 0
        ex = poly[nxt, 0] - poly[k, 0]
        ey = poly[nxt, 1] - poly[k, 1]
        nx, ny = ey, -ex
        norm = math.sqrt(nx * nx + ny * ny)  # np.linalg.norm: sqrt of the squares' sum
        nx, ny = nx / norm, ny / norm
        normal[k, 0], normal[k, 1] = nx, ny
        offset[k] = nx * poly[k, 0] + ny * poly[k, 1]  # einsum("ij,ij->i")
    return normal, offset


@numba.njit(cache=True, nogil=True, error_model="numpy")
def grown_shape(poly: np.ndarray, d_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A convex CCW polygon (P, 2) grown by ``d_m`` > 0 (``planning.inflate``: edges moved out,
    corners sharper than 90 degrees bevelled), with the grown polygon's outward unit normals
    and offsets (``planning.halfplanes``)."""
    normal, offset = _halfplanes(poly)
    n = poly.shape[0]
    line_n = np.empty((2 * n, 2))
    line_c = np.empty(2 * n)
    m = 0
    for i in range(n):
        p = i - 1 if i > 0 else n - 1
        px, py = normal[p, 0], normal[p, 1]
        if px * normal[i, 0] + py * normal[i, 1] < 0.0:
            bx, by = px + normal[i, 0], py + normal[i, 1]
            s = math.sqrt(bx * bx + by * by)
            bx, by = bx / s, by / s
            line_n[m, 0], line_n[m, 1] = bx, by
            line_c[m] = bx * poly[i, 0] + by * poly[i, 1] + d_m
            m += 1
        line_n[m, 0], line_n[m, 1] = normal[i, 0], normal[i, 1]
        line_c[m] = offset[i] + d_m
        m += 1
    out = np.empty((m, 2))
    for k in range(m):
        q = k - 1 if k > 0 else m - 1  # the line before (np.roll(_, 1))
        n2x, n2y, c2 = line_n[q, 0], line_n[q, 1], line_c[q]
        nx, ny, c = line_n[k, 0], line_n[k, 1], line_c[k]
        det = n2x * ny - n2y * nx
        out[k, 0] = (c2 * ny - c * n2y) / det
        out[k, 1] = (n2x * c - nx * c2) / det
    grown_n, grown_c = _halfplanes(out)
    return out, grown_n, grown_c
