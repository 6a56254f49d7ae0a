"""The passages of an arena as the traffic rules see them: the geometry's, found at load, and the
temporary ones of robots at work, kept up to date; and where a robot may hold before one.

:class:`PassageMap` answers the geometric questions of ``sim.spatial.traffic.rules``: which
passages a robot's path is annotated with, whether a point is in a passage, whether a point
before a mouth is a holding point (free space, in no passage, off the lane out of the mouth,
room to pass it), whether a robot can hold between two passages (else they are one chain),
and where a robot kept out holds.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from sim.scenario import SpatialSpec
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.plane import near_box, workers_near
from sim.spatial.traffic.annotate import Chain, Crossing, hold_points, left_along
from sim.spatial.traffic.geometry import as_complex, to_segments, walls
from sim.spatial.traffic.passages import (
    Passage,
    find_passages,
    lane_m,
    two_lanes_m,
    worker_passage,
)

LANE_OUT_M = 2.0  # a holding point keeps a pass off this much of the lane out of a mouth, m
HOLD_STEP_M = 0.25  # holding points are looked for every this much farther back, m
NEAR_RINGS = (1.0, 1.5, 2.0, 3.0)  # spot_near's rings round the robot, in passes
NEAR_POINTS = 16  # points on each ring


class PassageMap:
    """Every passage of an arena by key, and the geometry of holding before one.

    Args:
        spatial: the arena and its rules (``[spatial.traffic]``, ``orca.margin_m``,
            ``clearance_m``).
        radius_m: the robots' radius.
        planner: tells free space (a holding point must be on it).

    Attributes:
        passages: the geometry's passages (keys 0 .. ``n_static`` - 1) and the temporary ones
            of robots at work (key ``n_static`` + the robot's index).
        passage_m, lane_m: two lanes and one lane (``sim.spatial.traffic.passages``), m.
        pass_m: a robot passes one that stands this far from its way, m (two radii and
            ORCA's margins).
        reach_m: a robot beginning or ending work can change the annotation of a way this
            near it, m.
    """

    def __init__(self, spatial: SpatialSpec, radius_m: float, planner: GridPlanner) -> None:
        self.spec, self.planner = spatial.traffic, planner
        r = self.radius_m = radius_m
        margin, clear = spatial.orca.margin_m, spatial.clearance_m
        self.passage_m = self.spec.passage_m or two_lanes_m(r, margin, clear)
        self.lane_m = lane_m(r, margin, clear)
        self.pass_m = 2.0 * r + 2.0 * margin
        # a robot at work affects the passages, holding points and ways this near it: its
        # temporary passage lies within 1.5 passage_m + 3 r of it (room < passage_m each side,
        # four radii long); a point is tested in one grown by a radius, a holding point lies
        # aside_m off the way and a robot passes one that stands pass_m from its way
        self.reach_m = 1.5 * self.passage_m + 5.0 * r + self.spec.aside_m + self.pass_m
        w, h = spatial.width_m, spatial.height_m
        static = find_passages(spatial.obstacles, w, h, self.passage_m, 2.0 * (r + clear))
        self.n_static = len(static)
        self.passages: dict[int, Passage] = dict(enumerate(static))
        self.shapes = [as_complex(p) for p in spatial.obstacles] + walls(w, h)
        self.boxes = np.array(
            [[s.real.min(), s.imag.min(), s.real.max(), s.imag.max()] for s in self.shapes],
            dtype=float,
        ).reshape(-1, 4)
        self.room_: dict[tuple[int, int, int, int], bool] = {}  # room_between, static pairs
        self.version_ = 0  # counts the changes of ``passages`` (update_workers)
        self.table_: tuple = (-1,)  # _near_box's arrays of them, and the version they hold

    # -- passages -------------------------------------------------------------------------
    def inside(self, key: int, z: complex, pad_along_m: float) -> bool:
        """True if point z is in passage ``key`` grown by ``pad_along_m`` at its ends and a
        radius at its sides (False for a passage that is gone)."""
        p = self.passages.get(key)
        return p is not None and p.holds(z, pad_along_m, self.radius_m)

    def narrowed_by_walls(self, w: int) -> bool:
        """True if robot w at work leaves less than two lanes to the obstacles beside it."""
        p = self.passages.get(self.n_static + w)
        return p is not None and p.by_walls

    def passable(self, w: int) -> bool:
        """True unless robot w at work closes its aisle (its temporary passage is closed)."""
        p = self.passages.get(self.n_static + w)
        return p is None or p.passable

    def for_robot(
        self, j: int, end: complex, service: np.ndarray, way: np.ndarray | None = None
    ) -> dict[int, Passage]:
        """The passages robot j's path (ending at ``end``) may be annotated with: not the
        temporary passage of a robot at work at its own site (``service``: each robot's
        service point), nor one its path ends in (it goes to that robot's site's queue, not
        past it). With ``way`` (the path, x + iy), only those :func:`crossings` looks at
        (a centre within half the length plus half the width of the path's box)."""
        r, out = self.radius_m, {}
        items = self.passages.items() if way is None else self._near_box(way)
        for key, p in items:
            if p.worker >= 0 and (
                p.worker == j or abs(service[p.worker] - service[j]) < 1e-6 or p.holds(end, r, r)
            ):
                continue
            out[key] = p
        return out

    def _near_box(self, way: np.ndarray) -> list[tuple[int, Passage]]:
        """(key, passage) in ``passages``' order for those whose centre lies within its
        half length plus half width of the box of the points ``way``, as :func:`crossings`
        tests it (the same sums and comparisons, on arrays)."""
        if self.table_[0] != self.version_:
            items = list(self.passages.items())
            cx = np.array([p.centre.real for _, p in items])
            cy = np.array([p.centre.imag for _, p in items])
            reach = np.array([p.half_length_m + p.half_width_m for _, p in items])
            self.table_ = (self.version_, items, cx, cy, reach)
        _, items, cx, cy, reach = self.table_
        way = np.ascontiguousarray(way, dtype=complex)
        return [items[k] for k in near_box(way, cx, cy, reach).tolist()]

    def update_workers(self, changed: np.ndarray, work: np.ndarray, z: np.ndarray) -> tuple:
        """Robots ``changed`` began or ended work (``work``: who works now, at ``z``): their
        temporary passages, and those of the robots at work near them (their room depends on
        each other), are made again. Returns the keys dropped, the number of new passages and
        the robots whose passage came, went or changed."""
        r = self.radius_m
        self.version_ += 1  # the passages may change: _near_box's table is built again
        dropped, touched = [], []
        for w in changed.tolist():
            if self.passages.pop(self.n_static + w, None) is not None:
                dropped.append(self.n_static + w)
                touched.append(w)
        made = 0
        if not work.any() or not len(changed):
            return dropped, made, np.array(touched, dtype=int)
        reach = 2.0 * (self.passage_m + 2.0 * r)
        # a robot at work farther than this is neither the nearest shape within passage_m of
        # w's body nor the first one within passage_m on either side of it (bodies are
        # disc_polygon's octagons, corners r / cos(pi / 8) out): it cannot change w's passage
        counts_m = self.passage_m + 2.0 * r / np.cos(np.pi / 8) + 1e-9
        # those near, the robots at work that count for each and the obstacles and walls
        # within two lanes and a radius of it (by their bounding boxes)
        rows, others_at, others, shapes_at, shapes = workers_near(
            np.ascontiguousarray(z, dtype=complex),
            np.ascontiguousarray(work, dtype=bool),
            np.ascontiguousarray(changed, dtype=np.int64),
            reach,
            min(reach, counts_m),
            self.boxes,
            self.passage_m + r,
        )
        lane = self.lane_m
        for n, w in enumerate(rows.tolist()):
            key = self.n_static + w
            was = self.passages.pop(key, None)
            near = others[others_at[n] : others_at[n + 1]]
            mine = [self.shapes[k] for k in shapes[shapes_at[n] : shapes_at[n + 1]].tolist()]
            zw = complex(z[w])
            p = worker_passage(w, zw, r, mine, near, self.passage_m, lane)
            if p is not None and len(near):
                alone = worker_passage(w, zw, r, mine, near[:0], self.passage_m, 0)
                p = dataclasses.replace(p, by_walls=alone is not None)
            if p is not None:
                self.passages[key] = p
                made += was is None
            elif was is not None:
                dropped.append(key)
            if p != was and w not in touched:
                touched.append(w)
        return dropped, made, np.array(touched, dtype=int)

    # -- holding --------------------------------------------------------------------------
    def open_spot(self, spot: complex, to_left: complex, key: int, direction: int) -> bool:
        """A holding point before passage ``key`` (entered in ``direction``) as far as the
        geometry goes: on free space, in no passage, off the lane straight out of the mouth
        (``LANE_OUT_M`` of it) by a pass, and a robot passes it on its left."""
        r, passer = self.radius_m, spot + to_left * self.pass_m
        free = self.planner.free_one
        if not (free(spot.real, spot.imag) and free(passer.real, passer.imag)):
            return False
        p = self.passages.get(key)
        if p is not None:
            mouth = p.mouth(direction)
            lane_end = mouth - direction * LANE_OUT_M * p.axis
            off, _ = to_segments(np.array([spot]), np.array([mouth]), np.array([lane_end]))
            if off[0] < self.pass_m - 1e-9:
                return False
        return not any(q.holds(spot, r, r) for q in self.passages.values())

    def room_between(self, pts: np.ndarray, a: Crossing, b: Crossing) -> bool:
        """True if a robot on the path ``pts`` that has left crossing ``a`` can hold before
        crossing ``b`` (:meth:`open_spot`, at least a radius plus ``release_m`` past ``a``'s
        exit): then the two are not one chain. Remembered for a pair of the geometry's
        passages (it depends on the geometry alone)."""
        key = (a.key, a.direction, b.key, b.direction)
        static = a.key < self.n_static and b.key < self.n_static
        if static and key in self.room_:
            return self.room_[key]
        r, back = self.radius_m, self.radius_m + self.spec.hold_m
        room = a.exit_left_m - b.entry_left_m - r - self.spec.release_m
        room = min(room, left_along(pts)[0] - b.entry_left_m)
        found = False
        if room >= back:
            steps = int((room - back) / HOLD_STEP_M)
            spots = hold_points(pts, b.entry_left_m, back, self.spec.aside_m, HOLD_STEP_M, steps)
            found = any(self.open_spot(s, left, b.key, b.direction) for s, left in spots)
        if static:
            self.room_[key] = found
        return found

    def spot(self, pts: np.ndarray, chain: Chain, others: np.ndarray, keep_m: float):
        """Where a robot on the path ``pts`` kept out of ``chain`` holds: the first of
        ``annotate.hold_points`` that is a holding point (:meth:`open_spot`), a radius plus
        ``hold_m`` or more from the mouth and ``keep_m`` from every point of ``others`` (the
        other robots, and the points others hold at); None if there is none."""
        back = self.radius_m + self.spec.hold_m
        mouth = chain.zone[0]
        key, direction = chain.passages[0]
        for s, to_left in hold_points(pts, chain.entry_left_m, back, self.spec.aside_m):
            if abs(s - mouth) < back - 1e-6 or not self.open_spot(s, to_left, key, direction):
                continue
            if len(others) and np.abs(others - s).min() < keep_m:
                continue
            return s
        return None

    def spot_near(self, z: complex, chain: Chain, others: np.ndarray, keep_m: float):
        """Where a robot at ``z`` kept out of ``chain`` holds when its way before the mouth
        has no holding point (it stands too near the mouth, or others hold there): of
        ``NEAR_POINTS`` points on each ring of ``NEAR_RINGS`` passes round it, nearest ring
        first and on a ring the farthest from the mouth first, the first that is a holding
        point (:meth:`open_spot`, a robot passing it on the side away from the mouth), a
        radius plus ``hold_m`` or more from the mouth and ``keep_m`` from every point of
        ``others``; None if there is none."""
        back = self.radius_m + self.spec.hold_m
        mouth = chain.zone[0]
        key, direction = chain.passages[0]
        turn = np.exp(2j * np.pi * np.arange(NEAR_POINTS) / NEAR_POINTS)
        for ring in NEAR_RINGS:
            cand = z + ring * self.pass_m * turn
            for s in cand[np.argsort(-np.abs(cand - mouth), kind="stable")].tolist():
                if abs(s - mouth) < back - 1e-6:
                    continue
                away = s - mouth
                to_left = 1j * away / abs(away)
                if not self.open_spot(s, to_left, key, direction):
                    continue
                if len(others) and np.abs(others - s).min() < keep_m:
                    continue
                return s
        return None
