"""Planned-path distances for a whole fleet: each task site's shortest-path map on a grid.

The planner's distance from a point p to a site s is min over the anchors a that p sees of
|p - a| + F_s(a): an anchor is an obstacle vertex (F_s its geodesic distance to s) or the site
itself (F_s = 0). Which anchor wins depends on where p is, so this module precomputes it: for
every cell of a grid (about ``CELL_M``) and every site, the anchor that is optimal for *every*
point of the cell (``sim.spatial.navigation.anchors``). A bid is then one table look-up and one
straight segment. Where no single anchor is certain (the cell straddles a shadow edge or a boundary
between two anchors' regions: a few per cent of the pairs) the cell keeps a short list of
candidates, and a query tests those exactly, with the planner's own segment test on the obstacles in
the segment's direction (``sim.spatial.navigation.raster.SightIndex``). Candidates only ever leave
for a proof, so the table gives the planner's distance up to rounding (the tests compare it with
``GridPlanner.exact_distances`` and ``GridPlanner.path`` lengths).
"""

from __future__ import annotations

import copy
import time
from collections import OrderedDict

import numpy as np

from sim.spatial.navigation.anchors import (
    edge_directions,
    next_points,
    refine,
    run_starts,
    taut_wedges,
)
from sim.spatial.navigation.raster import (
    DONT_CARE,
    Grid,
    Obstacles,
    SightIndex,
    polygon_cells,
    visibility,
)

CELL_M = 0.5  # finest cells, about; the arena is split evenly
TOP_M = 16.0  # coarsest blocks, about: every anchor is tried there
TABLE_BYTES = 128 * 2**20  # cells grow past CELL_M to keep the anchor table below this
SITES_PER_PASS = 4  # sites refined together (bounds the candidate arrays)


