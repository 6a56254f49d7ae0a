"""Which anchor can be a robot's best, where: the coarse-to-fine refinement of the distance field.

For one task site an *anchor* is an obstacle vertex (its geodesic distance F to the site known)
or the site itself (F = 0); the planner's distance from p is the least |p - a| + F(a) over the
anchors a that p sees. A block of cells starts with every anchor and passes to its four
sub-blocks only those that may win somewhere in it; an anchor is dropped when

- the block does not see it at all (``sim.spatial.navigation.raster`` shadows; the certainty margin
keeps
  this exact),
- the block lies outside its *taut wedge*: a shortest path that bends at a vertex a toward the
  next vertex n wraps a's obstacle, so p - a lies between the far edge of the obstacle at a and
  the extension of n -> a beyond a. Every shortest path is taut, whichever of several equally
  short continuations the planner recorded, so the wedge of any one of them holds the points
  whose best anchor is a (with a small angular slack for rounding),
- it is dominated: an anchor seen from the whole block is cheaper at every point of it (the
  difference |p - b| - |p - a| varies over the block by at most the block's radius times
  2 sin(phi / 2), phi bounding the angle under which a and b are seen from the block).

A block seen entirely by its site is straight-line; a block left with one anchor seen entirely
is settled. Candidates only ever leave for a proof.
"""

from __future__ import annotations

import numpy as np

from sim.spatial.navigation.raster import FULL, PART, Grid

WEDGE_SLACK_RAD = 1e-4  # taut wedges are widened by this angle, and by MARGIN_M
MARGIN_M = 1e-6
DOMINANCE_TOL_M = 1e-7


def refine(
    grid: Grid, top: int, pyramid, kind, normals, zv, anchor_z, anchor_f, s0: int, n_sites: int
):
    """The anchor table of a few sites, coarse to fine.

    Args:
        grid: the cells; blocks of ``2**top`` x ``2**top`` cells are the coarsest.
        top: number of halvings from the coarsest blocks to the cells.
        pyramid: per level (cells first) the visibility class (``sim.spatial.navigation.raster``) of
        every
            point (V vertices, then every site's goal) from every block, (P, blocks).
        kind, normals: the sites' taut wedges (:func:`taut_wedges`), (S', V).
        zv: (V,) the vertices (x + iy).
        anchor_z, anchor_f: (S', V + 3) the sites' anchors and their geodesic to the site.
        s0: index of the first of these sites among all ``n_sites``.

    Returns:
        (S', cells) codes: anchor 0..V (V: the site itself), V + 1 no path, V + 2 several
        candidates; and for the latter their candidates as (int32 key cell * n_sites + site,
        int16 anchor, bool seen from the whole cell), each cell's consecutive.
    """
    nv = len(zv)
    n_s = len(anchor_z)
    s1 = s0 + n_s
    inf_code, mixed_code = nv + 1, nv + 2
    codes = np.full((n_s, grid.ny, grid.nx), inf_code, dtype=np.int16)
    nbx, nby = grid.nx >> top, grid.ny >> top
    seen = pyramid[top] & 2 > 0  # (points, top blocks): seen from some point of the block
    start = np.empty((n_s, nby * nbx, nv + 1), dtype=bool)
    start[:, :, :nv] = seen[:nv].T[None] & (kind[:, None, :] > 0)
    start[:, :, nv] = seen[nv + s0 : nv + s1]
    site, block, anchor = (a.astype(np.int32) for a in np.nonzero(start))
    az_all, af_all = anchor_z, anchor_f
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
            keep[w] = ~outside_wedge(
                normals[site[w], anchor[w]], zv[anchor[w]], x0, y0, side_x, side_y
            )
        site, block, anchor, vis = site[keep], block[keep], anchor[keep], vis[keep]
        bx, by = bx[keep], by[keep]
        pair = site * (bx_n * (grid.ny >> level)) + block
        starts = run_starts(pair)
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
        starts = run_starts(pair)
        sizes = np.diff(np.append(starts, len(pair)))
        one = (sizes == 1) & (vis[starts] == FULL) if pair.size else np.zeros(0, bool)
        first = starts[one]
        _write(codes, level, site[first], bx[first], by[first], anchor[first])
        if level == 0:
            rest = ~np.repeat(one, sizes)
            _write(codes, 0, site[rest], bx[rest], by[rest], mixed_code)
            key = block[rest].astype(np.int32) * n_sites + (site[rest] + s0)
            extra = (key.astype(np.int32), anchor[rest].astype(np.int16), vis[rest] == FULL)
            return codes.reshape(n_s, -1), extra
        rest = ~np.repeat(one, sizes)
        site, anchor, bx, by = site[rest], anchor[rest], bx[rest], by[rest]
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


def run_starts(key: np.ndarray) -> np.ndarray:
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


def next_points(planner, dist: np.ndarray, last: np.ndarray, goal: complex) -> np.ndarray:
    """(V,) the point after each vertex on its recorded shortest path to the goal (x + iy)."""
    nv = len(dist)
    here = np.arange(nv)
    ok = np.isfinite(dist) & (last >= 0)
    nxt = np.full(nv, -1)
    via = ok & (last != here)
    nxt[via] = planner.pred_[last[via], here[via]]
    z = planner.vertices_ @ np.array([1.0, 1j])
    return np.where(nxt >= 0, z[np.maximum(nxt, 0)], goal)


def edge_directions(planner) -> tuple[np.ndarray, np.ndarray]:
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


def taut_wedges(zv: np.ndarray, edges, nxt: np.ndarray, dist: np.ndarray):
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


def outside_wedge(normals, apex, x0, y0, side_x, side_y) -> np.ndarray:
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
