"""Which obstacles can a small query touch: bounding boxes bucketed on a uniform grid.

Single queries in plain Python (is this point free, does this short segment cross an obstacle,
how far is the nearest obstacle on each side of this segment) used to test every obstacle's
bounding box; in an arena with a hundred obstacles that loop is the cost. :class:`BoxBuckets`
files each box under the grid cells it overlaps, so a query rectangle looks at the boxes of the
cells it covers and nothing else. The answer is a superset of the boxes that meet the rectangle,
in ascending index order (callers that break ties by order see the same order as a full loop).
:class:`EdgeCells` does the same for the array query "nearest obstacle point" of many robots
at once: each cell of a grid lists the few edges that can be nearest to a point in it.
"""

from __future__ import annotations

from math import floor

import numpy as np

MAX_CELLS = 64  # a query covering more cells than this gets every box (a loop over all is as quick)


class BoxBuckets:
    """Axis-aligned boxes bucketed on square cells.

    Args:
        boxes: (x0, y0, x1, y1) per box.
        cell_m: cell side; about the size of a typical box works well.
    """

    def __init__(self, boxes: list[tuple[float, float, float, float]], cell_m: float) -> None:
        self.n = len(boxes)
        self.all_ = list(range(self.n))
        self.inv_ = 1.0 / cell_m
        self.ox_ = min((b[0] for b in boxes), default=0.0)
        self.oy_ = min((b[1] for b in boxes), default=0.0)
        self.cells_: dict[tuple[int, int], list[int]] = {}
        for k, (x0, y0, x1, y1) in enumerate(boxes):
            i0, j0, i1, j1 = self._span(x0, y0, x1, y1)
            for i in range(i0, i1 + 1):
                for j in range(j0, j1 + 1):
                    self.cells_.setdefault((i, j), []).append(k)

    def _span(self, x0: float, y0: float, x1: float, y1: float) -> tuple[int, int, int, int]:
        inv, ox, oy = self.inv_, self.ox_, self.oy_
        return (
            floor((x0 - ox) * inv),
            floor((y0 - oy) * inv),
            floor((x1 - ox) * inv),
            floor((y1 - oy) * inv),
        )

    def at(self, x: float, y: float) -> list[int]:
        """Boxes whose cell holds the point (x, y), ascending (a superset of those holding it)."""
        inv = self.inv_
        return self.cells_.get((floor((x - self.ox_) * inv), floor((y - self.oy_) * inv)), [])

    def near(self, x0: float, y0: float, x1: float, y1: float) -> list[int]:
        """Boxes that may meet the rectangle [x0, x1] x [y0, y1], ascending (a superset)."""
        i0, j0, i1, j1 = self._span(x0, y0, x1, y1)
        if (i1 - i0 + 1) * (j1 - j0 + 1) > MAX_CELLS:
            return self.all_
        cells, found = self.cells_, set()
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                hit = cells.get((i, j))
                if hit:
                    found.update(hit)
        return sorted(found)


