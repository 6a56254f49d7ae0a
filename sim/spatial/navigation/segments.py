"""Which segments cross an inflated obstacle: the planner's visibility test, compiled.

:meth:`sim.spatial.navigation.planning.GridPlanner.blocked` asks it for every visibility
question: the graph between obstacle vertices when a planner is built (V (V - 1) / 2 segments),
a new goal against every vertex, and a bid's straight lines. Each segment is tested against the
obstacles whose bounding box it meets (strictly) by Cyrus-Beck clipping; a boundary touched or
run along does not block. The arithmetic is the planner's numpy test's, term by term and in
the same order (no fused multiply-add: numba fuses only with ``fastmath``), so the answers are
the same bit for bit (tests/spatial/navigation/test_segments.py).

numba caches the compiled function beside this module (``__pycache__``); a cold cache costs
about a second, once.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def blocked_segments(
    a: np.ndarray,
    b: np.ndarray,
    polys: np.ndarray,
    bb_lo: np.ndarray,
    bb_hi: np.ndarray,
    normals: np.ndarray,
    offsets: np.ndarray,
    n_edges: np.ndarray,
    tol: float,
) -> np.ndarray:
    """(S,) True where segment a[s] -> b[s] (m) enters the interior of one of the obstacles
    ``polys`` (indices into the (P, E, 2) ``normals``, (P, E) ``offsets`` of inflated convex
    polygons with ``n_edges[k]`` real edges each, and their bounding boxes ``bb_lo``,
    ``bb_hi``); an edge's inside is ``n . x < offset - tol``."""
    out = np.zeros(a.shape[0], dtype=np.bool_)
    for s in range(a.shape[0]):
        ax, ay, bx, by = a[s, 0], a[s, 1], b[s, 0], b[s, 1]
        lox, hix = min(ax, bx), max(ax, bx)
        loy, hiy = min(ay, by), max(ay, by)
        dx, dy = bx - ax, by - ay
        for q in range(polys.shape[0]):
            k = polys[q]
            if not (
                lox < bb_hi[k, 0] and loy < bb_hi[k, 1] and hix > bb_lo[k, 0] and hiy > bb_lo[k, 1]
            ):
                continue
            t_lo, t_hi = 0.0, 1.0
            never = False
            for e in range(n_edges[k]):
                nx, ny = normals[k, e, 0], normals[k, e, 1]
                num = offsets[k, e] - tol - (nx * ax + ny * ay)
                den = nx * dx + ny * dy
                if den > 0.0:
                    t = num / den
                    if t < t_hi:
                        t_hi = t
                elif den < 0.0:
                    t = num / den
                    if t > t_lo:
                        t_lo = t
                elif num <= 0.0:  # parallel to this edge and outside it: misses the polygon
                    never = True
                    break
            if not never and t_lo < t_hi:
                out[s] = True
                break
    return out
