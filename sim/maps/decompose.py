"""Exact convex decomposition of a polygon with holes (integer coordinates).

Three classic steps, each exact because every coordinate is an integer (half cells):

1. *Bridging* (Eberly, "Triangulation by ear clipping"): each hole, rightmost first, is joined to
   the outline by a two-way cut from its rightmost corner to a corner of the outline that sees
   it, which makes one weakly simple polygon. The corner is found by testing the outline's
   corners nearest first against every edge, so the cut never crosses or touches the boundary.
2. *Ear clipping* of that polygon into triangles.
3. *Hertel-Mehlhorn*: triangles are merged across their shared edges (the cuts of step 1
   included: they are not walls), longest edge first, whenever the union stays convex. The
   pieces are at most four times as many as the fewest convex pieces possible, with no new
   corners (no Steiner points), and they tile the polygon exactly.
"""

from __future__ import annotations

import numpy as np

from sim.maps.lattice import area2, cross, segments_touch, turns


def convex_pieces(outline: np.ndarray, holes: list[np.ndarray]) -> list[np.ndarray]:
    """Convex counter-clockwise pieces (each (k, 2) int64, no collinear corners) that tile the
    region inside ``outline`` (counter-clockwise) and outside every hole (clockwise)."""
    poly = bridge_holes(outline, holes)
    return merge_convex(poly, ear_clip(poly))


def bridge_holes(outline: np.ndarray, holes: list[np.ndarray]) -> np.ndarray:
    """One weakly simple counter-clockwise polygon: the outline with every hole cut into it."""
    poly = np.asarray(outline, dtype=np.int64)
    todo = sorted((np.asarray(h, dtype=np.int64) for h in holes), key=lambda h: -int(h[:, 0].max()))
    for k, hole in enumerate(todo):
        m = int(np.lexsort((hole[:, 1], hole[:, 0]))[-1])  # rightmost corner (then topmost)
        a, b = _edges([poly, *todo[k:]])
        mx = hole[m]
        h_prev, h_next = hole[m - 1], hole[(m + 1) % len(hole)]
        order = np.argsort(((poly - mx) ** 2).sum(axis=1), kind="stable")
        for c in order.tolist():
            pc = poly[c]
            p_prev, p_next = poly[c - 1], poly[(c + 1) % len(poly)]
            if (
                _in_sector(pc, p_prev, p_next, mx - pc)
                and _in_sector(mx, h_prev, h_next, pc - mx)
                and _clear(mx, pc, a, b)
            ):
                ring = np.roll(hole, -m, axis=0)
                poly = np.vstack([poly[: c + 1], ring, ring[:1], poly[c:]])
                break
        else:
            raise ValueError("no corner of the outline sees a hole: the loops cross")
    return poly


