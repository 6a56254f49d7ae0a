"""The event rules' plane geometry on small arrays, compiled: the gap between two convex
polygons, a line clipped to one, the distance from points to a path and whether a way passes
near them, the robots at work near others and the obstacles near each, the room in the aisle
beside a robot at work, how long a robot would wait for robots at work on its way, a robot's
free place at its site, the site queues' look at the fleet, and a robot's ways out of a site
and the robots coming to it.

The traffic rules (``sim.spatial.traffic``), look-ahead (``sim.spatial.jams``) and the site
queues (``sim.spatial.sites``) ask these questions many times per event, on arrays of a few
to a few thousand points, where numpy's cost is its calls and temporaries, not its
arithmetic. The arithmetic here is numpy's baseline x86-64 kernels'
(``NPY_ENABLE_CPU_FEATURES=X86_V2``, the golden runs'), term by term and in the same order: a
complex product is ``(ar br - ai bi, ar bi + ai br)``, a complex modulus is
``l * sqrt(1 + (s / l)^2)`` of the larger and smaller part, and nothing is fused (numba fuses
a multiply and an add only with ``fastmath``). So the answers are numpy's bit for bit there
(tests/sim/spatial/test_plane.py); with numpy's AVX2 kernels, which fuse, numpy's own last
bits differ from these. :func:`worker_room` replaces Python code on complex scalars and copies
Python's arithmetic instead (its modulus is the C library's ``hypot``;
tests/sim/spatial/traffic/test_passages.py).

numba caches the compiled functions beside this module (``__pycache__``); a cold cache costs
a few seconds, once.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from sim.spatial.navigation.baseline import clip01, modulus

TOL_M = 1e-9  # a line touching a polygon's boundary meets it (``geometry.TOL_M``)


@numba.njit(cache=True, nogil=True, inline="always")
def _to_segment(p: complex, a: complex, b: complex) -> tuple[float, complex]:
    """Distance from p to segment a -> b and its nearest point (``geometry.to_segments``)."""
    dr, di = b.real - a.real, b.imag - a.imag
    dd = max(dr * dr - di * -di, 1e-24)  # (d conj(d)).real
    ur, ui = p.real - a.real, p.imag - a.imag
    t = clip01((ur * dr - ui * -di) / dd)  # ((p - a) conj(d)).real / dd
    near = complex(a.real + (t * dr - 0.0 * di), a.imag + (t * di + 0.0 * dr))  # a + t d
    return modulus(p.real - near.real, p.imag - near.imag), near


@numba.njit(cache=True, nogil=True, inline="always")
def _strictly_inside(x: complex, poly: np.ndarray) -> bool:
    """x lies strictly inside the convex CCW polygon (the cross products all above TOL_M)."""
    n = len(poly)
    for e in range(n):
        e0, e1 = poly[e], poly[(e + 1) % n]
        er, ei = e1.real - e0.real, e1.imag - e0.imag
        ur, ui = x.real - e0.real, x.imag - e0.imag
        if not er * ui + -ei * ur > TOL_M:  # (conj(e1 - e0) (x - e0)).imag
            return False
    return True


@numba.njit(cache=True, nogil=True)
def polygon_gap(pa: np.ndarray, pb: np.ndarray) -> tuple[float, complex, complex]:
    """Distance between two disjoint convex polygons ((P,) complex, CCW) and the nearest
    points (on ``pa``, on ``pb``); 0 where they touch or overlap (then the points are a vertex
    and its nearest). Ties go to the first vertex and edge in order, ``pa``'s vertices
    first, as numpy's argmin does (the numpy reference: tests/sim/spatial/test_plane.py)."""
    na, nb = len(pa), len(pb)
    best_ab, p_ab, q_ab = math.inf, 0j, 0j
    for i in range(na):
        for k in range(nb):
            d, near = _to_segment(pa[i], pb[k], pb[(k + 1) % nb])
            if d < best_ab:
                best_ab, p_ab, q_ab = d, pa[i], near
    best_ba, p_ba, q_ba = math.inf, 0j, 0j
    for m in range(nb):
        for n in range(na):
            d, near = _to_segment(pb[m], pa[n], pa[(n + 1) % na])
            if d < best_ba:
                best_ba, p_ba, q_ba = d, near, pb[m]
    if best_ab <= best_ba:
        gap, p, q = best_ab, p_ab, q_ab
    else:
        gap, p, q = best_ba, p_ba, q_ba
    for i in range(na):
        if _strictly_inside(pa[i], pb):
            return 0.0, p, q
    for m in range(nb):
        if _strictly_inside(pb[m], pa):
            return 0.0, p, q
    return gap, p, q


