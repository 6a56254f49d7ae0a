"""The traffic layer's plane geometry on small arrays, compiled: the gap between two convex
polygons, a line clipped to one, and the distance from points to a path.

The traffic rules ask these questions many times per event (every robot at work against the
shapes near it, every path against the robots standing near it), on arrays of a few to a few
hundred points, where numpy's cost is its calls, not its arithmetic. The arithmetic here is
numpy's baseline x86-64 kernels' (``NPY_ENABLE_CPU_FEATURES=X86_V2``, the golden runs'), term
by term and in the same order: a complex product is ``(ar br - ai bi, ar bi + ai br)``, a
complex modulus is ``l * sqrt(1 + (s / l)^2)`` of the larger and smaller part, and nothing is
fused (numba fuses a multiply and an add only with ``fastmath``). So the answers are numpy's
bit for bit there (tests/sim/spatial/traffic/test_compiled.py); with numpy's AVX2 kernels,
which fuse, numpy's own last bits differ from these.

numba caches the compiled functions beside this module (``__pycache__``); a cold cache costs a
few seconds, once.
"""

from __future__ import annotations

import math

import numba
import numpy as np

TOL_M = 1e-9  # a line touching a polygon's boundary meets it (``geometry.TOL_M``)


@numba.njit(cache=True, nogil=True, inline="always")
def _modulus(x: float, y: float) -> float:
    """|x + iy| as numpy's baseline kernel computes it."""
    re, im = abs(x), abs(y)
    big, small = max(re, im), min(re, im)
    if big == 0.0:
        return 0.0
    if math.isinf(big):
        return math.inf
    ratio = small / big
    return big * math.sqrt(1.0 + ratio * ratio)


@numba.njit(cache=True, nogil=True, inline="always")
def _to_segment(p: complex, a: complex, b: complex) -> tuple[float, complex]:
    """Distance from p to segment a -> b and its nearest point (``geometry.to_segments``)."""
    dr, di = b.real - a.real, b.imag - a.imag
    dd = max(dr * dr - di * -di, 1e-24)  # (d conj(d)).real
    ur, ui = p.real - a.real, p.imag - a.imag
    t = (ur * dr - ui * -di) / dd  # ((p - a) conj(d)).real / dd
    t = min(max(t, 0.0), 1.0)
    near = complex(a.real + (t * dr - 0.0 * di), a.imag + (t * di + 0.0 * dr))  # a + t d
    return _modulus(p.real - near.real, p.imag - near.imag), near


@numba.njit(cache=True, nogil=True, inline="always")
def _strictly_inside(x: complex, poly: np.ndarray) -> bool:
    """x lies strictly inside the convex CCW polygon (``geometry.inside``)."""
    n = len(poly)
    for e in range(n):
        e0, e1 = poly[e], poly[(e + 1) % n]
        er, ei = e1.real - e0.real, e1.imag - e0.imag
        ur, ui = x.real - e0.real, x.imag - e0.imag
        if not er * ui + -ei * ur > TOL_M:  # (conj(e1 - e0) (x - e0)).imag
            return False
    return True


@numba.njit(cache=True, nogil=True)
def polygon_gap(pa: np.ndarray, pb: np.ndarray) -> tuple[float, complex, complex]:
    """Distance between two disjoint convex polygons ((P,) complex, CCW) and the nearest
    points (on ``pa``, on ``pb``); 0 where they touch or overlap (then the points are a vertex
    and its nearest). Ties go to the first vertex and edge in order, ``pa``'s vertices
    first, as ``geometry.polygon_gap``'s argmin does."""
    na, nb = len(pa), len(pb)
    best_ab, p_ab, q_ab = math.inf, 0j, 0j
    for i in range(na):
        for k in range(nb):
            d, near = _to_segment(pa[i], pb[k], pb[(k + 1) % nb])
            if d < best_ab:
                best_ab, p_ab, q_ab = d, pa[i], near
    best_ba, p_ba, q_ba = math.inf, 0j, 0j
    for m in range(nb):
        for n in range(na):
            d, near = _to_segment(pb[m], pa[n], pa[(n + 1) % na])
            if d < best_ba:
                best_ba, p_ba, q_ba = d, near, pb[m]
    if best_ab <= best_ba:
        gap, p, q = best_ab, p_ab, q_ab
    else:
        gap, p, q = best_ba, p_ba, q_ba
    for i in range(na):
        if _strictly_inside(pa[i], pb):
            return 0.0, p, q
    for m in range(nb):
        if _strictly_inside(pb[m], pa):
            return 0.0, p, q
    return gap, p, q


@numba.njit(cache=True, nogil=True)
def clip_line(origin: complex, direction: complex, poly: np.ndarray) -> tuple[float, float]:
    """The interval of t where ``origin + t direction`` lies in the convex CCW polygon
    (boundary included); (inf, -inf) if the line misses it."""
    lo, hi = -math.inf, math.inf
    n = len(poly)
    for e in range(n):
        e0, e1 = poly[e], poly[(e + 1) % n]
        er, ei = e1.real - e0.real, e1.imag - e0.imag
        ur, ui = origin.real - e0.real, origin.imag - e0.imag
        b = er * ui + -ei * ur  # cross(edge, origin - e0): inside where >= 0
        r = er * direction.imag + -ei * direction.real  # its change per unit t
        if abs(r) < 1e-15:
            if b < -TOL_M:
                return math.inf, -math.inf
            continue
        t = -b / r - TOL_M / r
        if r > 0:
            if t > lo:
                lo = t
        elif t < hi:
            hi = t
    if lo <= hi:
        return lo, hi
    return math.inf, -math.inf


@numba.njit(cache=True, nogil=True)
def path_gaps(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """(n,) distance from each of ``points`` to the polyline ``path`` (its segments path[k]
    -> path[k + 1]; inf for a path of fewer than two points), m."""
    out = np.full(len(points), math.inf)
    for i in range(len(points)):
        for k in range(len(path) - 1):
            d, _ = _to_segment(points[i], path[k], path[k + 1])
            if d < out[i]:
                out[i] = d
    return out


@numba.njit(cache=True, nogil=True)
def way_gaps(points: np.ndarray, z: np.ndarray, paths: np.ndarray, index: np.ndarray) -> np.ndarray:
    """(R,) distance from the nearest of ``points`` to each robot's way ahead: from where it is
    (``z[r]``) to the waypoint it aims at (``paths[r, index[r]]``), then along its path's
    segments from there to the end of the (R, P) array ``paths``, m."""
    rows, width = paths.shape
    out = np.full(rows, math.inf)
    for r in range(rows):
        aim = paths[r, index[r]]
        best = math.inf
        for i in range(len(points)):
            d, _ = _to_segment(points[i], z[r], aim)
            if d < best:
                best = d
            for k in range(index[r], width - 1):
                d, _ = _to_segment(points[i], paths[r, k], paths[r, k + 1])
                if d < best:
                    best = d
        out[r] = best
    return out
