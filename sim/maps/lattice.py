"""Exact predicates on integer points (half cells): areas, turns, segments that meet.

Every corner the map geometry produces is an integer in half cells, so these tests have no
rounding: a turn is left, right or straight, two segments meet or they do not.
"""

from __future__ import annotations

import numpy as np


def area2(p: np.ndarray) -> int:
    """Twice the signed area of a closed polygon (k, 2) (> 0: counter-clockwise)."""
    x, y = p[:, 0], p[:, 1]
    return int((x * np.roll(y, -1) - np.roll(x, -1) * y).sum())


def cross(u: np.ndarray, w: np.ndarray) -> int:
    """The z component of u x w for two integer vectors (> 0: w turns left of u)."""
    return int(u[0]) * int(w[1]) - int(u[1]) * int(w[0])


def turns(p: np.ndarray) -> np.ndarray:
    """(k,) u x w at each corner of a closed polygon, u coming in and w going out."""
    u, w = p - np.roll(p, 1, axis=0), np.roll(p, -1, axis=0) - p
    return u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0]


def orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Sign of the turn a -> b -> c, row by row (+1 left, -1 right, 0 collinear)."""
    ab, ac = b - a, c - a
    return np.sign(ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0])


def segments_touch(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """(m,) True where segment p1-q1 and segment p2-q2 share a point, ends included (the caller
    has checked that their bounding boxes meet, which decides the collinear case)."""
    o1, o2 = orient(p1, q1, p2), orient(p1, q1, q2)
    o3, o4 = orient(p2, q2, p1), orient(p2, q2, q1)
    collinear = (o1 == 0) & (o2 == 0)
    return np.where(collinear, True, (o1 * o2 <= 0) & (o3 * o4 <= 0))