class DistanceField:
    """The anchor table of a planner's arena for a fixed set of task sites.

    Build with :meth:`build`; query with :meth:`distances`. Everything is read-only once
    built, so one field may serve every planner with the same obstacles and sites
    (``SHARED``, a :class:`FieldCache`).
    """

    def __init__(
        self, planner, sites: np.ndarray, max_groups: int = 1 << 16, pairs_per_pass: int = 1 << 16
    ) -> None:
        # Candidate lists get table codes of their own up to the table's range (uint16), the
        # rest are filed by key; lists are digested this many (cell, site) pairs at a time.
        # Neither changes a distance; tests lower both to exercise the keyed lists and passes.
        self.max_groups, self.pairs_per_pass = max_groups, pairs_per_pass
        # a shallow copy: GridPlanner.set_obstacles rebinds the planner's geometry, and the
        # field, which other planners may share, must keep the geometry it was built for
        self.planner = copy.copy(planner)
        self.sites = np.unique(np.asarray(sites, dtype=float).reshape(-1, 2), axis=0)

    @staticmethod
    def fits(planner, n_sites: int) -> bool:
        """True if a field of ``planner``'s arena for ``n_sites`` sites can be built: anchor
        codes in 15 bits, keys of the undecided pairs in 31."""
        grid, _ = _grid(planner.spatial.width_m, planner.spatial.height_m, n_sites)
        small = len(planner.vertices_) + 3 <= np.iinfo(np.int16).max
        return small and grid.nx * grid.ny * n_sites < 2**31

    @classmethod
    def build(cls, planner, sites: np.ndarray, **limits: int) -> DistanceField:
        """Precompute the table for ``sites`` (k, 2) in ``planner``'s arena (``limits``:
        ``max_groups``, ``pairs_per_pass`` as the constructor takes them)."""
        field = cls(planner, sites, **limits)
        field._build()
        return field

    def _build(self) -> None:
        t0 = time.perf_counter()
        pl = self.planner
        sites = self.sites
        n_sites = len(sites)
        self.column_ = {(float(x), float(y)): s for s, (x, y) in enumerate(sites.tolist())}
        goals = pl.snap(sites)
        self.goal_extra_ = np.linalg.norm(sites - goals, axis=1)
        verts = pl.vertices_
        nv = len(verts)
        self.n_vertices_ = nv
        if not self.fits(pl, n_sites):
            raise ValueError(f"{nv} vertices and {n_sites} sites do not fit a distance field")
        self.grid_, self.levels_ = grid, levels = _grid(
            pl.spatial.width_m, pl.spatial.height_m, n_sites
        )
        obstacles = planner_obstacles(pl)
        points = np.concatenate([verts, goals])
        self.sight_ = SightIndex(points, obstacles)
        hidden = self._hidden(goals)
        dist = np.full((n_sites, nv), np.inf)
        nxt = np.zeros((n_sites, nv), dtype=complex)
        for s, goal in enumerate(goals):
            d, last = pl.goal_field(goal, hidden[s])
            dist[s] = d
            nxt[s] = next_points(pl, d, last, complex(*goal))
        zv = verts @ np.array([1.0, 1j])
        zg = goals @ np.array([1.0, 1j])
        # anchors 0..V-1 the vertices, V the site, V + 1 "no path", V + 2 "several candidates"
        self.inf_code_, self.mixed_code_, self.group_base_ = nv + 1, nv + 2, nv + 3
        nothing = np.zeros((n_sites, 2))
        self.anchor_z_ = np.concatenate(
            [np.broadcast_to(zv, (n_sites, nv)), zg[:, None], nothing], axis=1
        )
        inf_nan = np.broadcast_to([np.inf, np.nan], (n_sites, 2))
        self.anchor_f_ = np.concatenate([dist, np.zeros((n_sites, 1)), inf_nan], axis=1)
        t1 = time.perf_counter()
        meets, inside = polygon_cells(obstacles, grid)
        care = ~inside.ravel() & _in_box(grid, pl.lo_, pl.hi_)
        self.care_ = care
        self.clear_ = care & ~meets.ravel() & _within_box(grid, pl.lo_, pl.hi_)
        ras = visibility(points, obstacles, grid).reshape(nv + n_sites, -1)
        ras[:, ~care] = DONT_CARE
        pyramid = [ras]
        for _ in range(levels):
            ny, nx = grid.ny >> len(pyramid) - 1, grid.nx >> len(pyramid) - 1
            r = pyramid[-1].reshape(len(ras), ny // 2, 2, nx // 2, 2)
            pyramid.append(
                r[:, :, 0, :, 0] | r[:, :, 0, :, 1] | r[:, :, 1, :, 0] | r[:, :, 1, :, 1]
            )
            pyramid[-1] = pyramid[-1].reshape(len(ras), -1)
        t2 = time.perf_counter()
        wedge = edge_directions(pl)
        table = np.empty((grid.nx * grid.ny, n_sites), dtype=np.uint16)
        mixed = []
        for s0 in range(0, n_sites, SITES_PER_PASS):
            s1 = min(n_sites, s0 + SITES_PER_PASS)
            normals, kind = taut_wedges(zv, wedge, nxt[s0:s1], dist[s0:s1])
            codes, extra = refine(
                grid,
                levels,
                pyramid,
                kind,
                normals,
                zv,
                self.anchor_z_[s0:s1],
                self.anchor_f_[s0:s1],
                s0,
                n_sites,
            )
            table[:, s0:s1] = codes.T
            mixed.append(extra)
        self.table_ = table
        del ras, pyramid  # the visibility rasters are not kept
        self._index_mixed(mixed)
        t3 = time.perf_counter()
        self.timings_ = {"fields_s": t1 - t0, "raster_s": t2 - t1, "refine_s": t3 - t2}
        self.build_s_ = t3 - t0

    def _hidden(self, goals: np.ndarray) -> np.ndarray:
        """(S, V) ``GridPlanner.blocked`` from each goal to each vertex, testing only the
        obstacles in the segment's direction (``SightIndex``)."""
        nv, n_goals = self.n_vertices_, len(goals)
        verts = self.planner.vertices_
        out = np.zeros((n_goals, nv), dtype=bool)
        for g0 in range(0, n_goals if nv else 0, SITES_PER_PASS):
            goal = np.repeat(np.arange(g0, min(n_goals, g0 + SITES_PER_PASS)), nv)
            vertex = np.tile(np.arange(nv), len(goal) // max(1, nv))
            seg, obstacle = self.sight_.candidates(nv + goal, verts[vertex])
            cut = self.planner.blocked_by(goals[goal[seg]], verts[vertex[seg]], obstacle)
            hit = np.bincount(seg[cut], minlength=len(goal)) > 0
            out[g0 : g0 + SITES_PER_PASS] = hit.reshape(-1, nv)
        return out

    def _index_mixed(self, mixed) -> None:
        """File the undecided (cell, site) pairs' candidate lists.

        Many pairs share one list (the same anchors, each seen whole or not): the most common
        lists get table codes of their own (``group_base_`` on), so a query reads its list
        directly; pairs with a rare list keep the code ``mixed_code_`` and are found by key
        (cell * sites + site) in a sorted index."""
        n_sites = len(self.sites)
        key = np.concatenate([m[0] for m in mixed])
        anchor = np.concatenate([m[1] for m in mixed])
        full = np.concatenate([m[2] for m in mixed])
        mixed.clear()
        starts = run_starts(key)  # each pair's candidates are consecutive
        sizes = np.diff(np.append(starts, len(key)))
        rank = np.arange(len(key), dtype=np.int32) - np.repeat(starts.astype(np.int32), sizes)
        code = anchor.astype(np.int32) * 2 + full + 1
        digest = np.zeros(len(starts), dtype=np.uint64)
        step = self.pairs_per_pass  # bounds the temporaries
        with np.errstate(over="ignore"):  # a digest: uint64 arithmetic wraps on purpose
            mix = np.uint64(0x9E3779B97F4A7C15)
            powers = np.full(int(sizes.max(initial=1)), mix, dtype=np.uint64)
            powers[0] = 1
            powers = np.cumprod(powers)  # mix ** rank
            for p0 in range(0, len(starts), step):
                lo = starts[p0]
                hi = starts[p0 + step] if p0 + step < len(starts) else len(key)
                term = code[lo:hi].astype(np.uint64) * powers[rank[lo:hi]]
                digest[p0 : p0 + step] = np.add.reduceat(term, starts[p0 : p0 + step] - lo)
            digest = digest * mix + sizes.astype(np.uint64)
        del rank
        _, rep, which, count = np.unique(
            digest, return_index=True, return_inverse=True, return_counts=True
        )
        del digest
        rep_pair = rep[which]  # the first pair with the same digest: its list must be equal
        same = sizes == sizes[rep_pair]
        for p0 in range(0, len(starts), step):
            part = slice(p0, p0 + step)
            lo = starts[p0]
            hi = starts[p0 + step] if p0 + step < len(starts) else len(key)
            ref = np.repeat(starts[rep_pair[part]] - starts[part], sizes[part]) + np.arange(lo, hi)
            ref = np.minimum(ref, len(key) - 1)
            same[part] &= np.logical_and.reduceat(code[lo:hi] == code[ref], starts[part] - lo)
        del code
        capacity = min(np.iinfo(self.table_.dtype).max + 1 - self.group_base_, self.max_groups)
        popular = np.argsort(-count, kind="stable")[:capacity]
        group_of = np.full(len(count), -1)
        group_of[popular] = np.arange(len(popular))
        group = np.where(same, group_of[which], -1)
        listed = np.flatnonzero(group >= 0)
        cell, site = key[starts[listed]] // n_sites, key[starts[listed]] % n_sites
        self.table_[cell, site] = self.group_base_ + group[listed]
        first = starts[rep[popular]]
        g_sizes = sizes[rep[popular]]
        g_entry = np.repeat(first - np.cumsum(g_sizes) + g_sizes, g_sizes) + np.arange(
            g_sizes.sum()
        )
        rare = np.flatnonzero(group < 0)
        rare = rare[np.argsort(key[starts[rare]], kind="stable")]
        r_sizes = sizes[rare]
        r_entry = np.repeat(starts[rare] - np.cumsum(r_sizes) + r_sizes, r_sizes)
        r_entry += np.arange(r_sizes.sum())
        self.group_start_ = np.append(0, np.cumsum(g_sizes)).astype(np.int32)
        self.mixed_key_ = key[starts[rare]]
        self.mixed_start_ = (len(g_entry) + np.append(0, np.cumsum(r_sizes))).astype(np.int32)
        self.entry_anchor_ = np.concatenate([anchor[g_entry], anchor[r_entry]])
        self.entry_full_ = np.concatenate([full[g_entry], full[r_entry]])

    @property
    def nbytes(self) -> int:
        """Bytes the field holds (tables and indexes)."""
        return self._nbytes() + self.sight_.nbytes

    def _nbytes(self) -> int:
        arrays = (
            self.table_,
            self.anchor_z_,
            self.anchor_f_,
            self.goal_extra_,
            self.clear_,
            self.care_,
            self.mixed_key_,
            self.mixed_start_,
            self.group_start_,
            self.entry_anchor_,
            self.entry_full_,
        )
        return sum(a.nbytes for a in arrays)

    def columns(self, sites: np.ndarray) -> np.ndarray:
        """(k,) the field's column of each site (k, 2), -1 where the field does not know it."""
        col = self.column_
        return np.array(
            [col.get((x, y), -1) for x, y in np.asarray(sites).tolist()], dtype=np.int64
        )

    def distances(self, positions: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Planned path length (m) from each position (m, 2) to the sites ``cols`` (k,) known
        to the field (:meth:`columns`), as ``GridPlanner.distances`` computes it."""
        pl = self.planner
        pos = np.asarray(positions, dtype=float).reshape(-1, 2)
        grid = self.grid_
        cell = grid.cells(pos)
        check = np.flatnonzero(~self.clear_[cell] | ~grid.holds(pos))
        snapped, extra = pos, None
        if check.size:
            bad = check[~pl.free(pos[check])]
            if bad.size:
                snapped = pos.copy()
                snapped[bad] = pl.snap(pos[bad])
                extra = np.linalg.norm(pos - snapped, axis=1)
                cell = grid.cells(snapped)
                odd = bad[~self.care_[cell[bad]] | ~grid.holds(snapped[bad])]
                if odd.size:  # pushed out of the arena, or deep into an obstacle: no table
                    out = self.distances(np.delete(pos, odd, axis=0), cols)
                    exact = pl.exact_distances(pos[odd], self.sites[cols])
                    return np.insert(out, odd - np.arange(len(odd)), exact, axis=0)
        z = snapped @ np.array([1.0, 1j])
        codes = self.table_[cell][:, cols]
        nv, mixed = self.n_vertices_, self.mixed_code_
        out = np.abs(z[:, None] - self.anchor_z_[cols, nv][None, :])  # most see their site
        flat = np.flatnonzero(codes != nv)
        r, c = np.divmod(flat, len(cols))
        code = codes.ravel()[flat]
        via = np.flatnonzero(code < nv)
        at = cols[c[via]] * self.anchor_f_.shape[1] + code[via]
        zv = self.anchor_z_.ravel()[at]
        out.ravel()[flat[via]] = np.abs(z[r[via]] - zv) + self.anchor_f_.ravel()[at]
        out.ravel()[flat[code == self.inf_code_]] = np.inf
        several = np.flatnonzero(code >= mixed)
        if several.size:
            r, c = r[several], c[several]
            out.ravel()[flat[several]] = self._mixed(snapped, z, r, cell[r], cols[c], code[several])
        if extra is not None:
            out[bad] += extra[bad, None]
        goal_extra = self.goal_extra_[cols]
        if goal_extra.any():
            out += goal_extra[None, :]
        return out

    def _mixed(self, pts, z, robot, cell: np.ndarray, cols: np.ndarray, code: np.ndarray):
        """Distances of the (robot, site) pairs whose cell keeps several candidates (table
        ``code``): the cheapest candidate the robot sees (one exact test per robot and
        candidate point)."""
        nv, n_pts = self.n_vertices_, self.n_vertices_ + len(self.sites)
        group = code.astype(np.int64) - self.group_base_
        lo = self.group_start_[np.maximum(group, 0)]
        hi = self.group_start_[np.maximum(group, 0) + 1]
        rare = np.flatnonzero(group < 0)
        if rare.size:
            key = (cell[rare] * len(self.sites) + cols[rare]).astype(np.int32)
            row = np.searchsorted(self.mixed_key_, key)
            lo[rare], hi[rare] = self.mixed_start_[row], self.mixed_start_[row + 1]
        sizes = hi - lo
        entry = np.repeat(lo - np.cumsum(sizes) + sizes, sizes) + np.arange(sizes.sum())
        pair = np.repeat(np.arange(len(code)), sizes)
        anchor = self.entry_anchor_[entry].astype(np.int64)
        s = cols[pair]
        at = s * self.anchor_f_.shape[1] + anchor
        az = self.anchor_z_.ravel()[at]
        value = np.abs(z[robot[pair]] - az) + self.anchor_f_.ravel()[at]
        starts = np.cumsum(sizes) - sizes
        full = self.entry_full_[entry]
        sure = np.minimum.reduceat(np.where(full, value, np.inf), starts)
        test = np.flatnonzero(~full & (value < sure[pair]))  # could beat the best one seen whole
        if test.size:
            point = np.where(anchor[test] == nv, nv + s[test], anchor[test])
            key, first, inv = np.unique(
                robot[pair[test]] * n_pts + point, return_index=True, return_inverse=True
            )
            a = pts[key // n_pts]
            b = az[test[first]]
            seg, obstacle = self.sight_.candidates(key % n_pts, a)
            cut = self.planner.blocked_by(a[seg], np.column_stack([b.real, b.imag])[seg], obstacle)
            blocked = np.bincount(seg[cut], minlength=len(key)) > 0
            value[test[blocked[inv]]] = np.inf
        return np.minimum.reduceat(value, starts)


def _grid(width_m: float, height_m: float, n_sites: int) -> tuple[Grid, int]:
    """Cells of about ``CELL_M`` (larger if the table would pass ``TABLE_BYTES``), in whole
    top blocks of about ``TOP_M``; and the number of halvings from top blocks to cells."""
    cell = max(CELL_M, np.sqrt(width_m * height_m * 2 * max(1, n_sites) / TABLE_BYTES))
    levels = round(float(np.log2(max(1.0, TOP_M / cell))))
    k = 1 << levels
    nx = k * max(1, round(width_m / (k * cell)))
    ny = k * max(1, round(height_m / (k * cell)))
    return Grid(width_m / nx, height_m / ny, nx, ny), levels


def _in_box(grid: Grid, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(cells,) True where a cell meets the box [lo, hi]."""
    x0 = np.arange(grid.nx) * grid.dx_m
    y0 = np.arange(grid.ny) * grid.dy_m
    cx = (x0 <= hi[0]) & (x0 + grid.dx_m >= lo[0])
    cy = (y0 <= hi[1]) & (y0 + grid.dy_m >= lo[1])
    return (cy[:, None] & cx[None, :]).ravel()


def _within_box(grid: Grid, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(cells,) True where a cell lies inside the box [lo, hi]."""
    x0 = np.arange(grid.nx) * grid.dx_m
    y0 = np.arange(grid.ny) * grid.dy_m
    cx = (x0 >= lo[0]) & (x0 + grid.dx_m <= hi[0])
    cy = (y0 >= lo[1]) & (y0 + grid.dy_m <= hi[1])
    return (cy[:, None] & cx[None, :]).ravel()


def planner_obstacles(planner) -> Obstacles:
    """The planner's inflated polygons as the raster wants them (shrunk as its segment test)."""
    polys = planner.polygons_
    k, e = planner.offsets_.shape if len(polys) else (0, 1)
    verts = np.zeros((k, e, 2))
    for i, p in enumerate(polys):
        verts[i, : len(p)], verts[i, len(p) :] = p, p[0]
    return Obstacles(verts, planner.normals_, planner.offsets_ - planner.tol_m, planner.real_)


class FieldCache:
    """The last few fields built in this process, by arena and sites: runs of one scenario
    (a sweep's seeds on one worker) build theirs once. Fields are read-only, so sharing them
    changes no result."""

    def __init__(self, size: int = 2) -> None:
        self.size = size
        self._fields: OrderedDict = OrderedDict()

    def get(self, key, build) -> DistanceField:
        """The field for ``key``, built by ``build()`` if it is not kept."""
        field = self._fields.pop(key, None)
        if field is None:
            field = build()
        self._fields[key] = field
        while len(self._fields) > self.size:
            self._fields.popitem(last=False)
        return field

    def clear(self) -> None:
        self._fields.clear()


SHARED = FieldCache()
