"""Single-lane passages, found from the geometry: gaps between obstacles (or an obstacle and the
arena wall) narrower than two lanes, and the aisle beside a robot at work.

A *lane* is what one robot needs to pass: its body and ORCA's margin on both sides, and the
planner's clearance on the side of an obstacle, ``2 r + 2 margin + clearance`` (0.7 m for
0.25 m robots today). A gap narrower than two lanes (:func:`two_lanes_m`, 1.4 m) is a
*passage*: two robots cannot pass each other in it, so robots take it one direction at a time
(``sim.spatial.traffic.locks``).

A passage is a rectangle: its centre, the unit ``axis`` along the lane, a half length (the
stretch over which the gap stays narrower than two lanes) and a half width (half the widest
gap over that stretch). A robot at work whose body leaves less than two lanes on either side
(a 2 m aisle with a robot at work in its middle) makes a *temporary* passage across the aisle
through it, for as long as it works; one that leaves less than a lane on both sides closes the
aisle (``passable`` False): robots wait before it rather than beside it.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim.spatial.plane import worker_room
from sim.spatial.traffic.geometry import (
    TOL_M,
    as_complex,
    clip_line,
    contiguous_poly,
    disc_corners,
    polygon_gap,
    to_segments,
    walls,
)

SCAN_M = 0.05  # step of the scan along a gap for the stretch where it stays narrow, m
SCAN_MAX_M = 200.0  # no passage is longer than this, m
REFINE = 12  # bisections of each end of that stretch (to SCAN_M / 4096)


@dataclass(frozen=True, slots=True)
class Passage:
    """A single-lane stretch: a rectangle robots cross along ``axis``.

    Attributes:
        centre: its middle, x + iy, m.
        axis: unit vector along the lane (x + iy); a robot crossing it goes +1 (along) or -1.
        half_length_m: half its length along the lane, m.
        half_width_m: half its width across, m.
        gap_m: the narrowest gap across it, m.
        worker: the robot at work that makes it (a temporary passage), -1 for the geometry's.
        passable: a robot fits past (False: a robot at work closes the aisle).
        by_walls: the obstacles alone leave less than two lanes beside that robot (not only
            other robots at work round it).
    """

    centre: complex
    axis: complex
    half_length_m: float
    half_width_m: float
    gap_m: float
    worker: int = -1
    passable: bool = True
    by_walls: bool = True

    def local(self, z: np.ndarray) -> np.ndarray:
        """Points ``z`` in the passage's frame: real along the axis, imag across, m."""
        return (np.asarray(z) - self.centre) * np.conj(self.axis)

    def mouth(self, direction: int) -> complex:
        """Where a robot crossing in ``direction`` (+1 along the axis, -1 against) enters."""
        return self.centre - direction * self.half_length_m * self.axis

    def holds(self, z: complex, pad_along_m: float, pad_across_m: float) -> bool:
        """True if point ``z`` lies in the rectangle grown by the pads (along, across)."""
        p = (z - self.centre) * self.axis.conjugate()
        return (
            abs(p.real) <= self.half_length_m + pad_along_m
            and abs(p.imag) <= self.half_width_m + pad_across_m
        )


def two_lanes_m(radius_m: float, margin_m: float, clearance_m: float) -> float:
    """The width in which two robots pass each other: 2 (2 r + 2 margin) + 2 clearance, m."""
    return 2.0 * (2.0 * radius_m + 2.0 * margin_m) + 2.0 * clearance_m


def lane_m(radius_m: float, margin_m: float, clearance_m: float) -> float:
    """The room one robot needs beside a robot at work: 2 r + 2 margin + clearance, m (the
    planner keeps the clearance from the obstacle, ORCA two radii and margins from the robot)."""
    return 2.0 * radius_m + 2.0 * margin_m + clearance_m


def find_passages(
    obstacles, width_m: float, height_m: float, passage_m: float, min_gap_m: float
) -> tuple[Passage, ...]:
    """The passages of an arena: every pair of obstacles (an arena wall counts as one) whose
    gap is narrower than ``passage_m`` and wider than ``min_gap_m`` (narrower, no robot centre
    fits: the planner finds no path through it), unless a third obstacle fills the gap where
    it is narrowest (:func:`_filled`). Kept per arena for the process (a world is built anew
    at each reset).

    Args:
        obstacles: convex polygons, (P, 2) points or (P,) complex, counter-clockwise.
        width_m, height_m: the arena.
        passage_m: two lanes (:func:`two_lanes_m`).
        min_gap_m: two radii plus two clearances.
    """
    key = tuple(tuple(map(complex, as_complex(p))) for p in obstacles)
    return _passages(key, float(width_m), float(height_m), float(passage_m), float(min_gap_m))


@functools.lru_cache(maxsize=16)
def _passages(obstacles: tuple, width_m, height_m, passage_m, min_gap_m) -> tuple[Passage, ...]:
    polys = [np.array(p, dtype=complex) for p in obstacles]
    n_obs = len(polys)
    polys += walls(width_m, height_m)
    lo = np.array([[p.real.min(), p.imag.min()] for p in polys]).reshape(-1, 2)
    hi = np.array([[p.real.max(), p.imag.max()] for p in polys]).reshape(-1, 2)
    out = []
    for i in range(len(polys)):
        near = (lo[i + 1 :] < hi[i] + passage_m).all(axis=1)
        near &= (hi[i + 1 :] > lo[i] - passage_m).all(axis=1)
        for k in (np.flatnonzero(near) + i + 1).tolist():
            if i >= n_obs and k >= n_obs:
                continue  # two walls

            def filled(z: complex, pair=(i, k)) -> bool:
                return _filled(z, polys, lo, hi, pair, min_gap_m)

            found = pair_passage(polys[i], polys[k], passage_m, min_gap_m, filled=filled)
            if found is not None:
                out.append(found)
    return tuple(out)


