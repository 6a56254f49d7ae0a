"""The free width beside a path segment, compiled: the distance from a segment to the nearest
obstacle on each side of it (``PathFollower._sides``).

A path is given to a robot many times per simulated minute, and each segment's widths look
at the obstacles near it; in plain Python a segment costs a few hundred microseconds. This
is the same arithmetic as Python's complex numbers do it, step for step: a product
``(ar br - ai bi, ar bi + ai br)``, a float times a complex as the complex ``(t, 0)``, a
complex over a float by Smith's method (which, for a real divisor, divides each part), and
``abs`` as libm's ``hypot`` (numba's ``abs`` of a complex calls it, as Python's does). So the
widths are Python's bit for bit (tests/sim/spatial/navigation/test_widths.py), on every CPU:
none of it goes through numpy's kernels.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, inline="always")
def _to_segment(p: complex, s0: complex, s1: complex) -> float:
    """Distance from point p to segment s0 -> s1, as Python computes it with complex numbers."""
    dr, di = s1.real - s0.real, s1.imag - s0.imag
    dd = dr * dr - di * -di
    ur, ui = p.real - s0.real, p.imag - s0.imag
    t = (ur * dr - ui * -di) / dd if dd > 1e-24 else 0.0
    t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
    return abs(complex(ur - (t * dr - 0.0 * di), ui - (t * di + 0.0 * dr)))


@numba.njit(cache=True, nogil=True)
def segment_sides(
    a: complex,
    b: complex,
    owners: np.ndarray,
    verts: np.ndarray,
    vert_start: np.ndarray,
    vert_end: np.ndarray,
    edge0: np.ndarray,
    edge1: np.ndarray,
    edge_start: np.ndarray,
    edge_end: np.ndarray,
) -> tuple[float, float]:
    """Distance from segment a -> b to the nearest of the obstacles ``owners`` on its left and
    on its right (an obstacle straddling the segment's line counts on both; inf where none
    is): obstacle k has the vertices ``verts[vert_start[k]:vert_end[k]]`` and the edges
    ``edge0 -> edge1`` in ``[edge_start[k], edge_end[k])``."""
    length = abs(complex(b.real - a.real, b.imag - a.imag))
    if length > 1e-12:
        ucr, uci = (b.real - a.real) / length, -(b.imag - a.imag) / length
    else:
        ucr, uci = 1.0, 0.0
    left = right = math.inf
    for q in range(len(owners)):
        k = owners[q]
        dist = math.inf
        hi_side, lo_side = -math.inf, math.inf
        for v in range(vert_start[k], vert_end[k]):
            p = verts[v]
            d = _to_segment(p, a, b)
            if d < dist:
                dist = d
            ur, ui = p.real - a.real, p.imag - a.imag
            side = ur * uci + ui * ucr  # ((p - a) * unit_c).imag: > 0 left of the segment
            hi_side = max(hi_side, side)
            lo_side = min(lo_side, side)
        for e in range(edge_start[k], edge_end[k]):
            dist = min(dist, _to_segment(a, edge0[e], edge1[e]), _to_segment(b, edge0[e], edge1[e]))
        if hi_side > -1e-9:
            left = min(left, dist)
        if lo_side < 1e-9:
            right = min(right, dist)
    return left, right
