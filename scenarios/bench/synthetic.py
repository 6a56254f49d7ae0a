"""A plausible synthetic trajectory for the renderer's tests and benchmark (``scenarios.bench``).

A cheap, seeded stand-in for a recorded run: no world, no physics, no allocator. Robots drive at
constant speed along obstacle-avoiding straight-line paths (a visibility graph over the inflated
obstacle corners), their headings turning toward the path at a bounded rate, and they pass
through one another. Each works at its task for a type-dependent time and stays where it
finished. From t = 1 s, every 10 s while tasks remain, a round of U{3..7} tasks is announced; each
is given at once to the nearest free capable robot (high priority first) or lost. The result goes
through the same ``TrajectoryRecorder`` as a real run of ``sim.spatial.world.PymunkWorld``, so it
has every field the renderer reads.
"""

from __future__ import annotations

import heapq

import numpy as np

from sim.recording import Trajectory, TrajectoryRecorder
from sim.states import DRIVING, IDLE, WORKING

ARENA_WH = (20.0, 20.0)  # m
OBSTACLES = (
    ((4.0, 11.0), (8.0, 11.0), (8.0, 13.5), (4.0, 13.5)),  # m, convex, counter-clockwise
    ((12.0, 4.0), (16.5, 5.0), (13.0, 8.5)),
    ((13.0, 13.0), (15.5, 12.5), (17.0, 14.5), (15.5, 16.5), (13.0, 15.5)),
)
TYPE_NAMES = ("T1", "T2", "T3", "T4", "T5", "T6", "T7", "T8")
SPEED_MPS = 1.2
TURN_RATE_RADPS = 4.0
CLEARANCE_M = 0.6  # how far paths keep from obstacle edges
RECORD_EVERY_S = 0.1
ANNOUNCE_EVERY_S = 10.0


def _inflate(poly: np.ndarray, margin_m: float) -> np.ndarray:
    """Push each vertex of a convex polygon outward by about ``margin_m``."""
    centre = poly.mean(axis=0)
    out = poly - centre
    return centre + out * (1.0 + margin_m / np.linalg.norm(out, axis=1, keepdims=True))


def _dot(a: np.ndarray, b: np.ndarray) -> float:
    """a . b of two 2-vectors without BLAS (whose kernel, and so the last bit, depends on the
    CPU)."""
    return float(a[0] * b[0] + a[1] * b[1])


def _norm(a: np.ndarray) -> float:
    """|a| of a 2-vector, as :func:`_dot` (``np.linalg.norm`` of a vector calls BLAS)."""
    return float(np.sqrt(a[0] * a[0] + a[1] * a[1]))


def _segment_hits(a: np.ndarray, b: np.ndarray, poly: np.ndarray) -> bool:
    """True if segment ab enters the convex polygon (Cyrus-Beck clipping)."""
    d = b - a
    t0, t1 = 0.0, 1.0
    edges = np.roll(poly, -1, axis=0) - poly
    centre = poly.mean(axis=0)
    for p, e in zip(poly, edges, strict=True):
        normal = np.array([e[1], -e[0]])
        if _dot(normal, centre - p) > 0:  # make it point outward
            normal = -normal
        num = _dot(normal, a - p)
        den = _dot(normal, d)
        if abs(den) < 1e-12:
            if num > 0:
                return False
            continue
        t = -num / den
        if den < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return False
    return t1 - t0 > 1e-9


def _plan(
    start: np.ndarray, goal: np.ndarray, blocks: list[np.ndarray], nodes: np.ndarray
) -> list[np.ndarray]:
    """Shortest path start -> goal over the visibility graph of ``nodes`` (waypoints)."""
    points = np.vstack([start, goal, nodes])
    n = len(points)

    def free(i: int, j: int) -> bool:
        return not any(_segment_hits(points[i], points[j], poly) for poly in blocks)

    dist = np.full(n, np.inf)
    prev = np.full(n, -1)
    dist[0] = 0.0
    heap = [(0.0, 0)]
    while heap:
        d, i = heapq.heappop(heap)
        if i == 1:
            break
        if d > dist[i]:
            continue
        for j in range(1, n):
            step = _norm(points[j] - points[i])
            if d + step < dist[j] and free(i, j):
                dist[j] = d + step
                prev[j] = i
                heapq.heappush(heap, (dist[j], j))
    if not np.isfinite(dist[1]):
        return [goal]
    path, k = [], 1
    while k != 0:
        path.append(points[k])
        k = int(prev[k])
    return path[::-1]


