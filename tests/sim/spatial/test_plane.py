"""``sim.spatial.plane``: the event rules' compiled geometry gives numpy's
answers, bit for bit with numpy's baseline kernels (the golden runs' numerics, checked in a
child Python with ``NPY_ENABLE_CPU_FEATURES=X86_V2``) and within rounding with the kernels
this CPU dispatches; and the cases that decide by a tie or a touch come out as numpy's do.

The numpy functions below are that geometry as it was written in numpy: the
reference the compiled functions are held to.
"""

from __future__ import annotations

import numpy as np
import pytest

from sim.spatial import plane
from sim.spatial.sites import Sites
from sim.spatial.traffic.geometry import TOL_M, clip_line, disc_polygon, path_gaps, polygon_gap
from sim.spatial.traffic.geometry import to_segments as np_to_segments
from tests.golden.cases import in_baseline_child


# -- the numpy reference -------------------------------------------------------------------
def _next(poly):
    return np.concatenate((poly[1:], poly[:1]))


def np_inside(points, poly):
    e0, e1 = poly, _next(poly)
    cross = ((e1 - e0)[None, :].conj() * (np.asarray(points)[:, None] - e0[None, :])).imag
    return (cross > TOL_M).all(axis=1)


def np_polygon_gap(pa, pb):
    a0, a1 = pa, _next(pa)
    b0, b1 = pb, _next(pb)
    d_ab, near_ab = np_to_segments(pa[:, None], b0[None, :], b1[None, :])
    d_ba, near_ba = np_to_segments(pb[:, None], a0[None, :], a1[None, :])
    i, k = np.unravel_index(int(d_ab.argmin()), d_ab.shape)
    m, n = np.unravel_index(int(d_ba.argmin()), d_ba.shape)
    if d_ab[i, k] <= d_ba[m, n]:
        gap, p, q = float(d_ab[i, k]), complex(pa[i]), complex(near_ab[i, k])
    else:
        gap, p, q = float(d_ba[m, n]), complex(near_ba[m, n]), complex(pb[m])
    if np_inside(pa, pb).any() or np_inside(pb, pa).any():
        return 0.0, p, q
    return gap, p, q


def np_clip_line(origin, direction, poly):
    e0, e1 = poly, _next(poly)
    edge = e1 - e0
    base = (edge.conj() * (origin - e0)).imag
    rate = (edge.conj() * direction).imag
    lo, hi = -np.inf, np.inf
    for b, r in zip(base.tolist(), rate.tolist(), strict=True):
        if abs(r) < 1e-15:
            if b < -TOL_M:
                return np.inf, -np.inf
            continue
        t = -b / r
        if r > 0:
            lo = max(lo, t - TOL_M / r)
        else:
            hi = min(hi, t - TOL_M / r)
    return (lo, hi) if lo <= hi else (np.inf, -np.inf)


def np_path_gaps(points, path):
    gap, _ = np_to_segments(points[:, None], path[None, :-1], path[None, 1:])
    return gap.min(axis=1)


def np_way_gaps(points, z, pts, idx):
    aim = pts[np.arange(len(pts)), idx]
    gap = np_to_segments(points[None, :], z[:, None], aim[:, None])[0].min(axis=1)
    if pts.shape[1] > 1:
        seg = np_to_segments(points[None, None, :], pts[:, :-1, None], pts[:, 1:, None])[0]
        ahead = np.arange(pts.shape[1] - 1)[None, :] >= idx[:, None]
        seg = np.where(ahead[:, :, None], seg, np.inf)
        gap = np.minimum(gap, seg.min(axis=(1, 2)))
    return gap


def np_way_waits(pts, idx, last, after, z, service, work_z, work_service, end_s, t, v_max, block):
    col = np.arange(pts.shape[1])
    prev = np.concatenate((pts[:, -1:], pts[:, :-1]), axis=1)
    start = np.where(col == idx[:, None], z[:, None], prev)
    seg = pts - start
    live = (col >= idx[:, None]) & (col <= last[:, None])
    seg2 = (seg * seg.conj()).real
    rel = work_z[None, :, None] - start[:, None, :]
    frac = (rel * seg.conj()[:, None, :]).real / np.maximum(seg2, 1e-18)[:, None, :]
    frac = np.clip(frac, 0.0, 1.0)
    gap = np.abs(rel - frac * seg[:, None, :])
    gap = np.where(live[:, None, :], gap, np.inf)
    near = gap.argmin(axis=2)
    pick = np.take_along_axis
    nearest = pick(gap, near[..., None], axis=2)[..., 0]
    close = nearest < block
    seg_m = np.sqrt(seg2)
    rest = pick(after, near, axis=1) + (1.0 - pick(frac, near[..., None], axis=2)[..., 0]) * pick(
        seg_m, near, axis=1
    )
    total = np.abs(pick(pts, idx[:, None], axis=1) - z[:, None]) + pick(after, idx[:, None], axis=1)
    along = total - rest
    other = np.abs(service[:, None] - work_service[None, :]) > 1e-6
    left = end_s[None, :] - t - along / v_max
    ahead = along > block
    wait = np.where(close & ahead & other, np.maximum(left, 0.0), 0.0)
    return wait, along, np.where(other, nearest, np.inf)


