"""Free widths of a path segment, compiled: what ``PathFollower._free`` computes for one.

A robot that heads straight for its waypoint stays within its offset from the segment, so it
cannot touch an obstacle while that offset is below the segment's distance to the obstacles on
that side less its radius: the segment's free width (``sim.spatial.navigation.paths``). The
follower of a large team computes a side step's widths only as far as ``cap_m`` and flags them;
the moment a robot on such a segment is, or could stop, farther off than a flagged width,
:func:`refine` computes it exactly here, as ``PathFollower._refine`` does (the same arithmetic
per vertex and edge, so the same widths).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit


class Shapes(NamedTuple):
    """The obstacles as the follower keeps them (``views.shapes_of``): vertices ``verts`` and
    edges ``e0`` -> ``e1`` (x + iy), each obstacle's first vertex and first edge."""

    verts: np.ndarray
    vert_start: np.ndarray
    e0: np.ndarray
    e1: np.ndarray
    edge_start: np.ndarray


@njit(cache=True)
def to_segment(p, s0, s1):
    """Distance from point p to segment s0 -> s1 (``paths._to_segments`` for one pair)."""
    d = s1 - s0
    dd = (d * d.conjugate()).real
    t = ((p - s0) * d.conjugate()).real / max(dd, 1e-24)
    t = min(max(t, 0.0), 1.0)
    return abs(p - s0 - t * d)


@njit(cache=True)
def free_widths(a, b, shapes, radius_m):
    """The free width left and right of segment a -> b: the distance to the nearest obstacle
    on that side (one that straddles the segment's line counts on both) less the robot
    radius, at least 0 (``PathFollower._free``)."""
    n = shapes.vert_start.shape[0]
    left, right = np.inf, np.inf
    unit = (b - a) / max(abs(b - a), 1e-12)
    for o in range(n):
        v_end = shapes.vert_start[o + 1] if o + 1 < n else shapes.verts.shape[0]
        e_end = shapes.edge_start[o + 1] if o + 1 < n else shapes.e0.shape[0]
        dist = np.inf
        for k in range(shapes.edge_start[o], e_end):
            ends = min(
                to_segment(a, shapes.e0[k], shapes.e1[k]), to_segment(b, shapes.e0[k], shapes.e1[k])
            )
            dist = min(dist, ends)
        on_left, on_right = False, False
        for q in range(shapes.vert_start[o], v_end):
            dist = min(dist, to_segment(shapes.verts[q], a, b))
            side = ((shapes.verts[q] - a) * unit.conjugate()).imag  # > 0: left of the segment
            on_left = on_left or side > -1e-9
            on_right = on_right or side < 1e-9
        dist -= radius_m
        if on_left:
            left = min(left, dist)
        if on_right:
            right = min(right, dist)
    return max(left, 0.0), max(right, 0.0)


@njit(cache=True)
def refine(j, lo, hi, fol, shapes, radius_m):
    """Robot j at offsets (minus left) between ``lo`` and ``hi`` of its segment: where it is
    beyond a width only known to be at least ``cap_m``, compute that width exactly and keep it
    (``PathFollower._refine``). True if one was."""
    need = fol.capped[0, j] and lo < fol.free[0, j]
    need = need or (fol.capped[1, j] and hi > fol.free[1, j])
    if not need:
        return False
    idx = fol.index[j]
    left, right = free_widths(fol.points[j, idx - 1], fol.points[j, idx], shapes, radius_m)
    fol.free_m[j, idx, 0], fol.free_m[j, idx, 1] = left, right
    fol.capped_m[j, idx, 0] = fol.capped_m[j, idx, 1] = False
    fol.free[0, j], fol.free[1, j] = -left, right
    fol.capped[0, j] = fol.capped[1, j] = False
    return True
