"""Douglas-Peucker simplification of a component's boundary loops that only adds to it.

Each loop (integer corners in half cells, blocked on its left) is simplified on its own: a chain
of corners is replaced by the segment between its ends only if every corner of it lies within
``tol`` of that segment *and on its left*, so the blocked region can grow by up to ``tol`` but
never loses a point (Douglas-Peucker splits at the farthest corner, or first at the corner
farthest on the wrong side). Then the loops of one component (its outline and its holes) are
checked together: where two segments touch or cross, or a corner folds back on itself, or a
loop's orientation flips, the offending segments get back their farthest corner (and what the
two halves need to stay outside). That repeats until the loops are simple and disjoint, which
it must: with every corner back they are the original loops.

Growing only is the safe side for a robot: a gap between obstacles never widens, so no path is
planned where the grid has no room, and a wall one cell thick stays a wall.
"""

from __future__ import annotations

import numpy as np

from sim.maps.lattice import area2, segments_touch, turns


def simplify_loops(loops: list[np.ndarray], tol: float) -> list[np.ndarray]:
    """The loops of one blocked component, simplified to ``tol`` and kept simple and disjoint.

    Args:
        loops: (k, 2) int64 closed loops in half cells (outline counter-clockwise, holes
            clockwise); they must be simple and pairwise disjoint.
        tol: the largest distance of a dropped corner from its replacing segment, half cells.

    Returns:
        The simplified loops (subsets of the corners, in order), without collinear corners.
    """
    kept = [_douglas_peucker(p, tol) for p in loops]
    signs = [np.sign(area2(p)) for p in loops]
    while bad := _conflicts(loops, kept, signs):
        total = sum(len(k) for k in kept)
        for k, corner in bad:
            seg = int(np.searchsorted(kept[k], corner))
            kept[k] = _split(loops[k], kept[k], seg, tol)
        if sum(len(k) for k in kept) == total:  # every corner back: the input was not simple
            raise ValueError("boundary loops that touch or cross cannot be simplified")
    return [_drop_collinear(p[k]) for p, k in zip(loops, kept, strict=True)]


def _douglas_peucker(pts: np.ndarray, tol: float) -> np.ndarray:
    """Sorted indices of the corners kept of a closed loop (at least 3)."""
    n = len(pts)
    if n <= 3:
        return np.arange(n)
    far = int(np.argmax(((pts - pts[0]) ** 2).sum(axis=1)))
    idx = np.array(sorted({0, far} | _refine(pts, [(0, far), (far, n)], tol)))
    while len(idx) < 3:
        idx = _split(pts, idx, int(np.argmax(np.diff(np.append(idx, idx[0] + n)))), tol)
    return idx