def np_workers_by_way(rows, z, way, grow_m, service, j):
    zw = z[rows]
    box = (zw.real > way.real.min() - grow_m) & (zw.real < way.real.max() + grow_m)
    box &= (zw.imag > way.imag.min() - grow_m) & (zw.imag < way.imag.max() + grow_m)
    rows = rows[box]
    return rows, ~(np.abs(service[rows] - service[j]) > 1e-6)


def np_workers_near(z, work, changed, reach, close_m, boxes, grow_m):
    near = work & (np.abs(z[:, None] - z[changed][None, :]) < reach).any(axis=1)
    rows, at_work = near.nonzero()[0], z[work]
    within = np.abs(z[rows][:, None] - at_work[None, :]) < close_m
    x, y = z[rows].real[:, None], z[rows].imag[:, None]
    keep = (boxes[:, 0] <= x + grow_m) & (boxes[:, 2] >= x - grow_m)
    keep &= (boxes[:, 1] <= y + grow_m) & (boxes[:, 3] >= y - grow_m)
    others, shapes = [], []
    for w, close, box in zip(rows.tolist(), within, keep, strict=True):
        o = at_work[close]
        others.append(o[np.abs(o - z[w]) > 1e-9])
        shapes.append(np.flatnonzero(box))
    others_at = np.cumsum([0] + [len(o) for o in others])
    shapes_at = np.cumsum([0] + [len(b) for b in shapes])
    flat = [np.concatenate(part) if part else np.zeros(0) for part in (others, shapes)]
    return rows, others_at, flat[0], shapes_at, flat[1]


def np_coming_to(state, driving, service, z, site, within_m):
    coming = (state == driving) & (np.abs(service - site) < 1e-6)
    coming &= np.abs(z - site) < within_m
    return coming, coming.any()


def np_exit_clearances(z, ends, zs, j, within_m, coming, admitted):
    around = np.abs(zs - z) < within_m
    around[j] = False
    both = around & coming & admitted
    return Sites.clearance(z, ends, zs[around]), Sites.clearance(z, ends, zs[both])


def np_queue_scan(
    state, code, backoff, replan, blocked, held, z, service, admitted, holding, t, q, crowd_m
):
    driving = (state == code) & (backoff <= t)
    driving &= ~(replan | blocked | held)
    gap = np.abs(z - service)
    close = gap < q
    cand = driving & ~admitted
    near = cand & close
    hold = holding.nonzero()[0]
    if len(hold):
        rest = cand.nonzero()[0]
        same = np.abs(service[rest, None] - service[hold][None, :]) < 1e-6
        crowd = same & (np.abs(z[rest, None] - z[hold][None, :]) < crowd_m)
        near[rest[crowd.any(axis=1)]] = True
    far = float(np.where(driving & (gap >= q), gap, np.inf).min())
    coming = driving & ((admitted & close) | holding)
    return driving, gap, near, coming, (driving & close).any(), far


def np_near_sites(z, rows, sites, reach_m):
    return (np.abs(z[rows][:, None] - sites[None, :]) < reach_m).nonzero()


def np_near_box(way, cx, cy, reach):
    lo = complex(way.real.min(), way.imag.min())
    hi = complex(way.real.max(), way.imag.max())
    keep = (lo.real - reach <= cx) & (cx <= hi.real + reach)
    keep &= (lo.imag - reach <= cy) & (cy <= hi.imag + reach)
    return keep.nonzero()[0]


