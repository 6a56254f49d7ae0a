"""Which cells of a uniform grid see a point: the shadows of convex obstacles, row by row.

Seen from a point x, a convex obstacle O hides its *shadow*: the segments from x that enter O's
interior are those ending in the cone from x through O's two tangent vertices, beyond the edges
of O that face x. That is a convex region (two cone half-planes and one per facing edge). A cell
sees x from every point (``FULL``) if no shadow meets it, from no point (``NONE``) if one shadow
contains it, and otherwise maybe from some points (``PART``).

A convex region meets a row of cells over one interval of x: its extent on the row's two grid
lines and at its vertices inside the row. It contains the cells whose four corners lie within its
spans on both lines. The meeting test uses the region grown by ``MARGIN_M`` and the containing
test the region shrunk by it, so ``FULL`` and ``NONE`` hold for the planner's own segment test
(``GridPlanner.blocked``, whose obstacles are the inflated polygons shrunk by 1e-9 m) whatever
the rounding; only ``PART`` cells are left to an exact test.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# How a cell sees a point, as two bits: 1 = maybe not from every point, 2 = maybe from some.
# A group of cells sees it as the bitwise OR of its cells; DONT_CARE (no query can fall in the
# cell: inside an obstacle, outside the arena) is neutral.
DONT_CARE, NONE, FULL, PART = 0, 1, 2, 3
MARGIN_M = 1e-6  # certainty margin of FULL and NONE; far above rounding, far below a robot
_FEASIBLE_M = 1e-6  # a vertex of a region counts if no half-plane misses it by more


@dataclass(frozen=True, slots=True)
class Grid:
    """``nx`` x ``ny`` cells of ``dx_m`` x ``dy_m`` from the origin, numbered row by row."""

    dx_m: float
    dy_m: float
    nx: int
    ny: int

    def holds(self, xy: np.ndarray) -> np.ndarray:
        """(n,) True where a point (n, 2) lies on the grid (borders included)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        return (
            (xy >= 0).all(axis=1)
            & (xy[:, 0] <= self.nx * self.dx_m)
            & (xy[:, 1] <= self.ny * self.dy_m)
        )

    def cells(self, xy: np.ndarray) -> np.ndarray:
        """(n,) flat index (row * nx + column) of the cell holding each point (n, 2)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        col = np.clip(np.floor(xy[:, 0] / self.dx_m), 0, self.nx - 1).astype(np.int64)
        row = np.clip(np.floor(xy[:, 1] / self.dy_m), 0, self.ny - 1).astype(np.int64)
        return row * self.nx + col


def line_spans(normals: np.ndarray, offsets: np.ndarray, ys: np.ndarray):
    """Interval [lo, hi] of x where the line y = ys[l] lies in {p: n . p < c for every row}.

    Args:
        normals: (R, H, 2) half-plane normals of R convex regions (padding: (0, 0)).
        offsets: (R, H) offsets (padding: 1, always satisfied).
        ys: (L,) lines.

    Returns:
        lo, hi: (R, L); lo >= hi where the line misses the region.
    """
    nx, ny = normals[..., 0], normals[..., 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        at0, slope = offsets / nx, ny / nx  # bound(y) = at0 - slope * y on the line y
    lower, upper = nx < 0, nx > 0
    lo = _envelope(np.where(lower, at0, -np.inf), slope, ys, np.maximum, -np.inf)
    hi = _envelope(np.where(upper, at0, np.inf), slope, ys, np.minimum, np.inf)
    flat = nx == 0  # horizontal lines: n_y * y < c bounds y, not x
    with np.errstate(divide="ignore", invalid="ignore"):
        cut = offsets / ny
    y_hi = np.where(flat & (ny > 0), cut, np.inf).min(axis=1)
    y_lo = np.where(flat & (ny < 0), cut, -np.inf).max(axis=1)
    never = (flat & (ny == 0) & (offsets <= 0)).any(axis=1)
    miss = (ys[None] >= y_hi[:, None]) | (ys[None] <= y_lo[:, None]) | never[:, None]
    return lo, np.where(miss, -np.inf, hi)


def _envelope(at0: np.ndarray, slope: np.ndarray, ys: np.ndarray, pick, fill: float):
    """``pick`` (np.maximum or np.minimum) over h of at0[r, h] - slope[r, h] * ys: (R, L).
    Entries of at0 that are +-inf do not bound; columns with none bounding are skipped."""
    out = np.full((len(at0), len(ys)), fill)
    for h in np.flatnonzero(np.isfinite(at0).any(axis=0)).tolist():
        ok = np.isfinite(at0[:, h])
        term = np.where(ok, at0[:, h], fill)[:, None] - np.where(ok, slope[:, h], 0.0)[:, None] * ys
        pick(out, term, out=out)
    return out


def region_vertices(normals: np.ndarray, offsets: np.ndarray):
    """Corners of R convex regions: pairwise intersections of their lines that lie in the region.

    Returns:
        (R, P, 2) points and (R, P) True where the point is a corner (within ``_FEASIBLE_M``).
    """
    i, j = np.triu_indices(normals.shape[1], k=1)
    a, b = normals[:, i], normals[:, j]
    ca, cb = offsets[:, i], offsets[:, j]
    det = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (ca * b[..., 1] - cb * a[..., 1]) / det
        y = (a[..., 0] * cb - b[..., 0] * ca) / det
    pts = np.stack([x, y], axis=-1)
    ok = np.abs(det) > 1e-12
    miss = np.einsum("rhk,rpk->rph", normals, np.where(ok[..., None], pts, 0.0))
    miss -= offsets[:, None, :]
    ok &= (miss <= _FEASIBLE_M).all(axis=2)
    return pts, ok


def meet_rows(normals: np.ndarray, offsets: np.ndarray, grid: Grid, margin_m: float = MARGIN_M):
    """First and last column (R, ny) of the cells each of R convex regions, grown by
    ``margin_m``, meets in each row; first > last where it meets none."""
    h, hy, nx = grid.dx_m, grid.dy_m, grid.nx
    lo, hi = line_spans(normals, offsets + margin_m, np.arange(grid.ny + 1) * hy)
    lo, hi = np.where(lo < hi, lo, np.inf), np.where(lo < hi, hi, -np.inf)
    xmin = np.minimum(lo[:, :-1], lo[:, 1:])
    xmax = np.maximum(hi[:, :-1], hi[:, 1:])
    pts, ok = region_vertices(normals, offsets + margin_m)
    r, p = np.nonzero(ok & (pts[..., 1] >= 0) & (pts[..., 1] < grid.ny * hy))
    if r.size:
        row = np.minimum((pts[r, p, 1] / hy).astype(np.int64), grid.ny - 1)
        np.minimum.at(xmin, (r, row), pts[r, p, 0])
        np.maximum.at(xmax, (r, row), pts[r, p, 0])
    first = np.floor(np.clip(xmin / h, -1.0, nx + 1.0)).astype(np.int64)
    last = np.floor(np.clip(xmax / h, -1.0, nx + 1.0)).astype(np.int64)
    return np.maximum(first, 0), np.minimum(last, nx - 1)


def inside_rows(normals: np.ndarray, offsets: np.ndarray, grid: Grid, margin_m: float = MARGIN_M):
    """First and last column (R, ny) of the cells each of R convex regions, shrunk by
    ``margin_m``, contains in each row (all four corners inside); first > last where none."""
    h, nx = grid.dx_m, grid.nx
    lo, hi = line_spans(normals, offsets - margin_m, np.arange(grid.ny + 1) * grid.dy_m)
    left = np.maximum(lo[:, :-1], lo[:, 1:])
    right = np.minimum(hi[:, :-1], hi[:, 1:])
    first = np.ceil(np.clip(left / h, -1.0, nx + 1.0)).astype(np.int64)
    last = np.floor(np.clip(right / h, -1.0, nx + 1.0)).astype(np.int64) - 1
    return np.maximum(first, 0), np.minimum(last, nx - 1)


def paint(lo: np.ndarray, hi: np.ndarray, owner: np.ndarray, n_out: int, grid: Grid):
    """(n_out, ny, nx) count of the column ranges [lo, hi] (R, ny) covering each cell;
    range r belongs to ``owner[r]``."""
    width = grid.nx + 1
    r, row = np.nonzero(lo <= hi)
    base = (owner[r] * grid.ny + row) * width
    size = n_out * grid.ny * width
    diff = np.bincount(base + lo[r, row], minlength=size)
    diff -= np.bincount(base + hi[r, row] + 1, minlength=size)
    return np.cumsum(diff.reshape(n_out, grid.ny, width), axis=2)[..., : grid.nx]


@dataclass(frozen=True, slots=True)
class Obstacles:
    """Convex obstacles padded to E edges: vertices (K, E, 2) (padding repeats the first),
    outward normals (K, E, 2), offsets (K, E) and which edges are real (K, E)."""

    verts: np.ndarray
    normals: np.ndarray
    offsets: np.ndarray
    real: np.ndarray


def tangents(x: np.ndarray, polys: Obstacles):
    """Each obstacle seen from each point (P, 2): its edges facing the point (P, K, E) and the
    directions (P, K, 2) to its right and left tangent vertices (all of it lies
    counter-clockwise from the first and clockwise from the second)."""
    side = np.einsum("pj,kej->pke", x, polys.normals) - polys.offsets
    front = (side >= 0) & polys.real
    d = polys.verts[None] - x[:, None, None, :]  # (P, K, E, 2)
    cross = d[..., :, None, 0] * d[..., None, :, 1] - d[..., :, None, 1] * d[..., None, :, 0]
    here = np.hypot(d[..., 0], d[..., 1]) < 1e-9  # the point is this vertex: no tangent
    cross = np.where(here[..., None, :], 0.0, cross)
    right = np.argmax(np.where(here, -np.inf, cross.min(axis=3)), axis=2)
    left = np.argmin(np.where(here, np.inf, cross.max(axis=3)), axis=2)
    dr = np.take_along_axis(d, right[..., None, None], axis=2)[:, :, 0]
    dl = np.take_along_axis(d, left[..., None, None], axis=2)[:, :, 0]
    return front, dr, dl


def shadow_halfplanes(points: np.ndarray, polys: Obstacles):
    """Half-planes of the shadow of every obstacle seen from every point.

    Args:
        points: (P, 2).
        polys: :class:`Obstacles`.

    Returns:
        The whole shadows: normals (P * K, 2 + E, 2) and offsets (P * K, 2 + E), point-major
        (region p * K + k is obstacle k seen from point p); and the shadows less the obstacles
        themselves, one convex piece per edge facing away from the point (the cone beyond that
        edge): normals (N, 3, 2), offsets (N, 3) and the point (N,) of each. A point inside
        an obstacle's interior sees nothing: that shadow is the whole plane.
    """
    x = np.asarray(points, dtype=float).reshape(-1, 2)
    n_pts, (k, e) = len(x), polys.offsets.shape
    front, dr, dl = tangents(x, polys)
    nr = np.stack([dr[..., 1], -dr[..., 0]], axis=-1)
    nl = np.stack([-dl[..., 1], dl[..., 0]], axis=-1)
    nr /= np.linalg.norm(nr, axis=-1, keepdims=True)
    nl /= np.linalg.norm(nl, axis=-1, keepdims=True)
    cone = front.any(axis=2)
    cone_n = np.zeros((n_pts, k, 2, 2))
    cone_c = np.ones((n_pts, k, 2))
    cone_n[:, :, 0][cone], cone_n[:, :, 1][cone] = nr[cone], nl[cone]
    cone_c[:, :, 0] = np.where(cone, np.einsum("pkj,pj->pk", nr, x), 1.0)
    cone_c[:, :, 1] = np.where(cone, np.einsum("pkj,pj->pk", nl, x), 1.0)
    edge_n = np.broadcast_to(polys.normals, (n_pts, k, e, 2))
    edge_c = np.broadcast_to(polys.offsets, (n_pts, k, e))
    normals = np.concatenate([cone_n, np.where(front[..., None], edge_n, 0.0)], axis=2)
    offsets = np.concatenate([cone_c, np.where(front, edge_c, 1.0)], axis=2)
    p, kk, ee = np.nonzero(polys.real & ~front)
    piece_n = np.concatenate([cone_n[p, kk], -edge_n[p, kk, ee][:, None]], axis=1)
    piece_c = np.concatenate([cone_c[p, kk], -edge_c[p, kk, ee][:, None]], axis=1)
    whole = (normals.reshape(n_pts * k, 2 + e, 2), offsets.reshape(n_pts * k, 2 + e))
    return whole, (piece_n, piece_c, p)


def visibility(points: np.ndarray, polys: Obstacles, grid: Grid, chunk: int = 16) -> np.ndarray:
    """(P, ny, nx) uint8: ``FULL``, ``PART`` or ``NONE``, how each cell sees each point."""
    x = np.asarray(points, dtype=float).reshape(-1, 2)
    out = np.full((len(x), grid.ny, grid.nx), FULL, dtype=np.uint8)
    k = len(polys.offsets)
    if not k:
        return out
    for s in range(0, len(x), chunk):
        part = x[s : s + chunk]
        (normals, offsets), (piece_n, piece_c, piece_of) = shadow_halfplanes(part, polys)
        meets = paint(*meet_rows(piece_n, piece_c, grid), piece_of, len(part), grid)
        owner = np.repeat(np.arange(len(part)), k)
        hidden = paint(*inside_rows(normals, offsets, grid), owner, len(part), grid)
        out[s : s + chunk] = np.where(hidden > 0, NONE, np.where(meets > 0, PART, FULL))
    return out


class SightIndex:
    """Which obstacles can cut a sight line from each of P points, by direction.

    Seen from a point, an obstacle covers the directions between its two tangents; the circle
    of directions is cut into ``bins`` sectors and each sector lists the obstacles that cover
    any of it (with a small angular margin). A segment from the point can be blocked only by
    the obstacles of its direction's sector, so an exact test needs only those.
    """

    def __init__(
        self, points: np.ndarray, polys: Obstacles, bins: int = 1024, chunk: int = 64
    ) -> None:
        x = np.asarray(points, dtype=float).reshape(-1, 2)
        self.points, self.bins = x, bins
        n_pts, k = len(x), len(polys.offsets)
        counts, obstacles = [np.zeros(1, dtype=np.int64)], [np.zeros(0, dtype=np.int16)]
        step = 2 * np.pi / bins
        for c0 in range(0, n_pts if k else 0, chunk):
            part = x[c0 : c0 + chunk]
            front, dr, dl = tangents(part, polys)
            a0 = np.arctan2(dr[..., 1], dr[..., 0]) - 1e-6
            width = np.mod(np.arctan2(dl[..., 1], dl[..., 0]) - a0, 2 * np.pi) + 2e-6
            width = np.where(front.any(axis=2), np.minimum(width, 2 * np.pi), 2 * np.pi)
            lo = np.floor(a0 / step).astype(np.int64)
            n = np.minimum(np.floor((a0 + width) / step).astype(np.int64) - lo + 1, bins)
            p, kk = np.nonzero(n > 0)
            n = n[p, kk]
            offset = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
            key = np.repeat(p * bins, n) + np.mod(np.repeat(lo[p, kk], n) + offset, bins)
            order = np.argsort(key, kind="stable")
            obstacles.append(np.repeat(kk, n)[order].astype(np.int16))
            counts.append(np.bincount(key, minlength=len(part) * bins))
        if not k:
            counts.append(np.zeros(n_pts * bins, dtype=np.int64))
        self.start_ = np.cumsum(np.concatenate(counts))
        self.obstacle_ = np.concatenate(obstacles)

    @property
    def nbytes(self) -> int:
        return self.obstacle_.nbytes + self.start_.nbytes

    def candidates(self, point: np.ndarray, towards: np.ndarray):
        """For segments from ``points[point[s]]`` to ``towards[s]`` (S, 2): (segment, obstacle)
        pairs that may cut them, as two arrays."""
        d = towards - self.points[point]
        sector = np.floor(np.arctan2(d[:, 1], d[:, 0]) / (2 * np.pi / self.bins)).astype(np.int64)
        row = point * self.bins + np.mod(sector, self.bins)
        lo, hi = self.start_[row], self.start_[row + 1]
        n = hi - lo
        seg = np.repeat(np.arange(len(point)), n)
        idx = np.repeat(lo - np.cumsum(n) + n, n) + np.arange(n.sum())
        return seg, self.obstacle_[idx]


def polygon_cells(polys: Obstacles, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """(ny, nx) True where a cell meets an obstacle (grown by ``MARGIN_M``), and where it lies
    inside one (by more than ``MARGIN_M``)."""
    if not len(polys.offsets):
        none = np.zeros((grid.ny, grid.nx), dtype=bool)
        return none, none
    normals = np.where(polys.real[..., None], polys.normals, 0.0)
    offsets = np.where(polys.real, polys.offsets, 1.0)
    owner = np.zeros(len(offsets), dtype=np.int64)
    meets = paint(*meet_rows(normals, offsets, grid), owner, 1, grid)[0] > 0
    return meets, paint(*inside_rows(normals, offsets, grid), owner, 1, grid)[0] > 0