def _refine(pts: np.ndarray, stack: list[tuple[int, int]], tol: float) -> set[int]:
    """Corners (indices mod n) to keep so that every chain s..e of ``stack`` (s < e, which may
    pass the loop's end) is split into chains that lie within ``tol`` of their segment and on
    its left, the blocked side."""
    n = len(pts)
    added: set[int] = set()
    while stack:
        s, e = stack.pop()
        if e - s < 2:
            continue
        a, b = pts[s % n].astype(float), pts[e % n].astype(float)
        chain = pts[np.arange(s + 1, e) % n].astype(float)
        ab = b - a
        side = ab[0] * (chain[:, 1] - a[1]) - ab[1] * (chain[:, 0] - a[0])
        if (side < 0).any():  # a corner right of the segment: the blocked side would shrink
            m = s + 1 + int(np.argmin(side))
        else:
            d = _segment_distance(chain, a, b)
            m = s + 1 + int(np.argmax(d))
            if d[m - s - 1] <= tol:
                continue
        added.add(m % n)
        stack += [(s, m), (m, e)]
    return added


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of points (m, 2) to the segment a-b."""
    ab = b - a
    den = float(ab @ ab)
    t = np.zeros(len(p)) if den == 0 else np.clip((p - a) @ ab / den, 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)


def _split(pts: np.ndarray, idx: np.ndarray, seg: int, tol: float) -> np.ndarray:
    """``idx`` with the corner farthest from segment ``seg`` (idx[seg] to the next) added, and
    whatever the two new segments then need (:func:`_refine`)."""
    n = len(pts)
    s = int(idx[seg])
    e = int(idx[seg + 1]) if seg + 1 < len(idx) else int(idx[0]) + n
    if e - s < 2:
        return idx
    inner = np.arange(s + 1, e)
    d = _segment_distance(pts[inner % n].astype(float), pts[s % n], pts[e % n].astype(float))
    m = int(inner[int(np.argmax(d))])
    added = _refine(pts, [(s, m), (m, e)], tol) | {m % n}
    return np.unique(np.concatenate([idx, sorted(added)])).astype(np.int64)


def _conflicts(
    loops: list[np.ndarray], kept: list[np.ndarray], signs: list[float]
) -> list[tuple[int, int]]:
    """Segments to refine, as (loop, index of the segment's first corner in the loop): those
    that touch a non-adjacent one, the two of a corner that folds back, and the longest one of
    a loop whose orientation flipped."""
    a, b, owner, seg, nseg = [], [], [], [], []
    bad: set[tuple[int, int]] = set()
    for k, (pts, idx) in enumerate(zip(loops, kept, strict=True)):
        p = pts[idx]
        q = np.roll(p, -1, axis=0)
        a.append(p)
        b.append(q)
        owner.append(np.full(len(p), k))
        seg.append(np.arange(len(p)))
        nseg.append(np.full(len(p), len(p)))
        if np.sign(area2(p)) != signs[k]:
            bad.add((k, int(idx[np.argmax(np.diff(np.append(idx, idx[0] + len(pts))))])))
        back = (p - np.roll(p, 1, axis=0)) * (q - p)  # a straight corner that turns back
        for corner in np.flatnonzero((turns(p) == 0) & (back.sum(axis=1) < 0)).tolist():
            bad.update({(k, int(idx[corner])), (k, int(idx[corner - 1]))})
    a, b = np.concatenate(a), np.concatenate(b)
    owner, seg, nseg = np.concatenate(owner), np.concatenate(seg), np.concatenate(nseg)
    i, j = candidate_pairs(a, b)
    same = owner[i] == owner[j]
    step = np.abs(seg[i] - seg[j])
    adjacent = same & ((step == 1) | (step == nseg[i] - 1))
    i, j = i[~adjacent], j[~adjacent]
    hit = segments_touch(a[i], b[i], a[j], b[j])
    for s in np.concatenate([i[hit], j[hit]]).tolist():
        bad.add((int(owner[s]), int(kept[owner[s]][seg[s]])))
    return sorted(bad)


def candidate_pairs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs i < j (in sweep order) of segments whose bounding boxes meet (touching too)."""
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    order = np.argsort(lo[:, 0], kind="stable")
    lo_x = lo[order, 0]
    end = np.searchsorted(lo_x, hi[order, 0], side="right")
    count = np.maximum(end - np.arange(len(order)) - 1, 0)
    first = np.repeat(np.arange(len(order)), count)
    offset = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    i, j = order[first], order[first + 1 + offset]
    meet = (lo[i, 1] <= hi[j, 1]) & (lo[j, 1] <= hi[i, 1])
    return i[meet], j[meet]


def _drop_collinear(p: np.ndarray) -> np.ndarray:
    """The loop without corners where it runs straight on (180 degrees): a run of such corners
    lies on the line between its neighbours, so all of them go at once."""
    u, w = p - np.roll(p, 1, axis=0), np.roll(p, -1, axis=0) - p
    straight = (turns(p) == 0) & ((u * w).sum(axis=1) > 0)
    return p[~straight]
