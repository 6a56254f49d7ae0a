"""Path planning in the arena: exact any-angle shortest paths around inflated obstacles.

Every obstacle is a convex polygon. Grown by the robot radius plus a clearance, it becomes a
larger convex polygon (edges offset outward, sharp corners bevelled), so the free space of a robot
centre is a polygonal domain. Shortest paths in such a domain run straight between polygon
vertices: the planner keeps the visibility graph of those vertices and its all-pairs shortest
paths (``scipy.sparse.csgraph``), and for each goal point the geodesic distance from every vertex
to it (task sites are a finite set of points, so these fields are cached). A query tests the
straight line first; only if it is blocked it tests the vertices in order of their lower bound
|p - u| + D(u), a few at a time, and the first visible one gives the exact geodesic. In open space
the planned distance *is* the straight line, around obstacles it is never shorter. An occupancy
grid at ``grid_res_m`` is kept for rendering and debugging only.

A fleet bids on the scenario's task sites every round: from ``FIELD_MIN_ROBOTS`` robots on,
``distances`` looks those sites up in a distance field (``sim.spatial.navigation.distfield``: per
cell and site the vertex, or the site itself, that the query above would find), built once on first
use and shared by the planners of one process. Smaller calls, and points that are not task sites,
take the query above, so small scenarios never build a field and keep their results bit for bit.
"""

from __future__ import annotations

import functools

import numpy as np

from sim.scenario import SpatialSpec
from sim.spatial.navigation.buckets import BoxBuckets, typical_size
from sim.spatial.navigation.distfield import SHARED, DistanceField
from sim.spatial.navigation.geodesics import visibility_geodesics
from sim.spatial.navigation.segments import blocked_segments
from sim.spatial.navigation.shapes import grown_shape

_TOL_M = 1e-9  # boundaries count as free: segments may run along an inflated edge
_SNAP_M = 1e-6  # how far past a boundary a point pushed out of an obstacle lands
CHUNK = 1 << 20  # (pair, edge) entries per vectorised visibility chunk
_FIRST_BATCH = 8  # vertices tested per query in the first round (then 4x more each round)
FIELD_MIN_ROBOTS = 256  # distances for this many positions or more come from the field
LOCAL_MIN_VERTICES = 256  # path_around in an arena with more vertices plans in a local box ...
LOCAL_MARGIN_M = 6.0  # ... this much round the start, the goal and the robots, m
GROWN_MAX = 4096  # grown shapes of path_around's robots a planner keeps (then it starts again)


PAIRS_CACHED = 256  # graphs of at most this many vertices share their index pairs (path_around)
FREE_ONE_MAX = 16  # GridPlanner.free tests this many points or fewer one by one