def typical_size(boxes: list[tuple[float, float, float, float]]) -> float:
    """A cell side for :class:`BoxBuckets`: the median of the boxes' longer sides, >= 0.5 m."""
    sides = sorted(max(x1 - x0, y1 - y0) for x0, y0, x1, y1 in boxes)
    return max(0.5, sides[len(sides) // 2]) if sides else 1.0


EDGE_CELLS = 4096  # cells of an EdgeCells grid at most (about 1.6 m side for the 1000-robot arena)
EDGE_CELLS_MIN_EDGES = 48  # below this many edges a pass over all of them is as quick
_FAR = 1e150  # the padding edge: a point this far out is never the nearest


class EdgeCells:
    """For each cell of a square grid, the segments that can hold the nearest segment point of
    some point in the cell: a nearest-obstacle query looks at those and no others.

    A point p in cell C (centre c, half diagonal r) has d(p, e) <= d(c, e) + r for every
    segment e, so its nearest segment lies within d_min(c) + r of p and hence within
    d_min(c) + 2 r of c. Each cell keeps the segments with d(c, e) <= d_min(c) + 2 r (plus a
    micrometre for rounding), in ascending index order, padded with one far-away segment; every
    segment at the least distance from p is among them, so a query over them returns what a
    pass over all segments returns, bit for bit (the same arithmetic per segment, and the first
    of equal distances is the lowest index in both).

    Args:
        e0, e1: (E,) segment ends, x + iy.
        lo, hi: corners of the region the grid covers (points outside it have no cell).
        cells: at most this many cells.
    """

    def __init__(
        self, e0: np.ndarray, e1: np.ndarray, lo: complex, hi: complex, cells: int = EDGE_CELLS
    ) -> None:
        span = hi - lo
        side = max(float(np.sqrt(max(span.real * span.imag, 1e-12) / cells)), 0.25)
        self.nx = max(1, int(np.ceil(span.real / side)))
        self.ny = max(1, int(np.ceil(span.imag / side)))
        self.lo, self.inv, self.side = lo, 1.0 / side, side

        def near(dist: np.ndarray) -> np.ndarray:
            return dist <= dist.min(axis=1, keepdims=True) + np.sqrt(2.0) * side + 1e-6

        self.table = self._lists(e0, e1, near, len(e0))  # (cells, K), padding n
        self.e0 = np.append(e0, _FAR + 0j)  # the padding segment: a point far away
        self.d = np.append(e1 - e0, 0j)

    def within(self, reach_m: float) -> np.ndarray:
        """(cells, K) for each cell the indices of the segments that can come within
        ``reach_m`` of a point in it (d(c, e) <= reach + half the cell's diagonal, plus a
        micrometre), in ascending order, padded with -1: the candidates of a query for every
        segment in reach (the kernel's ``obstacles.obstacle_points``)."""
        bound = reach_m + np.sqrt(0.5) * self.side + 1e-6
        e0, d = self.e0[:-1], self.d[:-1]
        return self._lists(e0, e0 + d, lambda dist: dist <= bound, -1)

    def _lists(self, e0: np.ndarray, e1: np.ndarray, keep, pad: int) -> np.ndarray:
        """(cells, K): for each cell the indices of the segments ``keep`` (a map from the (P, E)
        distances of cell centres to segments to a bool mask) keeps, ascending, padded with
        ``pad``; K the most any cell keeps (at least 1)."""
        side = self.side
        xs = self.lo.real + side * (np.arange(self.nx) + 0.5)
        ys = self.lo.imag + side * (np.arange(self.ny) + 0.5)
        centres = (xs[None, :] + 1j * ys[:, None]).ravel()  # index = iy * nx + ix
        parts = []
        for a in range(0, len(centres), 256):  # bounded memory: 256 cells x E at a time
            kept = keep(_segment_distances(centres[a : a + 256], e0, e1))
            order = np.argsort(~kept, axis=1, kind="stable")  # kept ones first, ascending
            parts.append(np.where(np.take_along_axis(kept, order, axis=1), order, pad))
        width = max(1, max(int((p != pad).sum(axis=1).max()) for p in parts))
        return np.concatenate([p[:, :width] for p in parts])

    def cell_of(self, z: np.ndarray) -> np.ndarray:
        """(k,) cell index of each point, -1 outside the grid."""
        fx = np.floor((z.real - self.lo.real) * self.inv)
        fy = np.floor((z.imag - self.lo.imag) * self.inv)
        inside = (fx >= 0) & (fx < self.nx) & (fy >= 0) & (fy < self.ny)
        return np.where(inside, fy * self.nx + fx, -1).astype(np.intp)


def _segment_distances(p: np.ndarray, e0: np.ndarray, e1: np.ndarray) -> np.ndarray:
    """(P, E) distance from each point to each segment."""
    d = e1 - e0
    t = ((p[:, None] - e0) * d.conj()).real / np.maximum((d * d.conj()).real, 1e-24)
    return np.abs(e0 + np.clip(t, 0.0, 1.0) * d - p[:, None])
