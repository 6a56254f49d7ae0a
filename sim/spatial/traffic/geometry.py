"""Plane geometry the traffic layer needs: convex polygons, lines through them, rectangles.

Points are complex numbers x + iy (m); polygons are convex, counter-clockwise, as (P,) complex
arrays. Pure functions, no state.
"""

from __future__ import annotations

import functools

import numpy as np

from sim.spatial import plane

TOL_M = plane.TOL_M  # a line touching a polygon's boundary meets it


def as_complex(poly) -> np.ndarray:
    """A polygon given as (P, 2) points (or already complex) as a (P,) complex array."""
    arr = np.asarray(poly)
    if np.iscomplexobj(arr):
        return arr.astype(complex).reshape(-1)
    arr = arr.astype(float).reshape(-1, 2)
    return arr[:, 0] + 1j * arr[:, 1]


def to_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from points ``p`` to segments ``a -> b`` (broadcast together) and the nearest
    point of each segment, m."""
    d = b - a
    dd = np.maximum((d * d.conj()).real, 1e-24)
    t = np.clip(((p - a) * d.conj()).real / dd, 0.0, 1.0)
    near = a + t * d
    return np.abs(p - near), near


def contiguous_poly(poly) -> np.ndarray:
    """A polygon as the compiled functions take it: a contiguous (P,) complex array."""
    if isinstance(poly, np.ndarray) and poly.dtype == complex and poly.flags.c_contiguous:
        return poly
    return np.ascontiguousarray(as_complex(poly))


def polygon_gap(pa: np.ndarray, pb: np.ndarray) -> tuple[float, complex, complex]:
    """Distance between two disjoint convex polygons and the nearest points (on ``pa``, on
    ``pb``); 0 where they touch or overlap (then the points are a vertex and its nearest).
    Compiled (``sim.spatial.plane``)."""
    return plane.polygon_gap(contiguous_poly(pa), contiguous_poly(pb))


def clip_line(origin: complex, direction: complex, poly: np.ndarray) -> tuple[float, float]:
    """The interval of t where ``origin + t direction`` lies in the convex CCW polygon
    (boundary included); (inf, -inf) if the line misses it. Compiled
    (``sim.spatial.plane``)."""
    return plane.clip_line(complex(origin), complex(direction), contiguous_poly(poly))


def path_gaps(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """(n,) distance from each of ``points`` (x + iy) to the polyline ``path``: the least of
    :func:`to_segments` over its segments (inf for a path of fewer than two points), m.
    Compiled (``sim.spatial.plane``)."""
    pts = np.ascontiguousarray(points, dtype=complex).reshape(-1)
    return plane.path_gaps(pts, np.ascontiguousarray(path, dtype=complex).reshape(-1))


def clip_segments(
    a: np.ndarray, b: np.ndarray, centre: complex, axis: complex, half_len: float, half_w: float
) -> tuple[np.ndarray, np.ndarray]:
    """For segments ``a -> b`` (S,), the parameter interval [t0, t1] in [0, 1] that lies in the
    rectangle of ``centre``, unit ``axis`` (its long direction), half length ``half_len`` and
    half width ``half_w`` (Liang-Barsky); t0 > t1 where a segment misses it."""
    la = (a - centre) * np.conj(axis)
    lb = (b - centre) * np.conj(axis)
    t0, t1 = np.zeros(len(a)), np.ones(len(a))
    for p0, p1, half in ((la.real, lb.real, half_len), (la.imag, lb.imag, half_w)):
        d = p1 - p0
        for sign in (1.0, -1.0):  # sign * (p0 + t d) <= half
            num, den = half - sign * p0, sign * d
            with np.errstate(divide="ignore", invalid="ignore"):
                t = num / den
            flat = np.abs(den) < 1e-15
            t0 = np.where(~flat & (den < 0), np.maximum(t0, t), t0)
            t1 = np.where(~flat & (den > 0), np.minimum(t1, t), t1)
            out = flat & (num < 0)
            t0 = np.where(out, 2.0, t0)
    return t0, t1


def disc_polygon(centre: complex, radius_m: float, sides: int = 8) -> np.ndarray:
    """A regular polygon circumscribing the disc of ``radius_m`` round ``centre`` (CCW)."""
    return centre + _corners(radius_m, sides)


def disc_corners(radius_m: float, sides: int = 8) -> np.ndarray:
    """:func:`disc_polygon`'s corners round the origin (read-only): the polygon round a
    centre is the centre plus these."""
    return _corners(radius_m, sides)


@functools.lru_cache(maxsize=64)
def _corners(radius_m: float, sides: int) -> np.ndarray:
    """:func:`disc_polygon`'s corners round the origin (read-only, computed once)."""
    k = np.arange(sides)
    corner = radius_m / np.cos(np.pi / sides) * np.exp(1j * (np.pi / sides + 2 * np.pi * k / sides))
    corner.flags.writeable = False
    return corner


def walls(width_m: float, height_m: float, thick_m: float = 1.0) -> list[np.ndarray]:
    """The arena's four walls as rectangles outside it (CCW), as the pymunk world builds them."""
    w, h, t = width_m, height_m, thick_m
    boxes = [(-t, -t, w + t, 0.0), (-t, h, w + t, h + t), (-t, 0.0, 0.0, h), (w, 0.0, w + t, h)]
    return [
        np.array([x0 + 1j * y0, x1 + 1j * y0, x1 + 1j * y1, x0 + 1j * y1])
        for x0, y0, x1, y1 in boxes
    ]