def _free_point(rng: np.random.Generator, blocks: list[np.ndarray], margin_m: float) -> np.ndarray:
    w, h = ARENA_WH
    while True:
        p = rng.uniform((margin_m, margin_m), (w - margin_m, h - margin_m))
        if not any(_segment_hits(p, p + 1e-6, poly) for poly in blocks):
            return p


def synthetic_trajectory(
    rng: np.random.Generator, robots: int = 10, seconds: float = 120.0, tasks: int = 40
) -> Trajectory:
    """Make a plausible recorded run: 20 m x 20 m arena, three obstacles, eight task types.

    Args:
        rng: the only source of randomness (same generator state, same trajectory).
        robots: number of robots.
        seconds: simulated duration; poses are recorded every 0.1 s.
        tasks: tasks to announce (rounds of 3..7 every 10 s, from t = 1 s, while time remains).

    Returns:
        A ``Trajectory`` with every field the physics world records.
    """
    polys = [np.array(p, dtype=float) for p in OBSTACLES]
    blocks = [_inflate(p, CLEARANCE_M - 0.1) for p in polys]
    w, h = ARENA_WH
    nodes = np.vstack([_inflate(p, CLEARANCE_M + 0.15) for p in polys])
    nodes = np.clip(nodes, 0.5, (w - 0.5, h - 0.5))
    n_types = len(TYPE_NAMES)
    capable = rng.random((robots, n_types)) < 0.5
    capable[np.arange(robots), rng.integers(0, n_types, robots)] = True
    exec_s = rng.uniform(4.0, 14.0, n_types)

    rec = TrajectoryRecorder(
        ARENA_WH, OBSTACLES, TYPE_NAMES, [f"R{j + 1}" for j in range(robots)], RECORD_EVERY_S
    )
    pos = np.array([_free_point(rng, blocks, 1.0) for _ in range(robots)])
    head = rng.uniform(-np.pi, np.pi, robots)
    state = np.full(robots, IDLE, dtype=np.int8)
    paths: list[list[np.ndarray]] = [[] for _ in range(robots)]
    job = np.full(robots, -1)
    work_left = np.zeros(robots)
    job_type = np.zeros(robots, dtype=int)
    next_id, next_announce = 0, 1.0
    dt = RECORD_EVERY_S
    for step in range(round(seconds / dt) + 1):
        t = step * dt
        if t + 1e-9 >= next_announce and next_id < tasks:
            next_announce += ANNOUNCE_EVERY_S
            k = min(int(rng.integers(3, 8)), tasks - next_id)
            ids = np.arange(next_id, next_id + k)
            next_id += k
            types = rng.integers(0, n_types, k)
            high = rng.random(k) < 0.35
            sites = np.array([_free_point(rng, blocks, 1.0) for _ in range(k)])
            rec.announce(t, ids, types, high, sites)
            assignment = np.full(k, -1)
            for i in np.argsort(~high, kind="stable"):
                cand = np.flatnonzero((state == IDLE) & capable[:, types[i]])
                cand = cand[~np.isin(cand, assignment)]
                if cand.size:
                    j = int(cand[np.argmin(np.linalg.norm(pos[cand] - sites[i], axis=1))])
                    assignment[i] = j
                    job[j], job_type[j] = ids[i], types[i]
                    paths[j] = _plan(pos[j], sites[i], blocks, nodes)
                    state[j] = DRIVING
            rec.allocate(t, ids, assignment)
        for j in np.flatnonzero(state == DRIVING):
            budget = SPEED_MPS * dt
            while paths[j] and budget > 0:
                gap = paths[j][0] - pos[j]
                dist = _norm(gap)
                if dist <= budget:
                    pos[j] = paths[j].pop(0)
                    budget -= dist
                else:
                    pos[j] = pos[j] + gap / dist * budget
                    budget = 0.0
                if dist > 1e-9:
                    want = np.arctan2(gap[1], gap[0])
                    turn = (want - head[j] + np.pi) % (2 * np.pi) - np.pi
                    head[j] += np.clip(turn, -TURN_RATE_RADPS * dt, TURN_RATE_RADPS * dt)
            if not paths[j]:
                state[j] = WORKING
                work_left[j] = exec_s[job_type[j]]
        for j in np.flatnonzero(state == WORKING):
            work_left[j] -= dt
            if work_left[j] <= 1e-9:
                rec.done(int(job[j]), t)
                state[j], job[j] = IDLE, -1
        head = (head + np.pi) % (2 * np.pi) - np.pi
        rec.poses(t, pos, head, state)
    return rec.finish()
