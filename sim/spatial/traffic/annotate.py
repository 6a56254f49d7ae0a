"""Planned paths annotated with the passages they cross, and where a robot kept out holds.

A path is a polyline of complex points; along it, a point is named by the path length left
from it to the path's end (``left``, m, as the fleet's ``left_m``), which only falls as a
robot drives. :func:`crossings` intersects the path with each passage's rectangle: the
passage, the direction it is crossed in, and the path left at entry and at exit.
:func:`chains` groups crossings less than ``chain_m`` apart along the path: a robot asks for a
chain at once, so it never waits between two passages holding one of them. :func:`hold_points`
lists where a robot kept out of a chain may hold: a radius plus ``hold_m`` before the mouth,
aside of the lane where there is room.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sim.spatial.traffic.geometry import clip_segments
from sim.spatial.traffic.passages import Passage


@dataclass(frozen=True, slots=True)
class Crossing:
    """One passage a path crosses.

    Attributes:
        key: the passage's key.
        direction: +1 along the passage's axis, -1 against it.
        entry_left_m: path left where the path enters its rectangle, m.
        exit_left_m: path left where it leaves it (0: the path ends in it), m.
    """

    key: int
    direction: int
    entry_left_m: float
    exit_left_m: float


@dataclass(frozen=True, slots=True, eq=False)
class Chain:
    """Passages a robot takes at once: crossings less than ``chain_m`` apart along its path.

    Attributes:
        passages: (key, direction) of each passage, in path order, each key once.
        exits_left_m: path left where the path last leaves each of them, m.
        entry_left_m: path left at the first entry, m.
        exit_left_m: path left at the last exit, m.
        zone: (Z,) the path from the first entry to the exit clearance beyond the last exit,
            x + iy: entry waits until no standing robot is near it.
    """

    passages: tuple[tuple[int, int], ...]
    exits_left_m: tuple[float, ...]
    entry_left_m: float
    exit_left_m: float
    zone: np.ndarray

    @property
    def keys(self) -> frozenset[int]:
        return frozenset(k for k, _ in self.passages)


def left_along(pts: np.ndarray) -> np.ndarray:
    """(P,) path length left from each point of the polyline ``pts`` to its end, m."""
    seg = np.abs(np.diff(pts))
    return np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])


def crossings(pts: np.ndarray, passages: dict[int, Passage]) -> list[Crossing]:
    """The passages the polyline ``pts`` (x + iy, m) crosses, in path order (a passage crossed
    twice is listed twice). ``left`` is measured from each point to the end of ``pts``."""
    if len(pts) < 2 or not passages:
        return []
    a, b = pts[:-1], pts[1:]
    seg = np.abs(b - a)
    left = left_along(pts)
    lo = complex(pts.real.min(), pts.imag.min())
    hi = complex(pts.real.max(), pts.imag.max())
    out = []
    for key, p in passages.items():
        reach = p.half_length_m + p.half_width_m
        c = p.centre
        if not (lo.real - reach <= c.real <= hi.real + reach):
            continue
        if not (lo.imag - reach <= c.imag <= hi.imag + reach):
            continue
        t0, t1 = clip_segments(a, b, c, p.axis, p.half_length_m, p.half_width_m)
        hit = np.flatnonzero(t0 <= t1)
        if not len(hit):
            continue
        runs, start = [], hit[0]
        for prev, k in zip(hit[:-1].tolist(), hit[1:].tolist(), strict=True):
            if k != prev + 1 or t1[prev] < 1.0 - 1e-9 or t0[k] > 1e-9:
                runs.append((start, prev))
                start = k
        runs.append((start, hit[-1]))
        for k0, k1 in runs:
            enter = a[k0] + t0[k0] * (b[k0] - a[k0])
            leave = a[k1] + t1[k1] * (b[k1] - a[k1])
            ds = ((leave - enter) * np.conj(p.axis)).real
            if abs(ds) < 1e-9:
                ds = ((b[k0] - a[k0]) * np.conj(p.axis)).real
            direction = 1 if ds >= 0.0 else -1
            entry = float(left[k0] - t0[k0] * seg[k0])
            leave_left = float(left[k1] - t1[k1] * seg[k1])
            out.append(Crossing(key, direction, entry, max(leave_left, 0.0)))
    out.sort(key=lambda c: (-c.entry_left_m, c.key))
    return out


def chains(
    pts: np.ndarray,
    found: list[Crossing],
    chain_m: float,
    clear_m: float,
    roomy: Callable[[Crossing, Crossing], bool] | None = None,
) -> list[Chain]:
    """Group the crossings ``found`` on the polyline ``pts`` into chains: a crossing that
    enters less than ``chain_m`` after the chain so far leaves joins it, unless
    ``roomy(last, crossing)`` says a robot can hold between the two. Each chain's zone runs
    from its entry to ``clear_m`` beyond its exit (or the path's end)."""
    if not found:
        return []  # (most ways cross no passage)
    groups: list[list[Crossing]] = []
    for c in found:
        close = groups and min(g.exit_left_m for g in groups[-1]) - c.entry_left_m < chain_m
        if close and not (roomy is not None and roomy(groups[-1][-1], c)):
            groups[-1].append(c)
        else:
            groups.append([c])
    left = left_along(pts)
    out = []
    for group in groups:
        first: dict[int, int] = {}
        exits: dict[int, float] = {}
        for c in group:
            first.setdefault(c.key, c.direction)
            exits[c.key] = min(exits.get(c.key, np.inf), c.exit_left_m)
        entry = max(c.entry_left_m for c in group)
        leave = min(exits.values())
        zone = cut(pts, left, entry, max(leave - clear_m, 0.0))
        passages = tuple(first.items())
        out.append(Chain(passages, tuple(exits[k] for k in first), entry, leave, zone))
    return out


def cut(pts: np.ndarray, left: np.ndarray, from_left_m: float, to_left_m: float) -> np.ndarray:
    """The piece of the polyline ``pts`` (with ``left``, :func:`left_along`) from the point
    with ``from_left_m`` of path left to the one with ``to_left_m`` (<=), x + iy."""
    inner = pts[(left < from_left_m) & (left > to_left_m)]
    return np.concatenate(
        [[at_left(pts, left, from_left_m)], inner, [at_left(pts, left, to_left_m)]]
    )


def at_left(pts: np.ndarray, left: np.ndarray, left_m: float) -> complex:
    """The point of the polyline with ``left_m`` of path left (clipped to its ends)."""
    if left_m >= left[0]:
        return complex(pts[0])
    if left_m <= 0.0:
        return complex(pts[-1])
    k = int(np.searchsorted(-left, -left_m, side="right")) - 1  # left[k] >= left_m > left[k+1]
    span = left[k] - left[k + 1]
    t = (left[k] - left_m) / span if span > 1e-12 else 0.0
    return complex(pts[k] + t * (pts[k + 1] - pts[k]))


def hold_points(
    pts: np.ndarray,
    entry_left_m: float,
    back_m: float,
    aside_m: float,
    step_m: float = 0.25,
    steps: int = 8,
) -> list[tuple[complex, complex]]:
    """Where a robot on the polyline ``pts`` kept out of a chain it enters ``entry_left_m``
    before the path's end may hold, best first, each with the unit vector across the path to
    its left there: on its own way ``back_m`` before the entry, then every ``step_m`` farther
    back (``steps`` more, no farther back than where it is), each moved to the right of the
    way by ``aside_m``, half that, or not at all (a robot coming out of the passage keeps to
    its right too, so the two pass left to left; the caller checks which are free)."""
    left = left_along(pts)
    out = []
    room = left[0] - entry_left_m  # how far before the entry the robot is
    for k in range(steps + 1):
        back = back_m + k * step_m
        if back > room and k:
            break
        at = min(entry_left_m + back, left[0])
        spot = at_left(pts, left, at)
        ahead = at_left(pts, left, max(at - 0.05, 0.0))
        tangent = ahead - spot
        if abs(tangent) < 1e-9:
            continue
        to_left = 1j * tangent / abs(tangent)
        out += [(spot - to_left * off, to_left) for off in (aside_m, 0.5 * aside_m, 0.0)]
    return out