def _filled(z: complex, polys: list, lo: np.ndarray, hi: np.ndarray, pair, min_gap_m: float):
    """True if an obstacle other than the ``pair`` lies in their gap: nearer to the point
    ``z`` midway across it than a robot centre may come (half of ``min_gap_m``). The gap
    between two pieces of one wall (a map's wall is many convex pieces) is filled by the
    pieces between them: no robot crosses it, so it is no passage."""
    reach = 0.5 * min_gap_m - TOL_M
    xy = np.array([z.real, z.imag])
    near = np.flatnonzero(((lo - reach) < xy).all(axis=1) & ((hi + reach) > xy).all(axis=1))
    for j in near.tolist():
        if j in pair:
            continue
        poly = polys[j]
        nxt = np.roll(poly, -1)
        if (((z - poly) * (nxt - poly).conj()).imag > 0.0).all():  # left of every CCW edge
            return True
        if to_segments(z, poly, nxt)[0].min() < reach:
            return True
    return False


def pair_passage(
    pa: np.ndarray,
    pb: np.ndarray,
    passage_m: float,
    min_gap_m: float,
    worker: int = -1,
    filled: Callable[[complex], bool] | None = None,
) -> Passage | None:
    """The passage between two convex polygons, or None if their gap is not narrower than
    ``passage_m`` or not wider than ``min_gap_m``, or if ``filled`` says that something else
    fills it at the point midway across its narrowest place. The lane runs across the line of their
    nearest points; it extends along the lane as far as a line across it meets both polygons
    with a gap narrower than ``passage_m`` between them (scanned every ``SCAN_M``, ends
    bisected)."""
    gap, p, q = polygon_gap(pa, pb)
    passage_m -= TOL_M  # a gap of two lanes exactly (a rounding below) is two lanes
    if not min_gap_m < gap < passage_m:
        return None
    across = (q - p) / gap
    axis = 1j * across
    mid = 0.5 * (p + q)
    if filled is not None and filled(mid):
        return None

    def width(s: float) -> float:
        """Gap between the polygons on the line across at ``s`` along; inf where it misses."""
        origin = mid + s * axis
        a0, a1 = clip_line(origin, across, pa)
        b0, b1 = clip_line(origin, across, pb)
        if a0 > a1 or b0 > b1:
            return np.inf
        return b0 - a1

    ends, widest = [], gap
    for sign in (1.0, -1.0):
        s = 0.0
        while s < SCAN_MAX_M and width(sign * (s + SCAN_M)) < passage_m:
            s += SCAN_M
            widest = max(widest, width(sign * s))
        lo_s, hi_s = s, s + SCAN_M
        for _ in range(REFINE):
            m = 0.5 * (lo_s + hi_s)
            lo_s, hi_s = (m, hi_s) if width(sign * m) < passage_m else (lo_s, m)
        ends.append(sign * lo_s)
    s_hi, s_lo = ends
    if s_hi - s_lo < 1e-6:
        return None  # the polygons only come close at a point: no stretch to cross
    centre = mid + 0.5 * (s_hi + s_lo) * axis
    half_w = 0.5 * max(widest, width(0.5 * (s_hi + s_lo)))
    return Passage(centre, axis, 0.5 * (s_hi - s_lo), half_w, gap, worker)


def worker_passage(
    worker: int,
    z: complex,
    radius_m: float,
    obstacles: list[np.ndarray],
    others: np.ndarray,
    passage_m: float,
    lane: float,
) -> Passage | None:
    """The temporary passage a robot at work at ``z`` makes, or None if it leaves two lanes
    (``passage_m``) on one side.

    Across is the line from ``z`` to the nearest obstacle point (or robot at work); the room
    on each side is the free distance along it from the robot's body to the first obstacle or
    other robot at work (``others``, their centres). The passage is the rectangle across the
    aisle through the robot, four radii long (a robot whose centre is in it is beside the one
    at work); ``passable`` if either side leaves ``lane`` (:func:`lane_m`)."""
    others = contiguous_poly(others)  # (centres: a contiguous complex array as well)
    if not len(obstacles) and not len(others):
        return None
    polys = [contiguous_poly(o) for o in obstacles]
    at = np.array([0, *itertools.accumulate(map(len, polys))], dtype=np.int64)
    flat = np.concatenate(polys) if polys else others[:0]
    found, across, near, far = worker_room(
        complex(z), radius_m, disc_corners(radius_m), flat, at, others, passage_m
    )
    if not found:
        return None
    centre = z + 0.5 * (near - far) * across  # the middle of the aisle's cross-section
    half_w = 0.5 * (near + far) + radius_m
    passable = max(near, far) >= lane
    return Passage(
        centre, 1j * across, 2.0 * radius_m, half_w, float(max(near, far)), worker, passable
    )
