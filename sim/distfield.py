"""Planned-path distances for a whole fleet: each task site's shortest-path map on a grid.

The planner's distance from a point p to a site s is min over the anchors a that p sees of
|p - a| + F_s(a): an anchor is an obstacle vertex (F_s its geodesic distance to s) or the site
itself (F_s = 0). Which anchor wins depends on where p is, so this module precomputes it: for
every cell of a grid (about ``CELL_M``) and every site, the anchor that is optimal for *every*
point of the cell. A bid is then one table look-up and one straight segment. Where no single
anchor is certain (the cell straddles a shadow edge or a boundary between two anchors' regions:
a few per cent of the pairs) the cell keeps a short list of candidates, and a query tests those
exactly, with the planner's own segment test.

Candidates are found coarse to fine. A block of cells starts with every anchor and passes to its
four sub-blocks only those that may win somewhere in it; an anchor is dropped when

- the block does not see it at all (``sim.raster`` shadows; the certainty margin keeps this
  exact),
- the block lies outside its *taut wedge*: a shortest path that bends at a vertex a toward the
  next vertex n wraps a's obstacle, so p - a lies between the far edge of the obstacle at a and
  the extension of n -> a beyond a. Every shortest path is taut, whichever of several equally
  short continuations the planner recorded, so the wedge of any one of them holds the points
  whose best anchor is a (with a small angular slack for rounding),
- it is dominated: an anchor seen from the whole block is cheaper at every point of it (the
  difference |p - b| - |p - a| varies over the block by at most the block's radius times
  2 sin(phi / 2), phi bounding the angle under which a and b are seen from the block).

A block seen entirely by its site is straight-line; a block left with one anchor seen entirely
is settled. Candidates only ever leave for a proof, so the table gives the planner's distance up
to rounding (the tests compare it with ``GridPlanner.path`` lengths).
"""

from __future__ import annotations

import time
from collections import OrderedDict

import numpy as np