@numba.njit(cache=True, nogil=True)
def clip_line(origin: complex, direction: complex, poly: np.ndarray) -> tuple[float, float]:
    """The interval of t where ``origin + t direction`` lies in the convex CCW polygon
    (boundary included); (inf, -inf) if the line misses it."""
    lo, hi = -math.inf, math.inf
    n = len(poly)
    for e in range(n):
        e0, e1 = poly[e], poly[(e + 1) % n]
        er, ei = e1.real - e0.real, e1.imag - e0.imag
        ur, ui = origin.real - e0.real, origin.imag - e0.imag
        b = er * ui + -ei * ur  # cross(edge, origin - e0): inside where >= 0
        r = er * direction.imag + -ei * direction.real  # its change per unit t
        if abs(r) < 1e-15:
            if b < -TOL_M:
                return math.inf, -math.inf
            continue
        t = -b / r - TOL_M / r
        if r > 0:
            if t > lo:
                lo = t
        elif t < hi:
            hi = t
    if lo <= hi:
        return lo, hi
    return math.inf, -math.inf


@numba.njit(cache=True, nogil=True)
def worker_room(
    z: complex,
    radius_m: float,
    corner: np.ndarray,
    flat: np.ndarray,
    at: np.ndarray,
    others: np.ndarray,
    passage_m: float,
) -> tuple[bool, complex, float, float]:
    """``passages.worker_passage``'s geometry for a robot at work at ``z`` (its body
    ``z + corner``): the shapes are the polygons ``flat[at[s]:at[s + 1]]`` and a polygon
    ``o + corner`` round each of ``others``. Returns (True, across, near, far): the line
    across (a unit vector from the body toward the nearest shape) and the free room beyond the
    body toward that shape and away from it; (False, ...) (no passage) if the nearest shape is
    ``passage_m`` or more away or a side leaves that much. The arithmetic on complex scalars
    is Python's (a complex times or over a float as a complex with no imaginary part; ``abs``
    the C library's ``hypot``), as in the Python function, so the answers are its bit for
    bit."""
    nc, ns = len(corner), len(at) - 1
    n = ns + len(others)
    body = np.empty(nc, dtype=np.complex128)
    for c in range(nc):
        body[c] = z + corner[c]
    disc = np.empty(nc, dtype=np.complex128)
    best, p, q = math.inf, 0j, 0j
    for s in range(n):  # the nearest shape: the first of the least gap (np.argmin)
        if s < ns:
            d, ps, qs = polygon_gap(body, flat[at[s] : at[s + 1]])
        else:
            for c in range(nc):
                disc[c] = others[s - ns] + corner[c]
            d, ps, qs = polygon_gap(body, disc)
        if s == 0 or d < best:
            best, p, q = d, ps, qs
    if not best < passage_m:
        return False, 0j, 0.0, 0.0
    dr, di = q.real - p.real, q.imag - p.imag
    size = math.hypot(dr, di)
    if size > 1e-12:  # Python's complex / float: (dr + di 0) / size, (di - dr 0) / size
        ar, ai = (dr + di * 0.0) / size, (di - dr * 0.0) / size
    else:
        ar, ai = 1.0, 0.0
    room = np.empty(2)
    for side in range(2):  # -1, then +1: away from the nearest first
        sign = -1.0 if side == 0 else 1.0
        way = complex(sign * ar - 0.0 * ai, sign * ai + 0.0 * ar)  # sign * across
        least, any_ahead = math.inf, False
        for s in range(n):
            if s < ns:
                t0, t1 = clip_line(z, way, flat[at[s] : at[s + 1]])
            else:
                for c in range(nc):
                    disc[c] = others[s - ns] + corner[c]
                t0, t1 = clip_line(z, way, disc)
            if t0 <= t1 and t1 > 0.0:
                t = t0 if not 0.0 > t0 else 0.0  # max(t0, 0.0)
                if not any_ahead or t < least:  # min(...)
                    least, any_ahead = t, True
        room[side] = least - radius_m
        if room[side] >= passage_m:
            return False, 0j, 0.0, 0.0
    return True, complex(ar, ai), room[1], room[0]


