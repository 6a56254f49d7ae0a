"""Which obstacles can a small query touch: bounding boxes bucketed on a uniform grid.

Single queries in plain Python (is this point free, does this short segment cross an obstacle,
how far is the nearest obstacle on each side of this segment) used to test every obstacle's
bounding box; in an arena with a hundred obstacles that loop is the cost. :class:`BoxBuckets`
files each box under the grid cells it overlaps, so a query rectangle looks at the boxes of the
cells it covers and nothing else. The answer is a superset of the boxes that meet the rectangle,
in ascending index order (callers that break ties by order see the same order as a full loop).
"""

from __future__ import annotations

from math import floor

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