def np_free_place(places, site, kept, keeping, z, standing, lim, room, here):
    def within(points, centre):
        d = points - centre
        return points[(np.abs(d.real) <= lim) & (np.abs(d.imag) <= lim)]

    near_kept, near_standing = within(kept[keeping], site), within(z[standing], site)
    taken = np.zeros(len(places), dtype=bool)
    if len(near_kept):
        taken |= np.abs(near_kept[:, None] - places[None, :]).min(axis=0) < room
    if len(near_standing):
        taken |= np.abs(near_standing[:, None] - places[None, :]).min(axis=0) < room
    if taken.all():
        return -1
    free = (~taken).nonzero()[0]
    return 0 if free[0] == 0 else int(free[np.abs(places[free] - here).argmin()])


# -- cases ---------------------------------------------------------------------------------
def polygons(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """Convex CCW polygons: robots' octagons at random points, turned polygons of 3 to 8
    sides, and boxes on a half-metre grid (edges shared, corners touching, exact ties)."""
    out = []
    for _ in range(n):
        kind = rng.integers(3)
        if kind == 0:
            out.append(disc_polygon(complex(*rng.uniform(0, 6, 2)), 0.25))
        elif kind == 1:
            sides = int(rng.integers(3, 9))
            turn = np.exp(1j * rng.uniform(0, 2 * np.pi))
            shape = disc_polygon(0j, float(rng.uniform(0.1, 1.5)), sides) * turn
            out.append(complex(*rng.uniform(0, 6, 2)) + shape)
        else:
            x0, y0 = rng.integers(0, 12, 2) / 2
            w, h = rng.integers(1, 5, 2) / 2
            out.append(np.array([x0 + 1j * y0, x0 + w + 1j * y0, x0 + w + 1j * (y0 + h)]))
            out[-1] = np.append(out[-1], x0 + 1j * (y0 + h))
    return out


def lines(rng: np.random.Generator, polys: list[np.ndarray], n: int):
    """(origin, direction) pairs: random, axis-parallel, and along a polygon's edge."""
    out = []
    for s in range(n):
        poly = polys[s % len(polys)]
        kind = s % 3
        if kind == 0:
            origin = complex(*rng.uniform(-1, 7, 2))
            direction = np.exp(1j * rng.uniform(0, 2 * np.pi))
        elif kind == 1:
            origin = complex(*(rng.integers(0, 14, 2) / 2))
            direction = (1, -1, 1j, -1j)[int(rng.integers(4))]
        else:
            k = int(rng.integers(len(poly)))
            edge = poly[(k + 1) % len(poly)] - poly[k]
            origin, direction = complex(poly[k]), complex(edge / abs(edge))
        out.append((complex(origin), complex(direction)))
    return out


def paths(
    rng: np.random.Generator, rows: int, width: int, grid: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(rows, width) polylines padded with their last point, every other one on the
    half-metre grid (with ``grid``), and the waypoint each aims at."""
    pts = rng.uniform(0, 6, (rows, width)) + 1j * rng.uniform(0, 6, (rows, width))
    on_grid = rng.integers(0, 12, (rows, width)) / 2 + 1j * rng.integers(0, 12, (rows, width)) / 2
    if grid:
        pts[::2] = on_grid[::2]
    last = rng.integers(0, width, rows)
    for r in range(rows):
        pts[r, last[r] :] = pts[r, last[r]]
    idx = np.minimum(rng.integers(0, width, rows), last)
    return pts, idx


def all_cases(seed: int):
    """Every compiled function on the same random cases: (name, compiled answer, numpy's)."""
    rng = np.random.default_rng(seed)
    polys = polygons(rng, 60)
    for a in range(len(polys)):
        for b in range(len(polys)):
            pa, pb = polys[a], polys[b]
            yield "polygon_gap", polygon_gap(pa, pb), np_polygon_gap(pa, pb)
    for origin, direction in lines(rng, polys, 600):
        for poly in polys[:20]:
            yield (
                "clip_line",
                clip_line(origin, direction, poly),
                np_clip_line(origin, direction, poly),
            )
    for _ in range(200):
        n, width = int(rng.integers(1, 12)), int(rng.integers(2, 9))
        points = rng.uniform(0, 6, n) + 1j * rng.uniform(0, 6, n)
        path = paths(rng, 1, width)[0][0]
        yield "path_gaps", path_gaps(points, path), np_path_gaps(points, path)
        pts, idx = paths(rng, int(rng.integers(1, 9)), width)
        z = rng.uniform(0, 6, len(pts)) + 1j * rng.uniform(0, 6, len(pts))
        gaps = np_way_gaps(points, z, pts, idx)
        rows = np.flatnonzero(rng.random(len(pts)) < 0.7)
        for name, reach in (("ways_near", rng.uniform(0, 3)), ("ways_near_tie", rng.choice(gaps))):
            got = plane.ways_near(points, float(reach), rows, z, pts, idx)
            yield name, got, (gaps < reach)[rows]  # _tie: a reach equal to one of the gaps
        for name, grid in (("free_place", False), ("free_place_grid", True)):
            got, want = place_cases(rng, grid)
            yield name, got, want
        for name, grid in (("way_waits", False), ("way_waits_grid", True)):
            pts, idx = paths(rng, len(pts), width, grid)
            last = np.maximum(idx, rng.integers(0, width, len(pts)))
            if grid:  # a way with nothing ahead (aiming past its end): numpy's first segment
                last[rng.random(len(pts)) < 0.2] = -1
            seg = np.abs(np.diff(pts, axis=1))  # path left after each waypoint, as a follower's
            after = np.cumsum(seg[:, ::-1], axis=1)[:, ::-1]
            after = np.concatenate([after, np.zeros((len(pts), 1))], axis=1)
            sites = rng.integers(0, 3, len(pts)) + 0j
            args = (pts, idx, last, after, z, sites, points, rng.integers(0, 3, n) + 0j)
            args += (rng.uniform(0, 30, n), float(rng.uniform(0, 10)), 0.7, 0.6)
            got, want = plane.way_waits(*args), np_way_waits(*args)
            yield name, np.concatenate(got, axis=None), np.concatenate(want, axis=None)
    rng = np.random.default_rng([seed, 1])
    for _ in range(200):  # robots at work by a way: on a grid, so some lie on the box's edge
        m = int(rng.integers(1, 30))
        z = rng.integers(0, 7, m) + 1j * rng.integers(0, 7, m) + rng.normal(0, 0.3, m) * (m % 2)
        way = rng.integers(0, 7, int(rng.integers(1, 6))) + 1j * rng.integers(0, 7, 1)
        service = rng.integers(0, 3, m) + 1e-7 * rng.integers(0, 20, m) + 0j
        rows = np.flatnonzero(rng.random(m) < 0.7)
        args = (rows, z, way, float(rng.choice([0.5, 1.0, 1.3])), service, int(rng.integers(m)))
        got, want = plane.workers_by_way(*args), np_workers_by_way(*args)
        yield "workers_by_way", np.concatenate(got), np.concatenate(want)
        k = int(rng.integers(0, 12))  # passages' centres by a way, reach as their sizes
        cx = rng.integers(0, 7, k) + 0.0
        cy = rng.integers(0, 7, k) + rng.normal(0, 0.3, k) * (m % 2)
        reach = rng.choice([0.5, 1.0, 1.3], k)
        yield "near_box", plane.near_box(way, cx, cy, reach), np_near_box(way, cx, cy, reach)
        work = rng.random(m) < 0.6  # robots at work near those that changed, on the grid too
        changed = np.flatnonzero(rng.random(m) < 0.2)
        x0, y0 = rng.integers(0, 7, (2, k)) / 2
        boxes = np.column_stack([x0, y0, x0 + rng.integers(1, 4, k) / 2, y0 + 0.5])
        reach = float(rng.choice([1.0, 2.0]))
        args = (z, work, changed, reach, min(reach, float(rng.choice([1.0, 1.5]))), boxes, 0.5)
        got, want = plane.workers_near(*args), np_workers_near(*args)
        yield (
            "workers_near",
            np.concatenate(got, dtype=complex),
            np.concatenate(want, dtype=complex),
        )
        site = complex(rng.integers(0, 7), rng.integers(0, 7))  # a site others come to
        state = np.where(rng.random(m) < 0.7, 1, rng.integers(0, 3, m)).astype(np.int8)
        args = (state, 1, service, z, complex(service[0]) if m % 3 else site, reach)
        (got, anyone), (want, want_any) = plane.coming_to(*args), np_coming_to(*args)
        yield "coming_to", np.append(got, anyone), np.append(want, want_any)
        j = int(rng.integers(m))  # a robot leaving: its exits' clearances from the others
        away = np.exp(1j * rng.choice([0.0, 0.5 * np.pi, rng.uniform(0, 2 * np.pi)]))
        ends = z[j] + 1.5 * away * np.exp(1j * np.radians(np.arange(-150, 151, 30)))
        ends[0] = z[j] + 1.5 * rng.choice([1, -1, 1j, -1j])  # towards a grid point
        args = (complex(z[j]), ends, z, j, reach, work, changed_mask(m, changed))
        got, want = plane.exit_clearances(*args), np_exit_clearances(*args)
        yield "exit_clearances", np.concatenate(got), np.concatenate(want)
        sites = np.unique(service[rng.random(m) < 0.5])  # idle robots near sites come to
        args = (z, np.flatnonzero(rng.random(m) < 0.6), sites, reach)
        got, want = plane.near_sites(*args, False), np_near_sites(*args)
        yield "near_sites", np.concatenate(got), np.concatenate(want)
        first = [part[:1] for part in want]  # the first pair, if any
        yield (
            "near_sites_first",
            np.concatenate(plane.near_sites(*args, True)),
            np.concatenate(first),
        )
        masks = rng.random((6, m)) < [[0.7], [0.1], [0.1], [0.1], [0.3], [0.2]]
        backoff = np.where(masks[0], -np.inf, rng.choice([1.0, 2.0], m))
        args = (state, 1, backoff, *masks[1:4], z, service, *masks[4:], 1.0, reach, 0.5)
        got, want = plane.queue_scan(*args), np_queue_scan(*args)  # a queue's look (t = 1)
        yield "queue_scan", np.concatenate(got, axis=None), np.concatenate(want, axis=None)


def changed_mask(m: int, rows: np.ndarray) -> np.ndarray:
    """(m,) True at ``rows``."""
    out = np.zeros(m, dtype=bool)
    out[rows] = True
    return out


def place_cases(rng: np.random.Generator, grid: bool):
    """(name, compiled, numpy) for robots round a site with six slots: some places kept,
    robots standing on or near others, every place taken now and then."""
    site = complex(*(rng.integers(2, 8, 2) if grid else rng.uniform(2, 8, 2)))
    ring = site + 0.8 * np.exp(2j * np.pi * np.arange(6) / 6)
    places = np.concatenate([[site], ring[rng.random(6) < 0.8]])
    m = int(rng.integers(1, 40))
    spread = rng.choice(places, m) + rng.normal(0, 0.4, m) + 1j * rng.normal(0, 0.4, m)
    z = np.round(spread * 2) / 2 if grid else spread
    kept = np.where(rng.random(m) < 0.5, rng.choice(places, m), z)
    keeping, standing = rng.random(m) < 0.3, rng.random(m) < 0.4
    here = complex(np.round(z[0] * 2) / 2) if grid else complex(z[0])
    args = (places, site, kept, keeping, z, standing, 1.6, 0.6, here)
    return plane.free_place(*args), np_free_place(*args)


def _flat(answer) -> np.ndarray:
    """An answer (a tuple of numbers or an array) as one complex array."""
    if isinstance(answer, tuple):
        return np.array(answer, dtype=complex)
    return np.asarray(answer, dtype=complex).reshape(-1)


def exact_mismatches(seed: int) -> dict[str, list[int]]:
    """{function: [cases checked, cases not equal bit for bit]}."""
    out: dict[str, list[int]] = {}
    for name, got, want in all_cases(seed):
        tally = out.setdefault(name, [0, 0])
        tally[0] += 1
        g, w = _flat(got), _flat(want)
        same = g.shape == w.shape and bool((g.view(np.uint64) == w.view(np.uint64)).all())
        tally[1] += not same
    return out


# -- tests ---------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_geometry_agrees_with_numpy_within_rounding(seed):
    """With this CPU's numpy kernels (fused or not): every answer within 1e-12 m, the same
    touch (0) or miss (inf) where numpy has one; two polygons' nearest points may be another
    pair of a tie (parallel edges), as far apart as the gap. Ways on a grid, where a robot at
    work is often equally near two segments, and reaches equal to a way's gap are held to
    numpy's answers in the child only."""
    counts: dict[str, int] = {}
    for name, got, want in all_cases(seed):
        counts[name] = counts.get(name, 0) + 1
        if name.endswith(("_grid", "_tie")):
            continue  # equal gaps (to two segments, or to the reach): rounding may differ here
        if name == "polygon_gap" and want[0] > 0:  # parallel edges tie: any nearest pair
            gap, p, q = got
            assert gap == pytest.approx(want[0], abs=1e-12)
            assert abs(q - p) == pytest.approx(gap, abs=1e-12)
            got, want = got[0], want[0]
        g, w = _flat(got), _flat(want)
        assert g.shape == w.shape, name
        finite = np.isfinite(w)
        assert (np.isfinite(g) == finite).all(), (name, got, want)
        assert (g[~finite] == w[~finite]).all(), (name, got, want)
        np.testing.assert_allclose(g[finite], w[finite], rtol=0, atol=1e-12, err_msg=name)
    assert counts == {
        "polygon_gap": 3600,
        "clip_line": 12000,
        "path_gaps": 200,
        "ways_near": 200,
        "ways_near_tie": 200,
        "way_waits": 200,
        "way_waits_grid": 200,
        "free_place": 200,
        "free_place_grid": 200,
        "workers_by_way": 200,
        "near_box": 200,
        "workers_near": 200,
        "coming_to": 200,
        "exit_clearances": 200,
        "near_sites": 200,
        "near_sites_first": 200,
        "queue_scan": 200,
    }


def test_cases_hold_touches_overlaps_misses_and_parallel_lines():
    """The random cases reach the branches that decide by a tie: polygons that overlap (gap
    0) and that stand apart, lines that miss, lines parallel to an edge (the rate-0 branch)."""
    gaps = [want[0] for name, _, want in all_cases(0) if name == "polygon_gap"]
    clips = [want for name, _, want in all_cases(0) if name == "clip_line"]
    assert 0.1 < np.mean(np.array(gaps) == 0.0) < 0.5
    assert 0.2 < np.mean([lo > hi for lo, hi in clips]) < 0.95
    rng = np.random.default_rng(0)
    polys = polygons(rng, 60)
    parallel = 0
    for _, direction in lines(rng, polys, 600):
        for poly in polys[:20]:
            edge = _next(poly) - poly
            parallel += bool((np.abs((edge.conj() * direction).imag) < 1e-15).any())
    assert parallel > 1000


def test_compiled_geometry_is_numpys_bit_for_bit_with_baseline_kernels():
    """In a child Python with numpy's baseline kernels (what the golden runs use), every
    answer is numpy's to the last bit."""
    call = "{s: ns['exact_mismatches'](s) for s in (0, 1)}"
    tallies = in_baseline_child(__file__, call)
    for seed, by_name in tallies.items():
        for name, (checked, differ) in by_name.items():
            assert checked > 0 and differ == 0, (seed, name, checked, differ)


def test_polygon_gap_and_clip_line_on_squares():
    a = np.array([0, 1, 1 + 1j, 1j])
    b = a + 3 + 0.5j
    # a's corner 1 + i is 2 m from b's edge, as b's corner 3 + 0.5i is from a's: a's first
    assert polygon_gap(a, b) == np_polygon_gap(a, b) == (2.0, 1 + 1j, 3 + 1j)
    assert polygon_gap(a, a + 0.5 + 0.5j)[0] == 0.0  # overlapping
    assert polygon_gap(a, a + 1)[0] == 0.0  # sharing an edge: touching
    assert clip_line(0.5j, 1, a) == pytest.approx((0.0, 1.0), abs=2e-9)  # boundary: TOL_M
    lo, hi = clip_line(2j, 1, a)
    assert lo > hi  # parallel to the top edge, above it: missed


def test_path_gaps_and_ways_near_measure_from_the_way_ahead_only():
    path = np.array([0, 4, 4 + 4j])
    assert path_gaps(np.array([2 + 1j, 5 + 2j, 2 + 1j]), path).tolist() == [1.0, 1.0, 1.0]
    assert path_gaps(np.array([1j]), path[:1]).tolist() == [np.inf]
    pts = np.array([[0, 4, 4 + 4j], [0, 4, 4 + 4j]])
    z, idx = np.array([4 + 1j, 0j]), np.array([2, 1])  # robot 0 is past the first segment
    point = np.array([2 - 1j])  # 1 m beside the first segment, 8 ** 0.5 m from robot 0
    rows = np.array([0, 1])
    assert plane.ways_near(point, 1.0, rows, z, pts, idx).tolist() == [False, False]
    assert plane.ways_near(point, 1.0 + 1e-9, rows, z, pts, idx).tolist() == [False, True]
    assert plane.ways_near(point, 2.83, rows, z, pts, idx).tolist() == [True, True]
    assert plane.ways_near(point, 2.83, rows[1:], z, pts, idx).tolist() == [True]
    assert plane.ways_near(point[:0], 9.0, rows, z, pts, idx).tolist() == [False, False]


if __name__ == "__main__":  # pragma: no cover - the child of the bit-for-bit test
    print(exact_mismatches(0))