@numba.njit(cache=True, nogil=True)
def path_gaps(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """(n,) distance from each of ``points`` to the polyline ``path`` (its segments path[k]
    -> path[k + 1]; inf for a path of fewer than two points), m."""
    out = np.full(len(points), math.inf)
    for i in range(len(points)):
        for k in range(len(path) - 1):
            d, _ = _to_segment(points[i], path[k], path[k + 1])
            if d < out[i]:
                out[i] = d
    return out


@numba.njit(cache=True, nogil=True, inline="always")
def _box(way: np.ndarray) -> tuple[float, float, float, float]:
    """The box of the points ``way`` (at least one, x + iy): least x, most x, least y, most y."""
    x0, x1, y0, y1 = way[0].real, way[0].real, way[0].imag, way[0].imag
    for k in range(1, len(way)):
        x0, x1 = min(x0, way[k].real), max(x1, way[k].real)
        y0, y1 = min(y0, way[k].imag), max(y1, way[k].imag)
    return x0, x1, y0, y1


@numba.njit(cache=True, nogil=True)
def near_box(way: np.ndarray, cx: np.ndarray, cy: np.ndarray, reach: np.ndarray) -> np.ndarray:
    """Indices, in order, of the points (cx, cy) that lie within their ``reach`` of the box of
    the points ``way`` (x + iy): lo - reach <= c <= hi + reach in x and in y (none for no
    points)."""
    if not len(way):
        return np.empty(0, dtype=np.int64)
    x0, x1, y0, y1 = _box(way)
    out = np.empty(len(cx), dtype=np.int64)
    n = 0
    for i in range(len(cx)):
        x, y, d = cx[i], cy[i], reach[i]
        if x0 - d <= x and x <= x1 + d and y0 - d <= y and y <= y1 + d:
            out[n] = i
            n += 1
    return out[:n]


@numba.njit(cache=True, nogil=True)
def workers_by_way(
    rows: np.ndarray, z: np.ndarray, way: np.ndarray, grow_m: float, service: np.ndarray, j: int
) -> tuple[np.ndarray, np.ndarray]:
    """Of the robots ``rows`` (at ``z[rows]``, in order), those strictly inside the box of the
    points ``way`` grown by ``grow_m``, and whether each has robot j's service point (within
    1e-6 m of ``service[j]``); none for no points."""
    if not len(way):
        return np.empty(0, dtype=np.int64), np.empty(0, dtype=np.bool_)
    x0, x1, y0, y1 = _box(way)
    x0, x1, y0, y1 = x0 - grow_m, x1 + grow_m, y0 - grow_m, y1 + grow_m
    out = np.empty(len(rows), dtype=np.int64)
    same = np.empty(len(rows), dtype=np.bool_)
    n = 0
    for r in rows:
        x, y = z[r].real, z[r].imag
        if x > x0 and x < x1 and y > y0 and y < y1:
            out[n] = r
            d = service[r] - service[j]
            same[n] = not modulus(d.real, d.imag) > 1e-6
            n += 1
    return out[:n], same[:n]


@numba.njit(cache=True, nogil=True)
def workers_near(
    z: np.ndarray,
    work: np.ndarray,
    changed: np.ndarray,
    reach_m: float,
    close_m: float,
    boxes: np.ndarray,
    grow_m: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The robots at work (``work``, at ``z``) within ``reach_m`` of one of the robots
    ``changed``, in order; for each, the other robots at work within ``close_m`` of it
    (farther than 1e-9 m, in order) and the shapes whose box (``boxes``: x0, y0, x1, y1) lies
    within ``grow_m`` of it in x and in y (``PassageMap.update_workers``' neighbours).

    Returns (rows, others_at, others, shapes_at, shapes): row n's others are
    ``others[others_at[n]:others_at[n + 1]]`` (x + iy), its shapes likewise."""
    m = len(z)
    at = np.nonzero(work)[0]
    rows = np.empty(m, dtype=np.int64)
    n = 0
    for i in at:
        for c in changed:
            d = z[i] - z[c]
            if modulus(d.real, d.imag) < reach_m:
                rows[n] = i
                n += 1
                break
    rows = rows[:n]
    others_at = np.zeros(n + 1, dtype=np.int64)
    shapes_at = np.zeros(n + 1, dtype=np.int64)
    for count in range(2):  # count, then fill
        others = np.empty(others_at[n], dtype=np.complex128)
        shapes = np.empty(shapes_at[n], dtype=np.int64)
        k = s = 0
        for r in range(n):
            zw = z[rows[r]]
            for a in at:
                d = zw - z[a]
                gap = modulus(d.real, d.imag)
                if gap < close_m and gap > 1e-9:
                    if count:
                        others[k] = z[a]
                    k += 1
            x, y = zw.real, zw.imag
            for b in range(boxes.shape[0]):
                if (
                    boxes[b, 0] <= x + grow_m
                    and boxes[b, 2] >= x - grow_m
                    and boxes[b, 1] <= y + grow_m
                    and boxes[b, 3] >= y - grow_m
                ):
                    if count:
                        shapes[s] = b
                    s += 1
            others_at[r + 1], shapes_at[r + 1] = k, s
    return rows, others_at, others, shapes_at, shapes


@numba.njit(cache=True, nogil=True)
def queue_scan(
    state: np.ndarray,
    driving_code: int,
    backoff_until_s: np.ndarray,
    replan: np.ndarray,
    blocked: np.ndarray,
    held: np.ndarray,
    z: np.ndarray,
    service: np.ndarray,
    admitted: np.ndarray,
    holding: np.ndarray,
    t: float,
    queue_m: float,
    crowd_m: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool, float]:
    """``Sites.queue``'s look at the fleet, as the masks are when it is called. The robots
    driving (state ``driving_code``, not backing off at ``t``, not replanning, waiting for a
    repair (``blocked``) or ``held`` before a passage) and each robot's gap to its service
    point, m; of the driving robots not let in (``admitted``), those within ``queue_m`` of
    it or within ``crowd_m`` of a robot ``holding`` for the same service point (1e-6 m),
    which ask now; the driving robots let in and near or holding, whose sites idle robots
    clear; whether a driving robot is within ``queue_m``, and the least gap of the others
    (inf without one)."""
    m = len(z)
    driving = np.zeros(m, dtype=np.bool_)
    near = np.zeros(m, dtype=np.bool_)
    coming = np.zeros(m, dtype=np.bool_)
    gap = np.empty(m)
    close_any, far = False, math.inf
    for i in range(m):
        d = z[i] - service[i]
        gap[i] = modulus(d.real, d.imag)
        if state[i] != driving_code or not backoff_until_s[i] <= t:
            continue
        if replan[i] or blocked[i] or held[i]:
            continue
        driving[i] = True
        close = gap[i] < queue_m
        if close:
            close_any = True
        elif gap[i] >= queue_m and gap[i] < far:
            far = gap[i]
        near[i] = close and not admitted[i]
        coming[i] = (admitted[i] and close) or holding[i]
    held = np.nonzero(holding)[0]  # a robot not let in, in the crowd of one holding: it asks
    for i in range(m):
        if not len(held) or not driving[i] or admitted[i] or near[i]:
            continue
        for h in held:
            d = service[i] - service[h]
            if modulus(d.real, d.imag) < 1e-6:
                d = z[i] - z[h]
                if modulus(d.real, d.imag) < crowd_m:
                    near[i] = True
                    break
    return driving, gap, near, coming, close_any, far


@numba.njit(cache=True, nogil=True)
def coming_to(
    state: np.ndarray,
    driving: int,
    service: np.ndarray,
    z: np.ndarray,
    site: complex,
    within_m: float,
) -> tuple[np.ndarray, bool]:
    """(m,) the robots in state ``driving`` whose service point is ``site`` (within 1e-6 m)
    and that are within ``within_m`` of it, and whether there is one (``Sites.leave``)."""
    out = np.zeros(len(z), dtype=np.bool_)
    anyone = False
    for i in range(len(z)):
        if state[i] != driving:
            continue
        d = service[i] - site
        if not modulus(d.real, d.imag) < 1e-6:
            continue
        d = z[i] - site
        if modulus(d.real, d.imag) < within_m:
            out[i] = anyone = True
    return out, anyone


@numba.njit(cache=True, nogil=True)
def exit_clearances(
    z: complex,
    ends: np.ndarray,
    zs: np.ndarray,
    j: int,
    within_m: float,
    coming: np.ndarray,
    admitted: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """How close the robots within ``within_m`` of ``z`` (at ``zs``, robot j not counted) come
    to each segment from ``z`` to one of ``ends``, and how close those of them ``coming`` and
    ``admitted`` come, m (inf without any): ``Sites.clearance`` of each group."""
    clear = np.full(len(ends), math.inf)
    clear_in = np.full(len(ends), math.inf)
    seg2 = np.empty(len(ends))  # each way out's squared length, as numpy's |seg| ** 2
    for k in range(len(ends)):
        seg_m = modulus(ends[k].real - z.real, ends[k].imag - z.imag)
        seg2[k] = seg_m * seg_m
    for i in range(len(zs)):
        d = zs[i] - z
        if i == j or not modulus(d.real, d.imag) < within_m:
            continue
        both = coming[i] and admitted[i]
        ar, ai = zs[i].real - z.real, zs[i].imag - z.imag
        for k in range(len(ends)):
            sr, si = ends[k].real - z.real, ends[k].imag - z.imag
            frac = clip01((ar * sr - ai * -si) / seg2[k])
            near_r = z.real + (frac * sr - 0.0 * si)
            near_i = z.imag + (frac * si + 0.0 * sr)
            gap = modulus(zs[i].real - near_r, zs[i].imag - near_i)
            if gap < clear[k]:
                clear[k] = gap
            if both and gap < clear_in[k]:
                clear_in[k] = gap
    return clear, clear_in


@numba.njit(cache=True, nogil=True)
def near_sites(
    z: np.ndarray, rows: np.ndarray, sites: np.ndarray, reach_m: float, first: bool
) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (n, k) of a robot ``rows[n]`` (at ``z``) within ``reach_m`` of ``sites[k]``,
    by n and then k (``Sites.clear_loiterers``); with ``first``, only the first of them."""
    count = 0
    for step in range(2):  # count, then fill
        robot = np.empty(count, dtype=np.int64)
        site = np.empty(count, dtype=np.int64)
        count = 0
        for n in range(len(rows)):
            zr = z[rows[n]]
            for k in range(len(sites)):
                d = zr - sites[k]
                if modulus(d.real, d.imag) < reach_m:
                    if step:
                        robot[count], site[count] = n, k
                    elif first:
                        return np.full(1, n), np.full(1, k)
                    count += 1
    return robot, site


@numba.njit(cache=True, nogil=True)
def ways_near(
    points: np.ndarray,
    reach_m: float,
    rows: np.ndarray,
    z: np.ndarray,
    paths: np.ndarray,
    index: np.ndarray,
) -> np.ndarray:
    """(len(rows),) whether one of ``points`` lies nearer than ``reach_m`` to the way ahead of
    each robot ``rows``: from where it is (``z[r]``) to the waypoint it aims at
    (``paths[r, index[r]]``), then along its path's segments to the end of the row of the
    (m, P) array ``paths``. Each row stops at the first such point and segment; a segment
    whose box lies farther than the reach from a point is not measured."""
    width = paths.shape[1]
    out = np.zeros(len(rows), dtype=np.bool_)
    far = reach_m + 1e-9  # a segment whose box is this far from a point in x or y is too far
    for n in range(len(rows)):
        r = rows[n]
        for i in range(len(points)):
            p = points[i]
            for k in range(index[r] - 1, width - 1):
                a = z[r] if k < index[r] else paths[r, k]
                b = paths[r, k + 1]
                if (
                    p.real < min(a.real, b.real) - far
                    or p.real > max(a.real, b.real) + far
                    or p.imag < min(a.imag, b.imag) - far
                    or p.imag > max(a.imag, b.imag) + far
                ):
                    continue
                d, _ = _to_segment(p, a, b)
                if d < reach_m:
                    out[n] = True
                    break
            if out[n]:
                break
    return out


@numba.njit(cache=True, nogil=True)
def way_waits(
    pts: np.ndarray,
    idx: np.ndarray,
    last: np.ndarray,
    after: np.ndarray,
    z: np.ndarray,
    service: np.ndarray,
    work_z: np.ndarray,
    work_service: np.ndarray,
    work_end_s: np.ndarray,
    t: float,
    v_max: float,
    block_m: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For robots on the (n, P) paths ``pts`` (aiming at waypoint ``idx``, the last one
    ``last``, path left after each waypoint ``after``, at ``z``, for sites ``service``) and
    robots at work at ``work_z`` (for sites ``work_service``, done at ``work_end_s``), each
    (n, w): how long each would wait for each (work left after getting there along its way
    at ``v_max``; 0 where the way passes no nearer than ``block_m``, the robot at work is not
    more than ``block_m`` ahead along it, or works at the robot's own site), the way's length
    to the point nearest it, and how near the way passes it (inf: it works at the robot's
    own site), m (``sim.spatial.jams.Jams.waits``)."""
    n, width = pts.shape
    w = len(work_z)
    wait = np.zeros((n, w))
    along = np.zeros((n, w))
    gap_out = np.zeros((n, w))
    start = np.empty(width, dtype=np.complex128)
    seg = np.empty(width, dtype=np.complex128)
    seg2 = np.empty(width)
    seg_m = np.empty(width)
    for r in range(n):
        for c in range(width):  # the segment into each waypoint; the first from the robot
            if c == idx[r]:
                start[c] = z[r]
            else:
                start[c] = pts[r, c - 1] if c > 0 else pts[r, width - 1]
            sr, si = pts[r, c].real - start[c].real, pts[r, c].imag - start[c].imag
            seg[c] = complex(sr, si)
            seg2[c] = sr * sr - si * -si
            seg_m[c] = math.sqrt(seg2[c])
        aim = pts[r, idx[r]]
        total = modulus(aim.real - z[r].real, aim.imag - z[r].imag) + after[r, idx[r]]
        for k in range(w):
            best, near, best_frac = math.inf, 0, 0.0
            for c in range(width):
                sr, si = seg[c].real, seg[c].imag
                rr = work_z[k].real - start[c].real
                ri = work_z[k].imag - start[c].imag
                frac = clip01((rr * sr - ri * -si) / max(seg2[c], 1e-18))
                if c == 0:
                    best_frac = frac  # numpy's argmin of all inf: the first
                if not (idx[r] <= c <= last[r]):
                    continue  # not on the way ahead: inf, never the least
                gap = modulus(rr - (frac * sr - 0.0 * si), ri - (frac * si + 0.0 * sr))
                if gap < best:
                    best, near, best_frac = gap, c, frac
            rest = after[r, near] + (1.0 - best_frac) * seg_m[near]
            way = total - rest
            other = (
                modulus(
                    service[r].real - work_service[k].real, service[r].imag - work_service[k].imag
                )
                > 1e-6
            )
            left = work_end_s[k] - t - way / v_max
            along[r, k] = way
            if best < block_m and way > block_m and other:
                wait[r, k] = left if left >= 0.0 else 0.0  # np.maximum(left, 0.0)
            gap_out[r, k] = best if other else math.inf
    return wait, along, gap_out


@numba.njit(cache=True, nogil=True)
def free_place(
    places: np.ndarray,
    site: complex,
    kept: np.ndarray,
    keeping: np.ndarray,
    z: np.ndarray,
    standing: np.ndarray,
    lim: float,
    room: float,
    here: complex,
) -> int:
    """The index in ``places`` (a site's places, its service point first) of the one a robot
    at ``here`` would be given, or -1 if every one is taken: a place is taken when a kept
    place (``kept[k]`` where ``keeping[k]``) or a standing robot (``z[k]`` where
    ``standing[k]``), either within ``lim`` of ``site`` in x and in y, lies closer than
    ``room`` to it; the service point if free, else the free place nearest ``here`` (the
    first of equals) (``sim.spatial.sites.Sites.free_place``)."""
    n = len(places)
    taken = np.zeros(n, dtype=np.bool_)
    for which in range(2):
        points, mask = (kept, keeping) if which == 0 else (z, standing)
        for k in range(len(points)):
            if not mask[k]:
                continue
            p = points[k]
            if not (abs(p.real - site.real) <= lim and abs(p.imag - site.imag) <= lim):
                continue
            for c in range(n):
                if modulus(p.real - places[c].real, p.imag - places[c].imag) < room:
                    taken[c] = True
    if not taken[0]:
        return 0
    best, pick = math.inf, -1
    for c in range(n):
        if not taken[c]:
            d = modulus(places[c].real - here.real, places[c].imag - here.imag)
            if d < best:
                best, pick = d, c
    return pick
