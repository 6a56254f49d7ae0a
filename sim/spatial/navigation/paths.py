"""Path following for arrays of robots, and how close a robot may come to the obstacles.

Each robot aims at the current waypoint of its planned path and switches to the next when it is
within ``waypoint_switch_m`` of it or beyond the waypoint's normal line. A robot pushed off its
path (by other robots, or going round them) may leave the planner's clearance: the straight line
from where it is to the waypoint could then cut an obstacle corner. A robot at lateral offset c
from the segment into waypoint T that heads straight for T stays within |c| of the segment, so it
cannot touch an obstacle while |c| is below the segment's distance to the obstacles on that side
less the robot radius. That *free width* is computed per segment and side when a path is set; a
robot pushed out farther steers for the path ``lookahead_m`` ahead instead, and the controller
caps its speed toward the nearest obstacle (``to_obstacle``, ``DiffDriveController.wall_cap``) as
toward a robot that stands still, until it is back within the free width. A robot not yet
heading for T (turning in, veering round another robot) drives along its heading, not toward T,
and the free width ends where it touches the obstacle: it is capped the same way as soon as the
point where it could stop lies beyond the free width (``drifting``).

Free widths are exact. With ``cap_m`` (large teams), the widths of a short one-segment path (a
side step) are first computed only as far as ``cap_m`` from the obstacles near it (a robot is
rarely that far off a 1 m step, and in open space the nearest obstacle may be 50 m away, which
is what made the exact width cost a pass over every obstacle edge); a width that reaches
``cap_m`` is flagged and computed exactly the moment a robot on that segment is, or could stop,
farther off than ``cap_m``, so every decision is the one the exact width gives.
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

from sim.scenario import FollowSpec
from sim.spatial.navigation.buckets import EDGE_CELLS_MIN_EDGES, BoxBuckets, EdgeCells, typical_size
from sim.spatial.navigation.widths import free_widths, segment_sides

SCALAR_FREE_MAX = 48  # free widths of fewer (segment, obstacle edge) pairs in plain Python
CELLS_FROM = 2048  # to_obstacle looks up grid cells for more (point, edge) pairs than this
FREE_CHUNK = 96  # segments per array pass of set_paths (about as quick as any, bounded memory)


class PathFollower:
    """Waypoint lists of m robots in padded arrays, with the vectorised bookkeeping around them.

    The segment each robot is on (its waypoint, the unit direction into it, the path length left
    after it, the corner speed there and its free widths) is kept in (m,) arrays, refreshed only
    when a robot passes a waypoint or gets a new path, so a control period reads no padded array.

    Args:
        m: number of robots.
        v_max_mps: top speed, used for the corner speeds.
        obstacles: convex polygons (V, 2) robots must not touch, arena walls included (a wall
            may be given as a two-point polygon, a segment).
        radius_m: robot radius.
        cap_m: a side step's free widths are computed this far, then exactly on demand.
        follow: the waypoint switch and look-ahead distances (``[spatial.follow]``).
    """

    def __init__(
        self,
        m: int,
        v_max_mps: float,
        obstacles=(),
        radius_m: float = 0.0,
        cap_m: float = np.inf,
        follow: FollowSpec | None = None,
    ) -> None:
        follow = FollowSpec() if follow is None else follow
        self.switch_m = follow.waypoint_switch_m  # aim at the next waypoint this close, m
        self.lookahead_m = follow.lookahead_m  # off its path, steer for it this far ahead, m
        self.v_max_mps = v_max_mps
        self.radius_m = radius_m
        self.cap_m = cap_m
        polys = [np.asarray(p, dtype=float) @ np.array([1.0, 1j]) for p in obstacles]
        polys = [p for p in polys if len(p)]
        edges = [(p, np.roll(p, -1)) if len(p) > 2 else (p[:1], p[-1:]) for p in polys]
        self.n_owner_ = len(polys)
        self.verts_ = np.concatenate(polys) if polys else np.zeros(0, dtype=complex)
        self.edge0_ = np.concatenate([e[0] for e in edges]) if polys else self.verts_
        self.edge1_ = np.concatenate([e[1] for e in edges]) if polys else self.verts_
        self.vert_start_ = np.cumsum([0] + [len(p) for p in polys])[:-1]
        self.edge_start_ = np.cumsum([0] + [len(e[0]) for e in edges])[:-1]
        self.vert_end_ = np.cumsum([0] + [len(p) for p in polys])[1:]
        self.edge_end_ = np.cumsum([0] + [len(e[0]) for e in edges])[1:]
        self.all_owners_ = np.arange(len(polys))
        self.owners_ = [  # the same, per obstacle, as Python lists: vertices and edges
            (p.tolist(), list(zip(e0.tolist(), e1.tolist(), strict=True)))
            for p, (e0, e1) in zip(polys, edges, strict=True)
        ]
        self.boxes_ = [  # bounding box of each obstacle: lower-left, upper-right (x + iy)
            (complex(p.real.min(), p.imag.min()), complex(p.real.max(), p.imag.max()))
            for p in polys
        ]
        boxes = [(lo.real, lo.imag, hi.real, hi.imag) for lo, hi in self.boxes_]
        self.buckets_ = BoxBuckets(boxes, typical_size(boxes))
        self.cells_ = None  # the edges near each grid cell, for to_obstacle (many edges only)
        if len(self.edge0_) >= EDGE_CELLS_MIN_EDGES:
            ends = np.concatenate([self.edge0_, self.edge1_])
            lo = complex(ends.real.min(), ends.imag.min())
            hi = complex(ends.real.max(), ends.imag.max())
            self.cells_ = EdgeCells(self.edge0_, self.edge1_, lo, hi)
        self.points = np.zeros((m, 2), dtype=complex)  # (m, P) waypoints, padded with the last
        self.last = np.full(m, -1)  # index of the final waypoint (-1: no path)
        self.index = np.zeros(m, dtype=int)  # waypoint currently aimed at
        self.after_m = np.zeros((m, 2))  # path length left after each waypoint
        self.corner2 = np.zeros((m, 2))  # squared speed allowed at each waypoint
        self.free_m = np.zeros((m, 2, 2))  # free width left, right of the segment into each
        self.capped_m = np.zeros((m, 2, 2), dtype=bool)  # ... only known to be >= cap_m
        self.tgt_ = np.zeros(m, dtype=complex)  # the current waypoint of each robot
        self.unit_c_ = np.zeros(m, dtype=complex)  # conj. unit direction of the segment into it
        self.seg_m_ = np.zeros(m)  # that segment's length
        self.after_ = np.zeros(m)  # path length after the current waypoint
        self.corner2_ = np.zeros(m)  # squared corner speed at the current waypoint
        self.switch_ = np.full(m, -1.0)  # switch within this distance (-1: last waypoint)
        self.beyond_ = np.full(m, -np.inf)  # ... or this far beyond the normal line (0 / -inf)
        self.free_ = np.zeros((2, m))  # minus the free width left, the free width right
        self.free_[0], self.free_[1] = -np.inf, np.inf  # no path: never off it
        self.capped_ = np.zeros((2, m), dtype=bool)  # left, right width of it only >= cap_m
        self.version_ = 0  # counts changes of the current-segment arrays (caches compare it)
        self.paths_set_ = 0  # counts paths given and cleared (the traffic rules compare it)
        self.sets_ = np.zeros(m, dtype=np.int64)  # ... of each robot
        self.lists_version_, self.lists_ = -1, []

    def set_paths(self, rows: list[int], paths: list[np.ndarray]) -> list[float]:
        """:meth:`set_path` for several robots (an auction round); their lengths (m).

        The free widths of all their segments are computed together, ``FREE_CHUNK`` segments
        per array pass (one pass per path costs its fixed overhead a thousand times a round)."""
        edges = len(self.edge0_)
        big = [k for k, p in enumerate(paths) if (len(p) - 1) * edges > SCALAR_FREE_MAX]
        free, capped = [None] * len(paths), [None] * len(paths)
        if self.cap_m < np.inf:  # single short segments (side steps): capped, one by one
            for k in [k for k in big if len(paths[k]) == 2]:
                (ax, ay), (bx, by) = paths[k].tolist()
                short = self._free_capped(complex(ax, ay), complex(bx, by))
                if short is not None:
                    free[k], capped[k] = short
            big = [k for k in big if free[k] is None]
        if big and self.n_owner_:
            pts = [paths[k][:, 0] + 1j * paths[k][:, 1] for k in big]
            a = np.concatenate([p[:-1] for p in pts])
            b = np.concatenate([p[1:] for p in pts])
            widths = np.concatenate(
                [
                    self._free(a[s : s + FREE_CHUNK], b[s : s + FREE_CHUNK])
                    for s in range(0, len(a), FREE_CHUNK)
                ]
            )
            ends = np.cumsum([len(p) - 1 for p in pts])
            for k, part in zip(big, np.split(widths, ends[:-1]), strict=True):
                free[k] = part
        return [
            self.set_path(j, p, w, c) for j, p, w, c in zip(rows, paths, free, capped, strict=True)
        ]

    def set_path(self, j: int, path: np.ndarray, free=None, capped=None) -> float:
        """Give robot j a path (P, 2) whose first point is where it is now; its length (m).
        ``free``: the free widths (P - 1, 2) of its segments if already known (:meth:`_free`),
        ``capped``: which of them are only known to be >= ``cap_m`` (:meth:`_free_capped`)."""
        n = len(path)
        self.paths_set_ += 1
        self.sets_[j] += 1
        if n > self.points.shape[1]:
            grow = ((0, 0), (0, n - self.points.shape[1]))
            self.points = np.pad(self.points, grow, mode="edge")
            self.after_m = np.pad(self.after_m, grow)
            self.corner2 = np.pad(self.corner2, grow)
            self.free_m = np.pad(self.free_m, (*grow, (0, 0)))
            self.capped_m = np.pad(self.capped_m, (*grow, (0, 0)))
        pts = (path[:, 0] + 1j * path[:, 1]).tolist()  # a few points: plain Python is quicker
        seg = [b - a for a, b in pairwise(pts)]
        length = [abs(s) for s in seg]
        after = [0.0] * n
        for k in range(n - 2, -1, -1):
            after[k] = after[k + 1] + length[k]
        corner2 = [0.0] * n
        for k in range(1, n - 1):
            turn = length[k - 1] * length[k]
            cos = (seg[k] * seg[k - 1].conjugate()).real / turn if turn > 1e-12 else 0.0
            cos = min(max(cos, 0.0), 1.0)
            corner2[k] = (self.v_max_mps * cos * cos) ** 2
        self.points[j, :n], self.points[j, n:] = pts, pts[-1]
        self.after_m[j, :n], self.after_m[j, n:] = after, 0.0
        self.corner2[j, :n], self.corner2[j, n:] = corner2, 0.0
        self.free_m[j] = np.inf
        self.capped_m[j] = False
        if n > 1:
            if free is None and n == 2 and self.cap_m < np.inf:
                free, capped = self._free_capped(pts[0], pts[1]) or (None, None)
            if free is None:
                free = self._free(np.array(pts[:-1]), np.array(pts[1:]))
            self.free_m[j, 1:n] = free
            if capped is not None:
                self.capped_m[j, 1:n] = capped
        self.last[j] = n - 1
        self.index[j] = min(1, n - 1)
        self.load_one(j)
        return after[0]

    def load_one(self, j: int) -> None:
        """Refresh robot j's current-segment entries from its waypoint index."""
        self.version_ += 1
        idx = int(self.index[j])
        tgt = complex(self.points[j, idx])
        seg = tgt - complex(self.points[j, max(idx - 1, 0)])
        length = abs(seg)
        self.tgt_[j], self.seg_m_[j] = tgt, length
        self.unit_c_[j] = seg.conjugate() / length if length > 0.0 else 0.0
        self.after_[j], self.corner2_[j] = self.after_m[j, idx], self.corner2[j, idx]
        more = idx < self.last[j]
        self.switch_[j] = self.switch_m if more else -1.0
        self.beyond_[j] = 0.0 if more else -np.inf
        self.free_[0, j], self.free_[1, j] = -self.free_m[j, idx, 0], self.free_m[j, idx, 1]
        self.capped_[:, j] = self.capped_m[j, idx]

    def segment_lists(self) -> list[list]:
        """The current-segment arrays as Python lists (the scalar control period of a small
        team): waypoint, conj. unit direction, switch distance, beyond offset, minus the free
        width left, free width right, path length after, squared corner speed, segment length.
        Cached until the arrays change (``version_``); an entry the caller refreshes itself
        after :meth:`load_one` may be kept with :meth:`keep_lists`."""
        if self.lists_version_ != self.version_:
            self.lists_ = [
                self.tgt_.tolist(),
                self.unit_c_.tolist(),
                self.switch_.tolist(),
                self.beyond_.tolist(),
                *self.free_.tolist(),
                self.after_.tolist(),
                self.corner2_.tolist(),
                self.seg_m_.tolist(),
            ]
            self.lists_version_ = self.version_
        return self.lists_

    def refresh_list_entry(self, j: int) -> None:
        """After :meth:`load_one` of robot j: copy its entries into the cached lists."""
        lists = self.lists_
        for k, arr in enumerate(
            (
                self.tgt_,
                self.unit_c_,
                self.switch_,
                self.beyond_,
                self.free_[0],
                self.free_[1],
                self.after_,
                self.corner2_,
                self.seg_m_,
            )
        ):
            lists[k][j] = arr[j].item()
        if self.lists_version_ == self.version_ - 1:  # nothing else changed meanwhile
            self.lists_version_ = self.version_

    def clear(self, j: int) -> None:
        """Robot j has no path (it stands)."""
        self.version_ += 1
        self.paths_set_ += 1
        self.sets_[j] += 1
        self.last[j] = -1
        self.index[j] = 0
        self.switch_[j], self.beyond_[j] = -1.0, -np.inf
        self.free_[0, j], self.free_[1, j] = -np.inf, np.inf
        self.capped_[:, j] = False

    def _load(self, rows: np.ndarray) -> None:
        """Refresh the current-segment arrays of ``rows`` from their waypoint index."""
        self.version_ += 1
        idx = self.index[rows]
        tgt = self.points[rows, idx]
        seg = tgt - self.points[rows, np.maximum(idx - 1, 0)]
        length = np.abs(seg)
        self.tgt_[rows], self.seg_m_[rows] = tgt, length
        self.unit_c_[rows] = np.where(length > 0.0, seg.conj() / np.maximum(length, 1e-12), 0.0)
        self.after_[rows], self.corner2_[rows] = self.after_m[rows, idx], self.corner2[rows, idx]
        more = idx < self.last[rows]
        self.switch_[rows] = np.where(more, self.switch_m, -1.0)
        self.beyond_[rows] = np.where(more, 0.0, -np.inf)
        left, right = self.free_m[rows, idx, 0], self.free_m[rows, idx, 1]
        self.free_[0, rows], self.free_[1, rows] = -left, right
        self.capped_[:, rows] = self.capped_m[rows, idx].T

    def targets(self, z: np.ndarray):
        """Advance past reached waypoints and pick where each robot steers.

        Args:
            z: (m,) positions x + iy (rows of robots without a path hold stale values).

        Returns:
            (m,) aim point minus position, (m,) distance to the waypoint, (m,) path length
            left, (m,) squared corner speed at the waypoint and the robots (indices) beyond the
            free width of their segment, or None.
        """
        delta = self.tgt_ - z
        gap = np.abs(delta)
        proj = delta * self.unit_c_  # real: ahead of the waypoint's normal line; imag: off path
        close = gap < self.switch_
        close |= proj.real < self.beyond_  # near the waypoint or beyond its normal line
        if np.count_nonzero(close):
            rows = close.nonzero()[0]
            self.index[rows] += 1
            self._load(rows)
            delta = self.tgt_ - z
            gap = np.abs(delta)
            proj = delta * self.unit_c_
        side = proj.imag  # minus the robot's offset to the left of the segment
        off = side < self.free_[0]
        off |= side > self.free_[1]
        if self.cap_m < np.inf and np.count_nonzero(off):
            rows = off.nonzero()[0]
            if self._refine(rows, side[rows], side[rows]):
                off[rows] = (side[rows] < self.free_[0, rows]) | (side[rows] > self.free_[1, rows])
        aim, rows = delta, None
        if np.count_nonzero(off):  # straight for the waypoint could touch an obstacle
            rows = off.nonzero()[0]
            back = np.minimum(
                np.maximum(proj.real[rows] - self.lookahead_m, 0.0), self.seg_m_[rows]
            )
            aim = delta.copy()
            aim[rows] -= back * self.unit_c_[rows].conj()
        return aim, gap, gap + self.after_, self.corner2_, rows

    def drifting(self, z: np.ndarray, h: np.ndarray, v_mps: np.ndarray, react_s: float, inv2a):
        """Robots beyond the free width of their segment or whose stopping point is, or None.

        Straight for the waypoint keeps a robot within the free width only once it heads that
        way: turning in, veering round another robot or pushed askew, it drives along its
        heading h, and at speed v (signed) covers v (react_s + |v| inv2a) before it stands. The
        free width ends where the robot would touch the obstacle, so the obstacle cap must watch
        a robot whose stopping point lies beyond it, not only one already there. Robots without
        a path never drift.
        """
        side = ((self.tgt_ - z) * self.unit_c_).imag  # minus the offset to the left
        stop = (h * self.unit_c_).imag  # leftward share of the heading
        stop *= v_mps * (react_s + np.abs(v_mps) * inv2a)
        np.subtract(side, stop, out=stop)  # the same at the stopping point
        lo, hi = np.minimum(side, stop), np.maximum(side, stop)
        out = lo < self.free_[0]
        out |= hi > self.free_[1]
        if self.cap_m < np.inf and np.count_nonzero(out):
            rows = out.nonzero()[0]
            if self._refine(rows, lo[rows], hi[rows]):
                out[rows] = (lo[rows] < self.free_[0, rows]) | (hi[rows] > self.free_[1, rows])
        return out.nonzero()[0] if np.count_nonzero(out) else None

    def _refine(self, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Robots ``rows`` at offsets (minus left) between ``lo`` and ``hi`` of their segment are
        beyond its stored free width; where that width is only known to be >= ``cap_m``, compute
        it exactly (:meth:`_free`) and store it. True if any was."""
        need = self.capped_[0, rows] & (lo < self.free_[0, rows])
        need |= self.capped_[1, rows] & (hi > self.free_[1, rows])
        if not np.count_nonzero(need):
            return False
        for j in rows[need].tolist():
            idx = int(self.index[j])
            a, b = self.points[j, idx - 1 : idx], self.points[j, idx : idx + 1]
            width = self._free(a, b)[0]
            self.free_m[j, idx], self.capped_m[j, idx] = width, False
            self.free_[0, j], self.free_[1, j] = -width[0], width[1]
            self.capped_[:, j] = False
        self.version_ += 1
        return True

    def lane_room(self, z: np.ndarray, rows: np.ndarray):
        """Robots ``rows`` at ``z`` (x + iy, m): the unit vector to the left of their current
        segment (0 for a segment of no length) and the room their centre has to the left and
        to the right before it leaves the segment's free width, m (inf where it is unbounded,
        negative beyond it)."""
        side = ((self.tgt_[rows] - z) * self.unit_c_[rows]).imag  # minus the left offset
        left = 1j * self.unit_c_[rows].conj()
        return left, side - self.free_[0, rows], self.free_[1, rows] - side

    def obstacle_points(self, z: np.ndarray, reach_m: float, count: int) -> np.ndarray:
        """(k, count) obstacle points of each point z (x + iy from it; inf + 0j where fewer):
        the nearest point of each edge within ``reach_m``, taken in order of distance (ties: the
        lower edge index) and kept unless it lies on or behind the line of a point kept before
        it (n . (q - q_j) <= 1e-9 with n the unit vector from q_j to z: a corner of the face z
        stands beside, the far side of an obstacle). The wall lines of ``[spatial.orca]
        wall_lines``; the compiled kernel's ``obstacles.obstacle_points``, bit for bit."""
        out = np.full((len(z), count), np.inf + 0j)
        if not self.n_owner_ or not len(z):
            return out
        e0, d = self.edge0_, self.edge1_ - self.edge0_
        t = ((z[:, None] - e0) * d.conj()).real / np.maximum((d * d.conj()).real, 1e-24)
        near = e0 + np.minimum(np.maximum(t, 0.0), 1.0) * d - z[:, None]
        gap = np.abs(near)
        for i in range(len(z)):
            ahead = np.flatnonzero(gap[i] < reach_m)
            kept: list[complex] = []
            for k in ahead[np.argsort(gap[i, ahead], kind="stable")].tolist():
                q = complex(near[i, k])
                if all(((q - c) * (-c / max(abs(c), 1e-12)).conjugate()).real > 1e-9 for c in kept):
                    kept.append(q)
                    if len(kept) == count:
                        break
            out[i, : len(kept)] = kept
        return out

    def to_obstacle(self, z: np.ndarray) -> np.ndarray:
        """From each point z (k,) to the nearest point of any obstacle or wall (x + iy).

        With many edges and points (more than ``CELLS_FROM`` pairs), points inside the edges'
        bounding box look only at the edges their grid cell lists
        (``sim.spatial.navigation.buckets.EdgeCells``): the same result, bit for bit."""
        if not self.n_owner_ or not len(z):
            return np.full(len(z), np.inf + 0j)
        cells = self.cells_
        if cells is not None and len(z) * len(self.edge0_) > CELLS_FROM:
            cell = cells.cell_of(z)
            if (cell >= 0).all():
                idx = cells.table[cell]
                return _nearest(z, cells.e0[idx], cells.d[idx])
        return _nearest(z, self.edge0_, self.edge1_ - self.edge0_)

    def to_obstacle_one(self, z: complex) -> complex:
        """:meth:`to_obstacle` of one point, in plain Python: obstacles whose bounding box is
        no nearer than the best point so far are skipped."""
        best, best_m = complex(np.inf, 0.0), np.inf
        x, y = z.real, z.imag
        for (lo, hi), (_, edges) in zip(self.boxes_, self.owners_, strict=True):
            dx = max(lo.real - x, x - hi.real, 0.0)
            dy = max(lo.imag - y, y - hi.imag, 0.0)
            if dx * dx + dy * dy >= best_m * best_m:
                continue
            for e0, e1 in edges:
                d = e1 - e0
                dc = d.conjugate()
                dd = (d * dc).real
                t = ((z - e0) * dc).real / (dd if dd > 1e-24 else 1e-24)
                t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
                near = e0 + t * d - z
                gap = abs(near)
                if gap < best_m:
                    best, best_m = near, gap
        return best

    def _free(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """(S, 2) free width left and right of segments a -> b: distance to the nearest
        obstacle on that side (one that straddles the segment's line counts on both) less the
        robot radius, at least 0."""
        out = np.full((len(a), 2), np.inf)
        if not self.n_owner_:
            return out
        if len(a) * len(self.edge0_) <= SCALAR_FREE_MAX:  # few: plain Python is quicker
            for k, (p, q) in enumerate(zip(a.tolist(), b.tolist(), strict=True)):
                out[k] = self._free_one(p, q)
            return out
        a, b = np.ascontiguousarray(a, dtype=complex), np.ascontiguousarray(b, dtype=complex)
        e0, e1, v = self.edge0_, self.edge1_, self.verts_
        return free_widths(a, b, v, self.vert_start_, e0, e1, self.edge_start_, self.radius_m)

    def _near_cap(self, a: complex, b: complex) -> list[int]:
        """Obstacles (indices) whose bounding box is within ``cap_m`` + radius of the
        segment's (a superset, :class:`sim.spatial.navigation.buckets.BoxBuckets`)."""
        d = self.cap_m + self.radius_m
        x0, x1 = (a.real, b.real) if a.real < b.real else (b.real, a.real)
        y0, y1 = (a.imag, b.imag) if a.imag < b.imag else (b.imag, a.imag)
        return self.buckets_.near(x0 - d, y0 - d, x1 + d, y1 + d)

    def _free_capped(self, a: complex, b: complex):
        """Free widths of segment a -> b as far as ``cap_m``, or None if it is too long.

        Only obstacles near the segment are looked at: one farther than ``cap_m`` + radius
        from the segment's bounding box cannot leave a width below ``cap_m``. A side without
        a nearer obstacle gets ``cap_m``, flagged: its true width is at least that, and it is
        computed exactly (:meth:`_refine`) if a robot is ever farther off the path.

        Returns:
            ((left, right) widths, (left, right) flags) or None.
        """
        near = self._near_cap(a, b)
        if near is self.buckets_.all_:
            return None
        left, right = self._sides(a, b, near)
        out, flags = [], []
        for dist in (left, right):
            width = dist - self.radius_m
            flags.append(width > self.cap_m)
            out.append(self.cap_m if width > self.cap_m else max(width, 0.0))
        return out, flags

    def _free_one(self, a: complex, b: complex) -> tuple[float, float]:
        """:meth:`_free` of one segment, in plain Python."""
        left, right = self._sides(a, b, None)
        return max(left - self.radius_m, 0.0), max(right - self.radius_m, 0.0)

    def _sides(self, a: complex, b: complex, owners) -> tuple[float, float]:
        """Distance from segment a -> b to the nearest of ``owners`` (indices) on its left and
        on its right (an obstacle straddling the segment's line counts on both). Compiled
        (``sim.spatial.navigation.widths``)."""
        return segment_sides(
            complex(a),
            complex(b),
            self.all_owners_ if owners is None else np.asarray(owners, dtype=np.int64),
            self.verts_,
            self.vert_start_,
            self.vert_end_,
            self.edge0_,
            self.edge1_,
            self.edge_start_,
            self.edge_end_,
        )


def _nearest(z: np.ndarray, e0: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(k,) from each point z to the nearest point of the segments e0 -> e0 + d, x + iy (the
    segments (E,) for all points, or (k, K) per point; ties: the first)."""
    t = ((z[:, None] - e0) * d.conj()).real / np.maximum((d * d.conj()).real, 1e-24)
    near = e0 + np.minimum(np.maximum(t, 0.0), 1.0) * d - z[:, None]
    return near[np.arange(len(z)), np.abs(near).argmin(axis=1)]


def _to_segment(p: complex, s0: complex, s1: complex) -> float:
    """Distance from point p to segment s0 -> s1 (complex numbers; plain Python, the
    reference of ``widths``)."""
    d = s1 - s0
    dd = (d * d.conjugate()).real
    t = ((p - s0) * d.conjugate()).real / dd if dd > 1e-24 else 0.0
    t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
    return abs(p - s0 - t * d)
