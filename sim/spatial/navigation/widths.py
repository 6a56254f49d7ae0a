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

:func:`free_widths` is the widths of many segments at once against every obstacle (a path
given to a robot, an auction round's paths), as ``PathFollower._free`` first computed them with
numpy arrays: the same arithmetic as numpy's baseline kernels
(``sim.spatial.navigation.baseline``), so numpy's answers bit for bit with
``NPY_ENABLE_CPU_FEATURES=X86_V2`` (the golden runs') and within rounding with numpy's AVX2
kernels, which fuse.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sim.spatial.navigation.baseline import clip01, modulus


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


@numba.njit(cache=True, nogil=True, inline="always")
def _gap(pr: float, pi: float, ar: float, ai: float, br: float, bi: float) -> float:
    """Distance from point p to segment a -> b as numpy computes ``|p - a - clip(t) d|`` with
    ``d = b - a``, ``t = ((p - a) conj(d)).real / max((d conj(d)).real, 1e-24)``."""
    dr, di = br - ar, bi - ai
    xr, xi = pr - ar, pi - ai
    t = clip01((xr * dr - xi * -di) / max(dr * dr - di * -di, 1e-24))
    return modulus(xr - (t * dr - 0.0 * di), xi - (t * di + 0.0 * dr))


@numba.njit(cache=True, nogil=True, inline="always")
def _span(start: np.ndarray, k: int, total: int) -> tuple[int, int]:
    """Obstacle k's slice of an array grouped by ``start``, as ``np.minimum.reduceat`` takes
    it (an empty group gives the one element at its start)."""
    end = start[k + 1] if k + 1 < len(start) else total
    return start[k], max(end, start[k] + 1)


@numba.njit(cache=True, nogil=True)
def free_widths(
    a: np.ndarray,
    b: np.ndarray,
    verts: np.ndarray,
    vert_start: np.ndarray,
    edge0: np.ndarray,
    edge1: np.ndarray,
    edge_start: np.ndarray,
    radius_m: float,
) -> np.ndarray:
    """(S, 2) free width left and right of the segments a -> b (S,): distance to the nearest
    obstacle on that side (one that straddles the segment's line counts on both) less
    ``radius_m``, at least 0; obstacle k has the vertices from ``verts[vert_start[k]]`` and the
    edges ``edge0 -> edge1`` from ``edge_start[k]`` on (to the next one's start)."""
    out = np.empty((len(a), 2))
    for s in range(len(a)):
        ar, ai, br, bi = a[s].real, a[s].imag, b[s].real, b[s].imag
        dr, di = br - ar, bi - ai
        size = max(modulus(dr, di), 1e-12)
        rat = 0.0 / size  # (b - a) / size: numpy divides by the complex (size, 0), Smith's way
        scl = 1.0 / (size + 0.0 * rat)
        ur, ui = (dr + di * rat) * scl, (di - dr * rat) * scl
        left = right = math.inf
        for k in range(len(vert_start)):
            dist = math.inf
            e_lo, e_hi = _span(edge_start, k, len(edge0))
            for e in range(e_lo, e_hi):
                p, q = edge0[e], edge1[e]
                dist = min(dist, _gap(ar, ai, p.real, p.imag, q.real, q.imag))
                dist = min(dist, _gap(br, bi, p.real, p.imag, q.real, q.imag))
            on_left = on_right = False
            v_lo, v_hi = _span(vert_start, k, len(verts))
            for v in range(v_lo, v_hi):
                pr, pi = verts[v].real, verts[v].imag
                dist = min(dist, _gap(pr, pi, ar, ai, br, bi))
                side = (pr - ar) * -ui + (pi - ai) * ur  # ((v - a) conj(unit)).imag: > 0 left
                on_left = on_left or side > -1e-9
                on_right = on_right or side < 1e-9
            dist -= radius_m
            if on_left:
                left = min(left, dist)
            if on_right:
                right = min(right, dist)
        out[s, 0], out[s, 1] = max(left, 0.0), max(right, 0.0)
    return out