def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``np.triu_indices(n, k=1)``: every pair of n vertices, i < j, row by row (read-only
    and shared for small n, where working them out costs as much as the rest of a graph)."""
    return _small_pairs(n) if n <= PAIRS_CACHED else np.triu_indices(n, k=1)


@functools.lru_cache(maxsize=8)
def _small_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    i, j = np.triu_indices(n, k=1)
    i.flags.writeable = j.flags.writeable = False
    return i, j


def _is_points(poly) -> bool:
    """True if ``poly`` is a tuple of (x, y) tuples of floats already, as
    :meth:`GridPlanner.set_obstacles` keeps its obstacles (it need not be converted again)."""
    return type(poly) is tuple and all(
        type(p) is tuple and len(p) == 2 and type(p[0]) is float and type(p[1]) is float
        for p in poly
    )


def halfplanes(poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward unit normals (E, 2) and offsets (E,) of a convex CCW polygon: inside is n.x < c."""
    edge = np.concatenate((poly[1:], poly[:1])) - poly  # np.roll(poly, -1, axis=0), quicker
    normal = np.column_stack([edge[:, 1], -edge[:, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return normal, np.einsum("ij,ij->i", normal, poly)


def inflate(poly: np.ndarray, d_m: float) -> np.ndarray:
    """Grow a convex CCW polygon by ``d_m``: a convex polygon containing its Minkowski sum with
    a disc. Corners sharper than 90 degrees get a bevel tangent to the rounded corner."""
    if d_m <= 0:
        return np.array(poly, dtype=float)
    normal, offset = halfplanes(poly)
    lines_n, lines_c = [], []
    for i in range(len(poly)):
        prev = normal[i - 1]
        # dot products written out (not @): BLAS rounds them by CPU model
        # (tests/golden/test_golden.py)
        if prev[0] * normal[i, 0] + prev[1] * normal[i, 1] < 0.0:
            bis = prev + normal[i]
            bis /= np.sqrt(bis[0] * bis[0] + bis[1] * bis[1])
            lines_n.append(bis)
            lines_c.append(bis[0] * poly[i][0] + bis[1] * poly[i][1] + d_m)
        lines_n.append(normal[i])
        lines_c.append(offset[i] + d_m)
    n, c = np.array(lines_n), np.array(lines_c)
    n2, c2 = np.concatenate((n[-1:], n[:-1])), np.concatenate((c[-1:], c[:-1]))  # np.roll(_, 1)
    det = n2[:, 0] * n[:, 1] - n2[:, 1] * n[:, 0]
    x = (c2 * n[:, 1] - c * n2[:, 1]) / det
    y = (n2[:, 0] * c - n[:, 0] * c2) / det
    return np.column_stack([x, y])


def polygon_signed_distance(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Signed distance (m) from each point (n, 2) to a convex CCW polygon: < 0 inside."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.einsum("pej,ej->pe", pts[:, None, :] - a[None], ab) / np.einsum("ej,ej->e", ab, ab)
    closest = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    dist = np.linalg.norm(pts[:, None, :] - closest, axis=2).min(axis=1)
    normal, offset = halfplanes(poly)
    # written out, not pts @ normal.T: BLAS's kernel, and so the last bit, depends on the CPU
    side = pts[:, :1] * normal[:, 0] + pts[:, 1:] * normal[:, 1]
    inside = (side - offset < 0).all(axis=1)
    return np.where(inside, -dist, dist)


class GridPlanner:
    """Shortest paths for a robot centre among the inflated obstacles of a spatial scenario.

    Args:
        spatial: the arena; obstacles are grown by ``drive.radius_m + clearance_m``.
        local_min_vertices: :meth:`path_around` in an arena with more obstacle vertices than
            this plans in a local box (the same path, quicker in a large arena).
        chunk: (pair, edge) entries per vectorised visibility chunk (bounds the temporaries;
            the result does not depend on it).
        grown_max: grown shapes of :meth:`path_around`'s robots kept (``grown_``; past it the
            planner starts again; the result does not depend on it).
    """

    def __init__(
        self,
        spatial: SpatialSpec,
        local_min_vertices: int = LOCAL_MIN_VERTICES,
        chunk: int = CHUNK,
        grown_max: int = GROWN_MAX,
    ) -> None:
        self.spatial = spatial
        self.local_min_vertices, self.chunk, self.grown_max = local_min_vertices, chunk, grown_max
        self.inflate_m = spatial.drive.radius_m + spatial.clearance_m
        self.tol_m = _TOL_M
        lo = self.inflate_m
        self.lo_ = np.array([lo, lo])
        self.hi_ = np.array([spatial.width_m - lo, spatial.height_m - lo])
        self.box_ = (*(self.lo_ - _TOL_M).tolist(), *(self.hi_ + _TOL_M).tolist())
        self.grown_: dict[tuple, tuple] = {}  # :meth:`set_obstacles`' grown shapes of others
        self.set_obstacles(spatial.obstacles)

    def set_obstacles(self, obstacles, known: tuple[GridPlanner, int] | None = None) -> None:
        """Plan around these convex polygons (m, counter-clockwise) from now on, instead of
        the scenario's; every cached distance (goal fields, the fleet's distance field) is
        dropped with the old ones.

        ``known``: (a planner, n), whose obstacles block the same segments between this
        planner's vertices as the first n of these do (the same ones, or those of them near a
        box that holds every vertex here). Whether two of its vertices see each other is then
        looked up in its visibility graph, and only the obstacles past the n are tested
        (:meth:`_visible`); the graph is the same as without it. The grown shapes of its
        obstacles are taken from it too (:meth:`_shape`, the same computation), and those of
        the others are kept in its ``grown_`` (at most its ``grown_max``) for the next planner
        given it: :meth:`path_around`'s robots at work stand where they stood."""
        self.obstacles = tuple(
            p if _is_points(p) else tuple(map(tuple, np.asarray(p, dtype=float).tolist()))
            for p in obstacles
        )
        same = known is not None and known[0].inflate_m == self.inflate_m
        had = known[0].shapes_ if same else {}
        grown = known[0].grown_ if same else {}
        if same and len(grown) > known[0].grown_max:
            grown.clear()
        self.shapes_ = {}
        for o in self.obstacles:
            shape = had.get(o) or grown.get(o)
            if shape is None:
                shape = grown[o] = self._shape(o)
            self.shapes_[o] = shape
        shapes = [self.shapes_[o] for o in self.obstacles]
        polys = [shape[0] for shape in shapes]
        self.polygons_ = polys
        n_edges = max((len(p) for p in polys), default=1)
        self.normals_ = np.zeros((len(polys), n_edges, 2))
        self.offsets_ = np.ones((len(polys), n_edges))  # padding edges: 0 < 1 always holds
        self.real_ = np.zeros((len(polys), n_edges), dtype=bool)
        for k, (p, n, c, *_) in enumerate(shapes):
            self.normals_[k, : len(p)], self.offsets_[k, : len(p)] = n, c
            self.real_[k, : len(p)] = True
        self.bb_lo_ = np.array([shape[3] for shape in shapes], dtype=float).reshape(-1, 2)
        self.bb_hi_ = np.array([shape[4] for shape in shapes], dtype=float).reshape(-1, 2)
        self.n_edges_ = self.real_.sum(axis=1).astype(np.int64)
        self.all_polys_ = np.arange(len(polys), dtype=np.int64)
        # the same as Python floats, for single queries (blocked_one, free_one)
        self.scalar_ = [(*lo, *hi, edges) for *_, lo, hi, edges in shapes]
        boxes = [
            (*lo, *hi) for lo, hi in zip(self.bb_lo_.tolist(), self.bb_hi_.tolist(), strict=True)
        ]
        self.buckets_ = BoxBuckets(boxes, typical_size(boxes))
        verts = np.concatenate(polys) if polys else np.zeros((0, 2))
        self.vertices_ = verts[self.free(verts)]
        self.vertex_at_: dict[tuple[float, float], int] | None = None
        self._build_graph(known)
        self._fields: dict[tuple[float, float], tuple[np.ndarray, np.ndarray]] = {}
        self._occupancy: np.ndarray | None = None
        self.field_: DistanceField | None = None

    def _shape(self, obstacle: tuple) -> tuple:
        """An obstacle (a tuple of its corners) grown by ``inflate_m``: the polygon (P, 2), its
        outward normals (P, 2) and offsets (P,) (:func:`halfplanes`), its bounding box's low
        and high corner and its edges (normal x, normal y, offset), as Python floats."""
        corners = np.ascontiguousarray(obstacle, dtype=float)
        if self.inflate_m > 0 and len(corners) >= 3:  # compiled: inflate, then halfplanes
            poly, normal, offset = grown_shape(corners, self.inflate_m)
        else:
            poly = inflate(corners, self.inflate_m)
            normal, offset = halfplanes(poly)
        pairs = zip(normal.tolist(), offset.tolist(), strict=True)
        edges = [(nx, ny, c) for (nx, ny), c in pairs]
        lo, hi = poly.min(axis=0).tolist(), poly.max(axis=0).tolist()
        return poly, normal, offset, lo, hi, edges

    def _build_graph(self, known: tuple[GridPlanner, int] | None = None) -> None:
        """All-pairs geodesics between the vertices: ``apsp_`` (V, V) m, ``pred_`` (V, V);
        ``seen_`` (V (V - 1) / 2,) which pairs i < j see each other (``np.triu_indices``
        order). ``known``: as :meth:`set_obstacles`."""
        v = self.vertices_
        nv = len(v)
        i, j = _pairs(nv)
        ok = ~self.blocked(v[i], v[j]) if known is None else self._visible(*known, i, j)
        self.seen_ = ok
        # scipy's undirected Dijkstra from every vertex, compiled (the same numbers)
        self.apsp_, self.pred_ = visibility_geodesics(v, i[ok], j[ok])

    def _visible(self, known: GridPlanner, n: int, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Whether vertices i[s] and j[s] see each other, :meth:`_build_graph`'s test: a pair
        of ``known``'s vertices (found by their coordinates: the test depends on nothing
        else) sees each other if it does there and no obstacle past the first ``n`` blocks
        it; every other pair is tested in full (``known``, ``n``: as :meth:`set_obstacles`)."""
        v = self.vertices_
        at = known.vertex_index()
        g = np.array([at.get(p, -1) for p in map(tuple, v.tolist())], dtype=np.intp)
        gi, gj = g[i], g[j]
        old = (gi >= 0) & (gj >= 0) & (gi != gj)
        ok = np.empty(len(i), dtype=bool)
        new = ~old
        ok[new] = ~self.blocked(v[i[new]], v[j[new]])
        lo, hi = np.minimum(gi[old], gj[old]), np.maximum(gi[old], gj[old])
        nk = len(known.vertices_)
        seen = known.seen_[lo * nk - lo * (lo + 1) // 2 + (hi - lo - 1)]
        rest = np.arange(n, len(self.polygons_))
        s = np.flatnonzero(old)[seen]
        ok[old] = seen
        ok[s] = ~self.blocked(v[i[s]], v[j[s]], rest)
        return ok

    def vertex_index(self) -> dict[tuple[float, float], int]:
        """Index of a vertex by its coordinates (x, y) (coincident vertices: one of them)."""
        if self.vertex_at_ is None:
            pts = map(tuple, self.vertices_.tolist())
            self.vertex_at_ = {p: k for k, p in enumerate(pts)}
        return self.vertex_at_

    def free(self, xy: np.ndarray) -> np.ndarray:
        """(n,) True where a robot centre may be: in the arena and clear of every obstacle.
        A few points (at most ``FREE_ONE_MAX``) are tested one by one (:meth:`free_one`: only
        the obstacles whose box holds the point, the same sums)."""
        pts = np.asarray(xy, dtype=float).reshape(-1, 2)
        if len(pts) <= FREE_ONE_MAX:
            return np.array([self.free_one(x, y) for x, y in pts.tolist()], dtype=bool)
        inside = ((pts >= self.lo_ - _TOL_M) & (pts <= self.hi_ + _TOL_M)).all(axis=1)
        if len(self.polygons_):
            proj = np.einsum("nj,pej->npe", pts, self.normals_) - self.offsets_[None]
            inside &= ~(proj < -_TOL_M).all(axis=2).any(axis=1)
        return inside

    def reachable(self, xy) -> bool:
        """True if a robot centre can stand at ``xy`` (in the arena, clear of obstacles)."""
        return bool(self.free(np.asarray(xy, dtype=float))[0])

    @property
    def occupancy(self) -> np.ndarray:
        """(ny, nx) bool grid at ``grid_res_m``: True where a robot centre cannot be."""
        if self._occupancy is None:
            res = self.spatial.grid_res_m
            xs = np.arange(res / 2, self.spatial.width_m, res)
            ys = np.arange(res / 2, self.spatial.height_m, res)
            gx, gy = np.meshgrid(xs, ys)
            free = self.free(np.column_stack([gx.ravel(), gy.ravel()]))
            self._occupancy = ~free.reshape(gy.shape)
        return self._occupancy

    def blocked(self, a: np.ndarray, b: np.ndarray, polys: np.ndarray | None = None) -> np.ndarray:
        """(S,) True where segment a[s] -> b[s] passes through the interior of an obstacle
        (of the obstacles ``polys``, indices, if given).

        Cyrus-Beck clipping of each segment against each inflated polygon whose bounding box it
        meets; touching a boundary or running along an edge is not blocked. Compiled
        (``sim.spatial.navigation.segments``); :meth:`blocked_reference` is the same test in
        numpy, with the same answers.
        """
        a = np.ascontiguousarray(a, dtype=float).reshape(-1, 2)
        b = np.ascontiguousarray(b, dtype=float).reshape(-1, 2)
        if not len(self.polygons_) or not len(a):
            return np.zeros(len(a), dtype=bool)
        if polys is None:
            polys = self.all_polys_
        polys = np.ascontiguousarray(polys, dtype=np.int64)
        return blocked_segments(
            a,
            b,
            polys,
            self.bb_lo_,
            self.bb_hi_,
            self.normals_,
            self.offsets_,
            self.n_edges_,
            _TOL_M,
        )

    def blocked_reference(
        self, a: np.ndarray, b: np.ndarray, polys: np.ndarray | None = None
    ) -> np.ndarray:
        """(S,) True where segment a[s] -> b[s] passes through the interior of an obstacle
        (of the obstacles ``polys``, indices, if given).

        :meth:`blocked` in numpy (the reference its compiled test is checked against), in
        chunks of ``chunk`` (pair, edge) entries.
        """
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        b = np.asarray(b, dtype=float).reshape(-1, 2)
        out = np.zeros(len(a), dtype=bool)
        bb_lo, bb_hi = self.bb_lo_, self.bb_hi_
        if polys is not None:
            bb_lo, bb_hi = bb_lo[polys], bb_hi[polys]
        if not len(bb_lo) or not len(a):
            return out
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        step = max(1, self.chunk // (len(bb_lo) * self.normals_.shape[1]))
        for s0 in range(0, len(a), step):
            sl = slice(s0, s0 + step)
            meet = lo[sl, 0, None] < bb_hi[None, :, 0]
            meet &= lo[sl, 1, None] < bb_hi[None, :, 1]
            meet &= hi[sl, 0, None] > bb_lo[None, :, 0]
            meet &= hi[sl, 1, None] > bb_lo[None, :, 1]
            si, pi = np.nonzero(meet)
            if not si.size:
                continue
            si += s0
            if polys is not None:
                pi = polys[pi]
            out[si[self._clips(a[si], b[si], pi)]] = True
        return out

    def blocked_by(self, a: np.ndarray, b: np.ndarray, obstacle: np.ndarray) -> np.ndarray:
        """:meth:`blocked` where only ``obstacle[s]`` (an index) can block segment s: the same
        test, one edge at a time over all segments (as :meth:`blocked_one` does per segment),
        which is quicker than :meth:`blocked`'s per-pair reductions for a few candidates."""
        a = np.asarray(a, dtype=float).reshape(-1, 2)
        b = np.asarray(b, dtype=float).reshape(-1, 2)
        k = np.asarray(obstacle)
        lo, hi = np.minimum(a, b), np.maximum(a, b)
        bb_lo, bb_hi = self.bb_lo_[k], self.bb_hi_[k]
        meet = (lo[:, 0] < bb_hi[:, 0]) & (lo[:, 1] < bb_hi[:, 1])
        meet &= (hi[:, 0] > bb_lo[:, 0]) & (hi[:, 1] > bb_lo[:, 1])
        idx = np.flatnonzero(meet)
        k = k[idx]
        ax, ay = a[idx, 0], a[idx, 1]
        dx, dy = b[idx, 0] - ax, b[idx, 1] - ay
        t_lo, t_hi = np.zeros(len(idx)), np.ones(len(idx))
        cut = np.ones(len(idx), dtype=bool)
        for e in range(self.normals_.shape[1]):
            nx, ny = self.normals_[k, e, 0], self.normals_[k, e, 1]
            num = self.offsets_[k, e] - _TOL_M - (nx * ax + ny * ay)
            den = nx * dx + ny * dy
            with np.errstate(divide="ignore", invalid="ignore"):
                t = num / den
            t_hi = np.where(den > 0, np.minimum(t_hi, t), t_hi)
            t_lo = np.where(den < 0, np.maximum(t_lo, t), t_lo)
            cut &= ~((den == 0) & (num <= 0))  # parallel to this edge and outside it
        out = np.zeros(len(a), dtype=bool)
        out[idx] = cut & (t_lo < t_hi)
        return out

    def _clips(self, a: np.ndarray, b: np.ndarray, poly: np.ndarray) -> np.ndarray:
        """Cyrus-Beck: True where segment a[s] -> b[s] enters the interior of ``poly[s]``."""
        n = self.normals_[poly]
        num = self.offsets_[poly] - _TOL_M - np.einsum("kej,kj->ke", n, a)
        den = np.einsum("kej,kj->ke", n, b - a)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = num / den
        t_hi = np.where(den > 0, ratio, np.inf).min(axis=1, initial=1.0)
        t_lo = np.where(den < 0, ratio, -np.inf).max(axis=1, initial=0.0)
        never = ((den == 0) & (num <= 0)).any(axis=1)
        return (t_lo < t_hi) & ~never

    def blocked_one(self, ax: float, ay: float, bx: float, by: float) -> bool:
        """:meth:`blocked` for one segment (ax, ay) -> (bx, by), in plain Python."""
        lox, hix = (ax, bx) if ax < bx else (bx, ax)
        loy, hiy = (ay, by) if ay < by else (by, ay)
        dx, dy = bx - ax, by - ay
        scalar = self.scalar_
        for k in self.buckets_.near(lox, loy, hix, hiy):
            x0, y0, x1, y1, edges = scalar[k]
            if not (lox < x1 and loy < y1 and hix > x0 and hiy > y0):
                continue
            t_lo, t_hi = 0.0, 1.0
            for nx, ny, c in edges:
                num = c - _TOL_M - (nx * ax + ny * ay)
                den = nx * dx + ny * dy
                if den > 0.0:
                    t = num / den
                    t_hi = t if t < t_hi else t_hi
                elif den < 0.0:
                    t = num / den
                    t_lo = t if t > t_lo else t_lo
                elif num <= 0.0:  # parallel to this edge and outside it: misses the polygon
                    t_lo, t_hi = 1.0, 0.0
                    break
            if t_lo < t_hi:
                return True
        return False

    def free_one(self, x: float, y: float) -> bool:
        """:meth:`free` for one point, in plain Python."""
        x0, y0, x1, y1 = self.box_
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            return False
        scalar = self.scalar_
        for k in self.buckets_.at(x, y):
            bx0, by0, bx1, by1, edges = scalar[k]
            if bx0 <= x <= bx1 and by0 <= y <= by1:  # inside is strictly inside every edge
                for nx, ny, c in edges:
                    if nx * x + ny * y - c >= -_TOL_M:
                        break
                else:
                    return False
        return True

    def snap(self, xy: np.ndarray) -> np.ndarray:
        """Push points (n, 2) that lie inside an inflated obstacle or the wall margin out to the
        nearest free boundary (robots pressed against an obstacle can be there)."""
        pts = np.array(xy, dtype=float).reshape(-1, 2)
        for _ in range(4):
            bad = np.flatnonzero(~self.free(pts))
            if not bad.size:
                break
            for k in bad.tolist():
                p = np.clip(pts[k], self.lo_, self.hi_)
                if len(self.polygons_):
                    proj = self.normals_[..., 0] * p[0] + self.normals_[..., 1] * p[1]
                    proj = proj - self.offsets_
                    for q in np.flatnonzero((proj < -_TOL_M).all(axis=1)).tolist():
                        e = int(np.argmax(np.where(self.real_[q], proj[q], -np.inf)))
                        p = p + self.normals_[q, e] * (_SNAP_M - proj[q, e])
                pts[k] = p
        return pts

    def goal_field(self, goal: np.ndarray, hidden=None) -> tuple[np.ndarray, np.ndarray]:
        """Geodesic distance (V,) from each vertex to ``goal`` and the last vertex before the goal
        on that path (-1 if unreachable); cached per goal point. ``hidden``: (V,) the result of
        :meth:`blocked` from the goal to each vertex, if the caller has it already."""
        key = (float(goal[0]), float(goal[1]))
        hit = self._fields.get(key)
        if hit is not None:
            return hit
        v = self.vertices_
        if hidden is None:
            hidden = self.blocked(np.broadcast_to(goal, v.shape), v)
        seen = np.flatnonzero(~hidden)
        if seen.size:
            total = self.apsp_[:, seen] + np.linalg.norm(v[seen] - goal, axis=1)[None]
            k = np.argmin(total, axis=1)
            dist = total[np.arange(len(v)), k]
            last = np.where(np.isfinite(dist), seen[k], -1)
        else:
            dist, last = np.full(len(v), np.inf), np.full(len(v), -1)
        self._fields[key] = (dist, last)
        return dist, last

    def _first_visible(self, pts: np.ndarray, rows: np.ndarray, lower: np.ndarray) -> np.ndarray:
        """Cost through the cheapest visible vertex per query.

        Args:
            pts: (m, 2) query points.
            rows: (n,) point of each query.
            lower: (n, V) cost through each vertex if it is visible from the point.

        Returns:
            (n,) cost through the first visible vertex in order of cost (``inf`` if none).
        """
        n, nv = lower.shape
        order = np.argsort(lower, axis=1)
        cost = np.full(n, np.inf)
        todo, start, size = np.arange(n), 0, _FIRST_BATCH
        while todo.size and start < nv:
            cand = order[todo, start : start + size]
            bound = lower[todo[:, None], cand]
            ok = np.isfinite(bound)
            pair = np.unique(rows[todo][:, None] * nv + cand, return_inverse=True)
            keys, inv = pair[0], pair[1].reshape(cand.shape)
            seen = ~self.blocked(pts[keys // nv], self.vertices_[keys % nv])
            vis = seen[inv] & ok
            hit = vis.any(axis=1)
            first = np.argmax(vis, axis=1)[hit]
            cost[todo[hit]] = bound[hit, first]
            todo = todo[~hit & ok[:, -1]]
            start, size = start + size, size * 4
        return cost

    def distances(self, positions: np.ndarray, sites: np.ndarray) -> np.ndarray:
        """Planned path length (m) from each position (m, 2) to each site (k, 2); ``inf`` where
        no path exists. Never shorter than the straight line; equal to it in open space.

        From ``FIELD_MIN_ROBOTS`` positions on, the scenario's task sites are looked up in the
        fleet's distance field (:meth:`field`, built on first use); other sites, and smaller
        calls, are computed here directly (:meth:`exact_distances`). Both give the length of
        the path :meth:`path` plans, up to rounding."""
        pos = np.asarray(positions, dtype=float).reshape(-1, 2)
        sites = np.asarray(sites, dtype=float).reshape(-1, 2)
        if len(pos) < FIELD_MIN_ROBOTS or not len(sites):
            return self.exact_distances(pos, sites)
        if self.field_ is None and not self.field_fits():  # no sites, or far too many
            return self.exact_distances(pos, sites)
        field = self.field()
        cols = field.columns(sites)
        known = cols >= 0
        uniq, inv = np.unique(cols[known], return_inverse=True)  # a batch may repeat sites
        if known.all():
            if len(uniq) == len(cols):
                return field.distances(pos, cols)
            return field.distances(pos, uniq)[:, inv]
        out = np.empty((len(pos), len(sites)))
        out[:, known] = field.distances(pos, uniq)[:, inv]
        out[:, ~known] = self.exact_distances(pos, sites[~known])
        return out

    def site_points(self) -> np.ndarray:
        """(k, 2) every task site of the scenario (all types), as given."""
        pts = [p for sites in self.spatial.sites for p in sites]
        return np.array(pts, dtype=float).reshape(-1, 2)

    def field_fits(self) -> bool:
        """True if the scenario has task sites and a distance field of them can be built."""
        n_sites = len(np.unique(self.site_points(), axis=0))
        return n_sites > 0 and DistanceField.fits(self, n_sites)

    def field(self) -> DistanceField:
        """The distance field of this arena (current obstacles) and the scenario's task sites:
        built on first use, shared with every planner of this process that has the same arena
        (``sim.spatial.navigation.distfield.SHARED``)."""
        if self.field_ is None:
            sites = self.site_points()
            self.field_ = SHARED.get(self.field_key(), lambda: DistanceField.build(self, sites))
        return self.field_

    def field_key(self) -> tuple:
        """What the distance field depends on: arena, inflation, current obstacles, sites."""
        sp = self.spatial
        return (
            sp.width_m,
            sp.height_m,
            self.inflate_m,
            self.obstacles,
            self.site_points().tobytes(),
        )

    def exact_distances(self, positions: np.ndarray, sites: np.ndarray) -> np.ndarray:
        """:meth:`distances` computed from scratch: the straight line where it is free, else
        the cheapest vertex the position sees plus that vertex's geodesic to the site."""
        pos = np.asarray(positions, dtype=float).reshape(-1, 2)
        sites = np.asarray(sites, dtype=float).reshape(-1, 2)
        if not len(sites) or not len(pos):
            return np.full((len(pos), len(sites)), np.inf)
        snapped = self.snap(pos)
        extra = np.linalg.norm(pos - snapped, axis=1)
        uniq, inv = np.unique(sites, axis=0, return_inverse=True)
        goals = self.snap(uniq)
        goal_extra = np.linalg.norm(uniq - goals, axis=1)
        a = np.repeat(snapped, len(goals), axis=0)
        b = np.tile(goals, (len(snapped), 1))
        direct = np.linalg.norm(a - b, axis=1)
        direct[self.blocked(a, b)] = np.inf
        best = direct.reshape(len(pos), len(goals))
        r, g = np.nonzero(~np.isfinite(best))
        if r.size and len(self.vertices_):
            fields = np.array([self.goal_field(goal)[0] for goal in goals])
            to_vertex = np.linalg.norm(snapped[:, None] - self.vertices_[None], axis=2)
            best[r, g] = self._first_visible(snapped, r, to_vertex[r] + fields[g])
        best = best + extra[:, None] + goal_extra[None]
        return best[:, inv.ravel()]

    def path(self, start_xy, goal_xy) -> np.ndarray:
        """Waypoints (P, 2) from ``start_xy`` to ``goal_xy``, both included; (0, 2) if no path."""
        start = np.asarray(start_xy, dtype=float).reshape(2)
        goal = np.asarray(goal_xy, dtype=float).reshape(2)
        snapped = not (self.free_one(*start.tolist()) and self.free_one(*goal.tolist()))
        if snapped:
            s, g = self.snap(np.stack([start, goal]))
        else:
            s, g = start, goal  # the usual case: no snapping needed
        pts = [start] if snapped and np.linalg.norm(s - start) > 0 else []
        pts.append(s)
        sx, sy = s.tolist()
        if self.blocked_one(sx, sy, *g.tolist()):
            if not len(self.vertices_):
                return np.zeros((0, 2))
            dist, last = self.goal_field(g)
            lower = np.linalg.norm(self.vertices_ - s, axis=1) + dist
            u = self._first_seen(s, lower)
            if u < 0:
                return np.zeros((0, 2))
            chain = [int(last[u])]
            while chain[-1] != u:
                chain.append(int(self.pred_[u, chain[-1]]))
            pts.extend(self.vertices_[chain[::-1]])
        pts.append(g)
        if snapped and np.linalg.norm(goal - g) > 0:
            pts.append(goal)
        return np.array(pts)

    def _first_seen(self, s: np.ndarray, lower: np.ndarray) -> int:
        """The first vertex visible from ``s`` in order of ``lower`` (the cost through each,
        ``np.argsort``'s order), of those with a finite cost; -1 if none. Tested a few at a
        time (:meth:`blocked`), as :meth:`_first_visible` does for many points."""
        order = np.argsort(lower)
        start, size = 0, _FIRST_BATCH
        while start < len(order):
            cand = order[start : start + size]
            finite = np.isfinite(lower[cand])  # (a prefix: the order is ascending)
            cand = cand[finite]
            if len(cand):
                seen = ~self.blocked(np.broadcast_to(s, (len(cand), 2)), self.vertices_[cand])
                if seen.any():
                    return int(cand[np.argmax(seen)])
            if not finite.all():
                break
            start, size = start + size, size * 4
        return -1

    def path_around(
        self, start_xy, goal_xy, robots: np.ndarray, radius_m: float, reuse: bool = True
    ) -> np.ndarray:
        """:meth:`path` with the robots at ``robots`` (x + iy, m) as obstacles too: each an
        octagon round a disc of ``radius_m`` (the robot's body), grown like every obstacle by
        a robot radius plus the clearance. A start inside such a grown robot is pushed out of
        it first. For the rare re-plan of a robot in a deadlock: it builds a planner of its own
        (a new visibility graph, whose pairs of obstacle vertices are looked up in this one's
        and tested against the robots only), milliseconds, and keeps only the robots' grown
        octagons (``grown_``: a robot at work is gone round where it stands); in an arena of
        more than ``local_min_vertices`` obstacle vertices only within ``LOCAL_MARGIN_M`` of the
        start, the goal and the robots (a path that would leave that box is not found).
        ``reuse=False`` builds the whole graph afresh (the same graph; ``mrta bench`` times
        both)."""
        robots = np.asarray(robots, dtype=complex).reshape(-1)
        if not len(robots):
            return self.path(start_xy, goal_xy)
        corner = radius_m / np.cos(np.pi / 8) * np.exp(1j * (np.pi / 8 + np.pi / 4 * np.arange(8)))
        rings = robots[:, None] + corner[None, :]
        octagons = [tuple(map(tuple, r)) for r in np.stack([rings.real, rings.imag], -1).tolist()]
        other = self.empty_like()
        obstacles = list(self.obstacles)
        if len(self.vertices_) > self.local_min_vertices:  # a large arena: plan in a box round it
            pts = np.vstack([np.reshape(start_xy, (1, 2)), np.reshape(goal_xy, (1, 2))])
            pts = np.vstack([pts, np.column_stack([robots.real, robots.imag])])
            lo = np.maximum(pts.min(axis=0) - LOCAL_MARGIN_M, self.lo_)
            hi = np.minimum(pts.max(axis=0) + LOCAL_MARGIN_M, self.hi_)
            other.lo_, other.hi_ = lo, hi
            other.box_ = (*(lo - _TOL_M).tolist(), *(hi + _TOL_M).tolist())
            near = (self.bb_hi_ >= lo - self.inflate_m).all(axis=1)
            near &= (self.bb_lo_ <= hi + self.inflate_m).all(axis=1)
            obstacles = [o for o, keep in zip(obstacles, near.tolist(), strict=True) if keep]
        other.set_obstacles(obstacles + octagons, known=(self, len(obstacles)) if reuse else None)
        return other.path(start_xy, goal_xy)

    def empty_like(self) -> GridPlanner:
        """A planner of the same arena and settings with no obstacles yet (give it some with
        :meth:`set_obstacles`): what :meth:`path_around` plans in, without building anything."""
        other = GridPlanner.__new__(GridPlanner)
        other.spatial, other.inflate_m, other.tol_m = self.spatial, self.inflate_m, self.tol_m
        other.lo_, other.hi_, other.box_ = self.lo_, self.hi_, self.box_
        other.local_min_vertices, other.chunk = self.local_min_vertices, self.chunk
        other.grown_, other.grown_max = {}, self.grown_max
        return other

    def side_step(
        self, xy: complex, other: complex, travel: complex, step_m: float, avoid: np.ndarray
    ) -> np.ndarray:
        """A short path that takes a robot at ``xy`` out of the way of a robot at ``other``
        moving along the unit direction ``travel`` (points as x + iy): sideways, away from the
        other robot's line, else to the other side, else straight ahead; (0, 2) if none is free.
        The end point keeps ``step_m / 2`` from every point of ``avoid`` (other robots).
        """
        lateral = 1j * travel
        side = 1.0 if ((xy - other) * lateral.conjugate()).real >= 0 else -1.0
        for offset in (side * lateral, -side * lateral, travel):
            path = self._hop(xy, xy + step_m * offset, avoid, step_m / 2)
            if len(path):
                return path
        return np.zeros((0, 2))

    def detour(
        self, xy: complex, around: complex, travel: complex, offset_m: float, goal, avoid
    ) -> np.ndarray:
        """A path from ``xy`` to ``goal`` that first passes beside ``around`` (a robot that
        will not move), ``offset_m`` to its side of the direction ``travel``; (0, 2) if neither
        side is free of obstacles and of the points ``avoid``."""
        lateral = 1j * travel
        side = 1.0 if ((xy - around) * lateral.conjugate()).real >= 0 else -1.0
        for sign in (side, -side):
            hop = self._hop(xy, around + sign * offset_m * lateral, avoid, offset_m / 2)
            if len(hop):
                rest = self.path(hop[-1], goal)
                if len(rest):
                    return np.concatenate([hop[:1], rest])
        return np.zeros((0, 2))

    def _hop(self, a: complex, b: complex, avoid: np.ndarray, keep_m: float) -> np.ndarray:
        """[a, b] as a (2, 2) path if b is free, seen from a and ``keep_m`` from ``avoid``."""
        start, end = np.array([a.real, a.imag]), np.array([b.real, b.imag])
        if not self.free_one(b.real, b.imag) or self.blocked_one(a.real, a.imag, b.real, b.imag):
            return np.zeros((0, 2))
        if len(avoid) and np.abs(np.asarray(avoid) - b).min() < keep_m:
            return np.zeros((0, 2))
        return np.stack([start, end])