def _edges(loops: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Start and end points (E, 2) of every edge of the closed loops."""
    return np.vstack(loops), np.vstack([np.roll(p, -1, axis=0) for p in loops])


def _in_sector(p: np.ndarray, prev: np.ndarray, nxt: np.ndarray, d: np.ndarray) -> bool:
    """True if direction ``d`` from corner ``p`` points strictly into the polygon, whose inside
    is on the left of prev -> p -> nxt."""
    u, w = nxt - p, prev - p
    turn = cross(u, w)
    if turn > 0:
        return cross(u, d) > 0 and cross(d, w) > 0
    if turn < 0:
        return not (cross(w, d) >= 0 and cross(d, u) >= 0)
    return cross(u, d) > 0  # a straight corner: the inside is the half-plane on the left


def _clear(p: np.ndarray, q: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """True if segment p-q meets the edges a-b only at its own ends, where those edges end."""
    lo, hi = np.minimum(p, q), np.maximum(p, q)
    near = ((np.minimum(a, b) <= hi) & (np.maximum(a, b) >= lo)).all(axis=1)
    a, b = a[near], b[near]
    m = len(a)
    hit = segments_touch(np.broadcast_to(p, (m, 2)), np.broadcast_to(q, (m, 2)), a, b)
    if not hit.any():
        return True
    a, b = a[hit], b[hit]
    for end, other in ((p, q), (q, p)):
        at_a, at_b = (a == end).all(axis=1), (b == end).all(axis=1)
        far = np.where(at_a[:, None], b, a)
        side = (other - end)[0] * (far - end)[:, 1] - (other - end)[1] * (far - end)[:, 0]
        along = ((far - end) * (other - end)).sum(axis=1) > 0
        ok = (at_a | at_b) & ~((side == 0) & along)
        a, b = a[~ok], b[~ok]
    return not len(a)


def ear_clip(poly: np.ndarray) -> np.ndarray:
    """Triangles (t, 3) of corner indices, counter-clockwise, tiling a weakly simple polygon."""
    n = len(poly)
    pts = np.asarray(poly, dtype=np.int64)
    prev = [(k - 1) % n for k in range(n)]
    nxt = [(k + 1) % n for k in range(n)]
    alive = np.ones(n, dtype=bool)
    tris: list[tuple[int, int, int]] = []
    left, k, stall = n, 0, 0
    while left > 3:
        p, q = prev[k], nxt[k]
        turn = cross(pts[k] - pts[p], pts[q] - pts[k])
        if (turn == 0 and _may_drop(pts, alive, p, k, q)) or (
            turn > 0 and _is_ear(pts, alive, prev, nxt, p, k, q)
        ):
            if turn:
                tris.append((p, k, q))
            nxt[p], prev[q] = q, p
            alive[k] = False
            left, k, stall = left - 1, p, 0
            continue
        k, stall = q, stall + 1
        if stall > left:
            raise ValueError("no ear to clip: the polygon is not simple")
    k = int(np.flatnonzero(alive)[0])
    if cross(pts[k] - pts[prev[k]], pts[nxt[k]] - pts[k]) != 0:
        tris.append((prev[k], k, nxt[k]))
    return np.array(tris, dtype=np.int64).reshape(-1, 3)


def _may_drop(pts: np.ndarray, alive: np.ndarray, p: int, k: int, q: int) -> bool:
    """True if a corner without a turn can go: it folds back (a spike of no area), or it runs
    straight on and no other corner stands at the same place (which its neighbours' new edge
    would then pass through)."""
    if int((pts[k] - pts[p]) @ (pts[q] - pts[k])) < 0:
        return True
    same = (pts[alive] == pts[k]).all(axis=1)
    return int(same.sum()) == 1


def _is_ear(
    pts: np.ndarray, alive: np.ndarray, prev: list[int], nxt: list[int], p: int, k: int, q: int
) -> bool:
    """True if triangle p, k, q (counter-clockwise) can be cut off: no other corner lies inside
    or on it, and no edge leaves a corner at the same place as one of its own (the two copies
    of a cut's end) into it or along its new side p-q."""
    tri = (pts[p], pts[k], pts[q])
    others = np.flatnonzero(alive)
    others = others[(others != p) & (others != k) & (others != q)]
    o = pts[others]
    twin = np.zeros(len(o), dtype=bool)
    for corner in tri:
        twin |= (o == corner).all(axis=1)
    a, b, c = tri
    rest = o[~twin]

    def side(u: np.ndarray, w: np.ndarray) -> np.ndarray:
        return (w[0] - u[0]) * (rest[:, 1] - u[1]) - (w[1] - u[1]) * (rest[:, 0] - u[0])

    if ((side(a, b) >= 0) & (side(b, c) >= 0) & (side(c, a) >= 0)).any():
        return False
    for t in others[twin].tolist():
        at = next(n for n, corner in enumerate(tri) if (pts[t] == corner).all())
        x, after, before = tri[at], tri[(at + 1) % 3], tri[(at + 2) % 3]
        for d in (pts[prev[t]] - x, pts[nxt[t]] - x):
            if cross(after - x, d) > 0 and cross(d, before - x) > 0:
                return False  # an edge into the triangle's corner
            new_side = before - x if at == 0 else after - x if at == 2 else None
            if new_side is not None and cross(new_side, d) == 0 and int(new_side @ d) > 0:
                return False  # an edge along the side the cut would add
    return True


def merge_convex(poly: np.ndarray, tris: np.ndarray) -> list[np.ndarray]:
    """Hertel-Mehlhorn: merge triangles across shared edges while the union stays convex.

    Corners are identified by position, so the two copies of a cut's ends are one corner and
    the cut is an edge like any other between two triangles.
    """
    uniq, vid = np.unique(np.asarray(poly, dtype=np.int64), axis=0, return_inverse=True)
    vid = vid.ravel()
    pieces: dict[int, list[int]] = {t: vid[tri].tolist() for t, tri in enumerate(tris)}
    owner: dict[tuple[int, int], int] = {}
    for t, ring in pieces.items():
        for e in zip(ring, ring[1:] + ring[:1], strict=True):
            owner[e] = t
    shared = [(u, v) for (u, v) in owner if u < v and (v, u) in owner]
    length = [int(((uniq[u] - uniq[v]) ** 2).sum()) for u, v in shared]
    for _, (u, v) in sorted(zip(length, shared, strict=True), key=lambda lv: -lv[0]):
        a_id, b_id = owner.get((u, v)), owner.get((v, u))
        if a_id is None or b_id is None or a_id == b_id:
            continue
        merged = _merge(uniq, pieces[a_id], pieces[b_id], u, v)
        if merged is None:
            continue
        for ring in (pieces[a_id], pieces.pop(b_id)):
            for e in zip(ring, ring[1:] + ring[:1], strict=True):
                owner.pop(e, None)
        pieces[a_id] = merged
        for e in zip(merged, merged[1:] + merged[:1], strict=True):
            owner[e] = a_id
    out = [_without_straight(uniq[ring]) for ring in pieces.values()]
    area = sum(area2(p) for p in out)
    if area != area2(np.asarray(poly, dtype=np.int64)):
        raise ValueError("the pieces do not tile the polygon")
    return out


def _merge(xy: np.ndarray, a: list[int], b: list[int], u: int, v: int) -> list[int] | None:
    """Convex pieces ``a`` (with edge u -> v) and ``b`` (with v -> u) as one, if it is convex."""
    ia, ib = a.index(v), b.index(u)
    path_a = a[ia:] + a[:ia]  # v ... u
    path_b = b[ib:] + b[:ib]  # u ... v
    if cross(xy[u] - xy[path_a[-2]], xy[path_b[1]] - xy[u]) < 0:
        return None
    if cross(xy[v] - xy[path_b[-2]], xy[path_a[1]] - xy[v]) < 0:
        return None
    return path_a + path_b[1:-1]


def _without_straight(p: np.ndarray) -> np.ndarray:
    """A convex ring without its 180-degree corners."""
    return p[turns(p) != 0]