from sim.raster import (
    DONT_CARE,
    FULL,
    PART,
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
WEDGE_SLACK_RAD = 1e-4  # taut wedges are widened by this angle, and by MARGIN_M
MARGIN_M = 1e-6
DOMINANCE_TOL_M = 1e-7


class DistanceField:
    """The anchor table of a planner's arena for a fixed set of task sites.

    Build with :meth:`build`; query with :meth:`distances`. Everything is read-only once
    built, so one field may serve every planner with the same obstacles and sites
    (:func:`shared_field`).
    """

    def __init__(self, planner, sites: np.ndarray) -> None:
        self.planner = planner
        self.sites = np.unique(np.asarray(sites, dtype=float).reshape(-1, 2), axis=0)

    @classmethod
    def build(cls, planner, sites: np.ndarray) -> DistanceField:
        """Precompute the table for ``sites`` (k, 2) in ``planner``'s arena."""
        field = cls(planner, sites)
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
        if nv + 3 > np.iinfo(np.int16).max:
            raise ValueError(f"{nv} obstacle vertices: the anchor table holds at most 32764")
        self.grid_, self.levels_ = grid, levels = _grid(
            pl.spatial.width_m, pl.spatial.height_m, n_sites
        )
        if grid.nx * grid.ny * n_sites >= 2**31:
            raise ValueError("too many cells x sites for the index of undecided pairs")
        obstacles = planner_obstacles(pl)
        points = np.concatenate([verts, goals])
        self.sight_ = SightIndex(points, obstacles)
        hidden = self._hidden(goals)
        dist = np.full((n_sites, nv), np.inf)
        nxt = np.zeros((n_sites, nv), dtype=complex)
        for s, goal in enumerate(goals):
            d, last = pl.goal_field(goal, hidden[s])
            dist[s] = d
            nxt[s] = _next_points(pl, d, last, complex(*goal))
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
        wedge = _wedge_geometry(pl)
        table = np.empty((grid.nx * grid.ny, n_sites), dtype=np.uint16)
        mixed = []
        for s0 in range(0, n_sites, SITES_PER_PASS):
            s1 = min(n_sites, s0 + SITES_PER_PASS)
            normals, kind = _wedges(zv, wedge, nxt[s0:s1], dist[s0:s1])
            codes, extra = self._refine(s0, s1, pyramid, normals, kind, zv)
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

    def _refine(self, s0: int, s1: int, pyramid, normals, kind, zv):
        """Anchor codes (s1 - s0, cells) of sites s0..s1 and their undecided cells' candidates."""
        grid, nv, top = self.grid_, self.n_vertices_, self.levels_
        n_s = s1 - s0
        codes = np.full((n_s, grid.ny, grid.nx), self.inf_code_, dtype=np.int16)
        nbx, nby = grid.nx >> top, grid.ny >> top
        seen = pyramid[top] & 2 > 0  # (points, top blocks): seen from some point of the block
        start = np.empty((n_s, nby * nbx, nv + 1), dtype=bool)
        start[:, :, :nv] = seen[:nv].T[None] & (kind[:, None, :] > 0)
        start[:, :, nv] = seen[nv + s0 : nv + s1]
        site, block, anchor = (a.astype(np.int32) for a in np.nonzero(start))
        az_all, af_all = self.anchor_z_[s0:s1], self.anchor_f_[s0:s1]
        for level in range(top, -1, -1):
            bx_n = grid.nx >> level
            side_x, side_y = grid.dx_m * (1 << level), grid.dy_m * (1 << level)
            bx, by = block % bx_n, block // bx_n
            point = np.where(anchor == nv, nv + s0 + site, anchor)
            vis = pyramid[level][point, block]
            keep = (vis == FULL) | (vis == PART)
            w = keep & (anchor < nv)
            w[w] = kind[site[w], anchor[w]] == 1
            if w.any():
                x0, y0 = bx[w] * side_x, by[w] * side_y
                keep[w] = ~_outside_wedge(
                    normals[site[w], anchor[w]], zv[anchor[w]], x0, y0, side_x, side_y
                )
            site, block, anchor, vis = site[keep], block[keep], anchor[keep], vis[keep]
            bx, by = bx[keep], by[keep]
            pair = site * (bx_n * (grid.ny >> level)) + block
            starts = _starts(pair)
            direct = (
                np.maximum.reduceat((anchor == nv) & (vis == FULL), starts)
                if pair.size
                else np.zeros(0, bool)
            )
            centre = (bx + 0.5) * side_x + 1j * (by + 0.5) * side_y
            az, af = az_all[site, anchor], af_all[site, anchor]
            to_a = np.abs(centre - az)
            g = to_a + af
            g_full = np.where(vis == FULL, g, np.inf)
            sizes = np.diff(np.append(starts, len(pair)))
            best = np.minimum.reduceat(g_full, starts) if pair.size else g_full
            at_best = (g_full == np.repeat(best, sizes)) & (vis == FULL)
            at_best = np.where(at_best, np.arange(len(pair)), len(pair))
            star = np.minimum.reduceat(at_best, starts) if pair.size else at_best
            has = np.repeat(star < len(pair), sizes)
            star_e = np.repeat(np.minimum(star, len(pair) - 1), sizes)
            rho = 0.5 * np.hypot(side_x, side_y)
            gap = g - g[star_e]  # at the block centre
            maybe = has & (gap > DOMINANCE_TOL_M)
            drop = maybe & (gap - 2.0 * rho > DOMINANCE_TOL_M)  # |p - b| - |p - a| is 2-Lipschitz
            fine = np.flatnonzero(maybe & ~drop)
            if fine.size:
                b, a = to_a[fine], to_a[star_e[fine]]
                phi = np.abs(
                    np.angle((az[fine] - centre[fine]) * np.conj(az[star_e[fine]] - centre[fine]))
                )
                with np.errstate(divide="ignore"):
                    phi += np.arcsin(np.minimum(1.0, rho / b)) + np.arcsin(np.minimum(1.0, rho / a))
                slope = 2.0 * np.sin(np.minimum(np.pi, phi) / 2.0)
                drop[fine] = gap[fine] - rho * slope > DOMINANCE_TOL_M
            keep = ~drop & ~np.repeat(direct, sizes)
            settled_direct = np.flatnonzero(direct)
            _write(
                codes,
                level,
                site[starts[settled_direct]],
                bx[starts[settled_direct]],
                by[starts[settled_direct]],
                nv,
            )
            site, block, anchor, vis, bx, by, pair = (
                a[keep] for a in (site, block, anchor, vis, bx, by, pair)
            )
            starts = _starts(pair)
            sizes = np.diff(np.append(starts, len(pair)))
            one = (sizes == 1) & (vis[starts] == FULL) if pair.size else np.zeros(0, bool)
            first = starts[one]
            _write(codes, level, site[first], bx[first], by[first], anchor[first])
            if level == 0:
                rest = ~np.repeat(one, sizes)
                _write(codes, 0, site[rest], bx[rest], by[rest], self.mixed_code_)
                key = block[rest].astype(np.int32) * len(self.sites) + (site[rest] + s0)
                extra = (key.astype(np.int32), anchor[rest].astype(np.int16), vis[rest] == FULL)
                return codes.reshape(n_s, -1), extra
            rest = ~np.repeat(one, sizes)
            site, anchor, bx, by = site[rest], anchor[rest], bx[rest], by[rest]
            starts = starts[~one]
            sizes = sizes[~one]
            new_start = np.cumsum(np.append(0, sizes[:-1])) if sizes.size else sizes
            rank = np.arange(len(site)) - np.repeat(new_start, sizes)
            base = 4 * np.repeat(new_start, sizes) + rank
            n_sz = np.repeat(sizes, sizes)
            order = np.empty(4 * len(site), dtype=np.int64)
            child_block = np.empty(4 * len(site), dtype=np.int32)
            nx_child = 2 * bx_n
            for c, (i, j) in enumerate(((0, 0), (1, 0), (0, 1), (1, 1))):
                pos = base + c * n_sz
                order[pos] = np.arange(len(site))
                child_block[pos] = (2 * by + j) * nx_child + 2 * bx + i
            site, anchor, block = site[order], anchor[order], child_block
        raise AssertionError("unreachable")

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
        starts = _starts(key)  # each pair's candidates are consecutive
        sizes = np.diff(np.append(starts, len(key)))
        rank = np.arange(len(key), dtype=np.int32) - np.repeat(starts.astype(np.int32), sizes)
        code = anchor.astype(np.int32) * 2 + full + 1
        digest = np.zeros(len(starts), dtype=np.uint64)
        step = 1 << 16  # pairs per pass: bounds the temporaries
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
        capacity = np.iinfo(self.table_.dtype).max + 1 - self.group_base_
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


def _starts(key: np.ndarray) -> np.ndarray:
    """Start of each run of equal values in ``key``."""
    if not key.size:
        return np.zeros(0, dtype=np.int64)
    return np.flatnonzero(np.append(True, key[1:] != key[:-1]))


def _write(codes, level, site, bx, by, code) -> None:
    """Set the cells of blocks (bx, by) at ``level`` of ``site`` (local) to ``code``."""
    if not len(site):
        return
    n_s, ny, nx = codes.shape
    k = 1 << level
    view = codes.reshape(n_s, ny // k, k, nx // k, k)
    value = np.broadcast_to(np.asarray(code, dtype=np.int16), site.shape)
    view[site, by, :, bx, :] = value[:, None, None]


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


def _next_points(planner, dist: np.ndarray, last: np.ndarray, goal: complex) -> np.ndarray:
    """(V,) the point after each vertex on its recorded shortest path to the goal (x + iy)."""
    nv = len(dist)
    here = np.arange(nv)
    ok = np.isfinite(dist) & (last >= 0)
    nxt = np.full(nv, -1)
    via = ok & (last != here)
    nxt[via] = planner.pred_[last[via], here[via]]
    z = planner.vertices_ @ np.array([1.0, 1j])
    return np.where(nxt >= 0, z[np.maximum(nxt, 0)], goal)


def _wedge_geometry(planner) -> tuple[np.ndarray, np.ndarray]:
    """Unit directions (V,) along the two polygon edges at each vertex (x + iy)."""
    polys = planner.polygons_
    if not polys:
        return np.zeros(0, dtype=complex), np.zeros(0, dtype=complex)
    allv = np.concatenate(polys)
    prev = np.concatenate([np.roll(p, 1, axis=0) for p in polys]) - allv
    nxt = np.concatenate([np.roll(p, -1, axis=0) for p in polys]) - allv
    keep = planner.free(allv)
    e1, e2 = (v[keep] @ np.array([1.0, 1j]) for v in (prev, nxt))
    return e1 / np.abs(e1), e2 / np.abs(e2)


def _wedges(zv: np.ndarray, edges, nxt: np.ndarray, dist: np.ndarray):
    """Taut wedges of every vertex toward its next point, for a few sites.

    Returns:
        normals (S, V, 2) complex: p is in the wedge of vertex v if Re(conj(n) (p - v)) <= 0
        for both; kind (S, V): 0 never an anchor, 1 a wedge, 2 anywhere (no usable direction).
    """
    e1, e2 = edges
    u = nxt - zv[None]
    length = np.abs(u)
    u = u / np.where(length > 0, length, 1.0)
    c1 = (np.conj(u) * e1).imag  # cross(u, e1)
    c2 = (np.conj(u) * e2).imag
    behind = (c1 * c2 < 0) & (np.abs(c1) > 1e-9) & (np.abs(c2) > 1e-9)  # -u inside the obstacle
    far = np.where((np.conj(u) * e1).real < (np.conj(u) * e2).real, e1, e2)
    w = -u
    ccw = (np.conj(far) * w).imag >= 0
    n1 = np.where(ccw, -1j * far, 1j * far)  # Re(conj(n1) q) <= 0  <=>  cross(far, q) >= 0 (ccw)
    n2 = np.where(ccw, 1j * w, -1j * w)
    kind = np.where(behind, 0, 1)
    kind = np.where(length < 1e-6, 2, kind)
    kind = np.where(np.isfinite(dist), kind, 0)
    return np.stack([n1, n2], axis=-1), kind


def _outside_wedge(normals, apex, x0, y0, side_x, side_y) -> np.ndarray:
    """(n,) True where the block [x0, x0 + side_x] x [y0, y0 + side_y] lies outside the wedge:
    beyond one of its two lines, by the margins, at the block's nearest corner to that line."""
    half_x, half_y = 0.5 * side_x, 0.5 * side_y
    q = (x0 + half_x - apex.real) + 1j * (y0 + half_y - apex.imag)  # block centre - apex
    slack = MARGIN_M + WEDGE_SLACK_RAD * (np.abs(q) + np.hypot(half_x, half_y))
    out = np.zeros(len(apex), dtype=bool)
    for k in range(2):
        n = normals[:, k]
        near = (
            (n.real * q.real + n.imag * q.imag) - half_x * np.abs(n.real) - half_y * np.abs(n.imag)
        )
        out |= near > slack
    return out


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
