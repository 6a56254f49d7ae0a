"""The traffic rules for single-lane passages, run once per control period (avoidance on,
``[spatial.traffic] rules = "on"``).

Every driving robot's path is annotated with the chains of passages it crosses
(``sim.spatial.traffic.annotate``) whenever the path changes, and again when a robot near its
way ahead begins or ends work (a temporary passage may come or go there). A robot
``request_m`` before a chain asks for it (``sim.spatial.traffic.locks``); it is let in when
every passage of the chain is free or used its way and no standing robot (at work, idle, or
holding) is on its way through the chain or within a radius plus ``exit_clear_m`` beyond its
exit. A robot kept out holds at a holding point before the mouth, aside of the lane where there
is room, its stuck clock stopped (drawn as waiting, counted by the stall meter as holding in a
queue); its deadline moves on by the time it held. It frees each passage once its centre is a
radius plus ``release_m`` past it. A robot held ``hold_max_s`` drives on without the lock, and
the jam rules (``sim.spatial.jams``) remain the fallback for whatever the locks do not prevent.
A period in which no robot began or stopped driving or working, no path was given or cleared
and the rules follow no robot returns at once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sim.scenario import SpatialSpec
from sim.spatial.controller import DiffDriveController
from sim.spatial.fleet import FleetState
from sim.spatial.navigation.paths import PathFollower
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.plane import ways_near, workers_by_way
from sim.spatial.sites import Sites
from sim.spatial.traffic.annotate import Chain, chains, crossings, left_along
from sim.spatial.traffic.geometry import path_gaps
from sim.spatial.traffic.locks import Locks
from sim.spatial.traffic.network import PassageMap
from sim.states import DRIVING, IDLE, WORKING

COUNTS = ("holds", "hold_s", "gave_up", "temporary", "round", "spot_near")  # (Locks has more)
ROUND_AIR_M = 0.02  # a way planned round a robot at work keeps this much more than a body, m
DETOUR_M = 0.2  # a path this much longer than the shortest is a detour another rule chose, m
FEW_ROWS = 16  # up to this many robots' paths are compared in plain Python (Traffic._new_paths)


class Traffic:
    """The traffic rules of a fleet of robots.

    Args:
        fleet: per-robot state, read and written in place.
        sites: the sites' service points and queues (a robot holding there stands).
        follower: the robots' paths.
        planner: plans the ways to holding points and on from them.
        controller: the drive limits (robot radius).
        spatial: the world's spatial table (``[spatial.traffic]``, ``orca.margin_m``,
            ``clearance_m``).
        held: (m,) robots holding before a passage, shared with the owner and written here.
        refresh: brings the schedule up to date after an event.
        clear_way: ``clear_way(k, j, way, t)`` asks idle robot k to step off ``way``, robot
            j's way through the passage it holds for; True if it does
            (:meth:`sim.spatial.jobs.Jobs.clear_way`).

    Attributes:
        map: the passages (:class:`sim.spatial.traffic.network.PassageMap`).
        locks: the directional locks (:class:`sim.spatial.traffic.locks.Locks`).
        counts: ``holds`` (robots kept out), ``hold_s`` (seconds held), ``gave_up`` (holds
            past ``hold_max_s``), ``temporary`` (passages made by robots at work), ``round``
            (ways planned round robots at work), ``spot_near`` (holds at a point round the
            robot, none being on its way: ``PassageMap.spot_near``).
    """

    def __init__(
        self,
        *,
        fleet: FleetState,
        sites: Sites,
        follower: PathFollower,
        planner: GridPlanner,
        controller: DiffDriveController,
        spatial: SpatialSpec,
        held: np.ndarray,
        refresh: Callable[[], None],
        clear_way: Callable[[int, int, np.ndarray, float], bool] | None = None,
    ) -> None:
        self.fleet, self.sites, self.follower, self.planner = fleet, sites, follower, planner
        self.spec = spec = spatial.traffic
        self.refresh, self.clear_way = refresh, clear_way
        self.radius_m = controller.radius_m
        self.map = PassageMap(spatial, self.radius_m, planner)
        self.pass_extra_m = spatial.jams.pass_extra_m
        self.near_m = self.map.pass_m  # a standing robot this near a way blocks it
        self.locks = Locks(spec.turn_s)
        m = len(fleet.state)
        self.held = held
        self.hold_since_s = np.full(m, np.inf)
        self.hold_at = np.zeros(m, dtype=complex)
        self.aside = np.zeros(m, dtype=bool)  # holding at a point that leaves a robot room
        self.blockers: dict[int, list[int]] = {}  # robots standing in each one's way, last look
        self.chains: list[list[Chain]] = [[] for _ in range(m)]
        self.chained: set[int] = set()  # every robot with a chain ahead (and some without)
        self.granted: list[Chain | None] = [None] * m  # the chain each robot may go through
        self.gave_up: list[frozenset[int]] = [frozenset()] * m
        self.sig = np.zeros((4, m), dtype=complex)  # the path each robot was annotated on
        self.sig[3] = np.nan
        self.sig_sets = np.full(m, -1)  # the follower's sets_ of each when last compared
        self.renewed = np.zeros(m, dtype=bool)  # its path differs from sig, at that look
        self.working = np.zeros(m, dtype=bool)
        self.driving = np.zeros(m, dtype=bool)  # who drove at the last full period
        self.paths_seen = -1  # the follower's paths_set_ when the last period began
        self.state_seen = b""  # the fleet's states (bytes) when the last full period began
        self.counts = dict.fromkeys(COUNTS, 0.0)

    # -- one control period ---------------------------------------------------------------
    def period(self, t: float) -> None:
        """Annotate changed paths, free passages left behind, ask, grant, hold."""
        f = self.fleet
        paths_set, self.paths_seen = self.paths_seen, self.follower.paths_set_
        if paths_set == self.paths_seen and self._still():
            return  # the quick form of the test below: no state changed since a full period
        drive = f.state == DRIVING
        work = f.state == WORKING
        moved = (work != self.working).any()
        if not moved and paths_set == self.paths_seen and self._quiet(drive):
            return  # nothing the rules follow, no path given or cleared, no one began driving
        self.driving = drive
        self.state_seen = f.state.tobytes()
        touched = np.zeros(len(drive), dtype=bool)
        if moved:
            changed = (work != self.working).nonzero()[0]
            self.working = work.copy()
            on = self.spec.at_work == "on"
            dropped, made, near = self.map.update_workers(changed, work & on, f.last_z_m)
            for key in dropped:
                self.locks.drop_passage(key)
            self.counts["temporary"] += made
            began = changed[work[changed]] if on else changed[:0]
            spots = ((f.last_z_m[near], self.map.reach_m), (f.last_z_m[began], self.map.pass_m))
            touched = self._touched(drive, spots, set(dropped))
        for j in [j for j in self._active() if not drive[j]]:
            self._drop(j, t)
        changed = touched
        changed[self._new_paths()] = True
        changed &= drive
        for j in changed.nonzero()[0].tolist():
            if self.held[j] and not moved:
                self._unhold(j, t, replan=False)  # another rule gave it a path
            if not self.held[j]:
                self.annotate(j, t)
        for j in [j for j in self._active() if drive[j] and not self.held[j]]:
            self._step(j, t)
        for j in self.locks.grant(t, self._ready):
            self.granted[j] = self.chains[j][0]
            if self.held[j]:
                self._unhold(j, t, replan=True)
        for j in list(self.locks.requests):
            if not self.held[j] and f.state[j] == DRIVING:
                self._hold(j, t)
            elif self.clear_way is not None:  # idle robots standing in its way step off it
                idle = [k for k in self.blockers.get(j, []) if f.state[k] == IDLE]
                for k in idle:
                    self.clear_way(k, j, self.chains[j][0].zone, t)
        late = self.held & (t - self.hold_since_s >= self.spec.hold_max_s)
        for j in late.nonzero()[0].tolist():
            self.gave_up[j] = self.chains[j][0].keys if self.chains[j] else frozenset()
            self.locks.cancel(j)
            self.counts["gave_up"] += 1
            self._unhold(j, t, replan=True)

    def _still(self) -> bool:
        """True if every robot's state is what it was when the last full period began and the
        rules follow none: :meth:`_quiet` then holds and no robot began or ended work (at a
        full period ``working`` and ``driving`` are set from that state), in fewer steps."""
        return self._follow_none() and self.fleet.state.tobytes() == self.state_seen

    def _quiet(self, drive: np.ndarray) -> bool:
        """True if no robot began or stopped driving since the last period and the rules
        follow none: then a period changes nothing."""
        return self._follow_none() and not (drive != self.driving).any()

    def _follow_none(self) -> bool:
        """True if the rules follow no robot: no lock, request, hold or chain ahead."""
        locks = self.locks  # (np.count_nonzero: quicker than ndarray.any on a small array)
        if locks.occupants or locks.requests or np.count_nonzero(self.held):
            return False
        return not any(self.chains[j] for j in self.chained)

    def _active(self) -> list[int]:
        """The robots the rules follow, in order: with a chain ahead, a lock, a request or
        holding (a few: found as a set, not as a mask of the fleet)."""
        self.chained = {j for j in self.chained if self.chains[j]}
        out = self.chained | set(self.locks.requests)
        out.update(self.held.nonzero()[0].tolist())
        for occ in self.locks.occupants.values():
            out.update(occ)
        return sorted(out)

    def _touched(self, drive: np.ndarray, spots, dropped: set[int]) -> np.ndarray:
        """(m,) driving robots whose annotation may change after robots began or ended work:
        their way ahead (from where they are along their path) passes within ``reach`` of one
        of the ``spots`` (pairs of points and reach: the robots whose temporary passage came,
        went or changed, within ``PassageMap.reach_m``, as a passage or a holding point in one
        may lie there; the robots that began work, within a pass, as a way may go round them),
        or a chain ahead of them holds a passage ``dropped``."""
        out = np.zeros(len(drive), dtype=bool)
        fol, z = self.follower, self.fleet.last_z_m
        ways = drive & (fol.last >= 0)
        rows = ways.nonzero()[0]
        if not len(rows):
            return out
        for points, reach in spots:
            if len(points):
                points = np.ascontiguousarray(points, dtype=complex)
                out[rows[ways_near(points, reach, rows, z, fol.points, fol.index)]] = True
        if dropped:  # (a robot with a chain ahead is in ``chained``)
            for j in self.chained:
                if ways[j] and any(c.keys & dropped for c in self.chains[j]):
                    out[j] = True
        return out

    def _new_paths(self, few: int = FEW_ROWS) -> list[int]:
        """The robots whose path is not the one they were last annotated on (first and last
        point, last index or length differ from ``sig``), in order. Compared again only for
        the robots given a path or cleared since the last look (the follower's ``sets_``
        against ``sig_sets``); the others keep their answer (``renewed``). Up to ``few`` such
        robots are compared one by one in plain Python (the same comparisons, without numpy's
        overhead per array)."""
        fol = self.follower
        rows = (fol.sets_ != self.sig_sets).nonzero()[0]
        if len(rows) > few:
            last = fol.last[rows]
            end = fol.points[rows, np.maximum(last, 0)]
            sig = np.stack([fol.points[rows, 0], end, last.astype(complex), fol.after_m[rows, 0]])
            self.renewed[rows] = (sig != self.sig[:, rows]).any(axis=0)
            self.sig_sets[rows] = fol.sets_[rows]
        else:
            points, old = fol.points, self.sig
            for j in rows.tolist():
                last = int(fol.last[j])
                self.renewed[j] = (
                    points[j, 0] != old[0, j]
                    or points[j, max(last, 0)] != old[1, j]
                    or last != old[2, j]
                    or fol.after_m[j, 0] != old[3, j]
                )
                self.sig_sets[j] = fol.sets_[j]
        return self.renewed.nonzero()[0].tolist()

    def _step(self, j: int, t: float) -> None:
        """Robot j (driving, not holding): drop the chains it has passed and free the
        passages it has left; in its granted chain, free each passage once past it; take a
        chain it is in already; ask for the next one within ``request_m``."""
        z, done = complex(self.fleet.last_z_m[j]), self.radius_m + self.spec.release_m
        left = self._left(j)
        ahead = self.chains[j]
        while ahead and left < ahead[0].exit_left_m - done:
            ahead.pop(0)
        have = self.locks.held_by(j)
        chain = ahead[0] if ahead else None
        if chain is not None and self.granted[j] is chain:
            passed = zip(chain.passages, chain.exits_left_m, strict=True)
            keep = {k for (k, _), out in passed if left >= out - done}
        else:
            keep = set(chain.keys) if chain is not None else set()
        self.locks.release(j, [k for k in have - keep if not self._inside(k, z)])
        if chain is None or self.granted[j] is chain:
            self.locks.cancel(j)
            return
        if left <= chain.entry_left_m + 1e-6:
            self.locks.force(j, chain.passages)  # in it already: keep others out
            self.granted[j] = chain
        elif left - chain.entry_left_m <= self.spec.request_m and chain.keys != self.gave_up[j]:
            part = [k for k in have & chain.keys if not self._inside(k, z)]
            self.locks.release(j, part)  # all or nothing
            self.locks.request(j, chain.passages, t)

    def _left(self, j: int) -> float:
        """Path left from robot j's position along its path as it is now, m (``left_m`` may
        belong to a path another rule set since the control period measured it)."""
        fol = self.follower
        if fol.last[j] < 0:
            return 0.0
        i = int(fol.index[j])
        return float(abs(fol.points[j, i] - self.fleet.last_z_m[j]) + fol.after_m[j, i])

    def _ready(self, j: int) -> bool:
        """Robot j may enter its chain: no standing robot (not driving, or holding) is within
        two radii and margins of its way through it and beyond its exit."""
        f = self.fleet
        if not self.chains[j]:
            return True
        chain = self.chains[j][0]
        stand = (f.state != DRIVING) | (self.held & ~self.aside) | self.sites.holding
        stand[j] = False
        for key in chain.keys:
            p = self.map.passages.get(key)
            if p is not None and p.worker >= 0 and p.passable:
                stand[p.worker] = False  # the robot at work a passable passage goes past
        rows = stand.nonzero()[0]
        zone = chain.zone
        if not len(rows) or len(zone) < 2:
            self.blockers.pop(j, None)
            return True
        block = rows[path_gaps(f.last_z_m[rows], zone) < self.near_m]
        self.blockers[j] = block.tolist()
        return not len(block)

    def _inside(self, key: int, z: complex) -> bool:
        """True if point z is in passage ``key`` or within a radius plus ``release_m`` of its
        ends (False for a passage that is gone)."""
        return self.map.inside(key, z, self.radius_m + self.spec.release_m)

    # -- paths ----------------------------------------------------------------------------
    def annotate(self, j: int, t: float, round_workers: bool = True) -> None:
        """Robot j's chains ahead from its path as it is now (none without a path); a path
        through robots at work is planned round them first (:meth:`_round_workers`)."""
        fol, f = self.follower, self.fleet
        self._keep_sig(j)
        last = int(fol.last[j])
        if last < 0:
            self.chains[j], self.granted[j] = [], None
            return
        pts = np.concatenate([[f.last_z_m[j]], fol.points[j, int(fol.index[j]) : last + 1]])
        if round_workers and self._round_workers(j, pts, t):
            return self.annotate(j, t, round_workers=False)
        found = crossings(pts, self.map.for_robot(j, complex(pts[-1]), self.sites.service, pts))
        clear = self.radius_m + self.spec.exit_clear_m

        def roomy(a, b) -> bool:
            return self.map.room_between(pts, a, b)

        ahead = self.chains[j] = chains(pts, found, self.spec.chain_m, clear, roomy)
        if ahead:
            self.chained.add(j)
        mine = ahead and ahead[0].keys <= self.locks.held_by(j)
        self.granted[j] = ahead[0] if mine else None

    def _round_workers(self, j: int, pts: np.ndarray, t: float) -> bool:
        """Robot j's path ``pts`` runs through robots at work (closer than a pass to them; not
        one within a pass of its end, at the place it goes to; at its own site only one in an
        aisle, ``PassageMap.narrowed_by_walls``: in a crowd on open floor the site's queue
        decides): plan it round them
        (``GridPlanner.path_around``, each a body, so the way is the lane beside it) and take
        that way if it is at most ``jams.pass_extra_m`` longer, or its extra length at top
        speed takes less than the work left of one that closes its aisle. True if the path
        changed."""
        f, r = self.fleet, self.radius_m
        if self.spec.at_work != "on":
            return False
        pass_m = self.map.pass_m
        # those outside the way's box grown by a pass cannot be near it
        rows, same = workers_by_way(
            self.working.nonzero()[0], f.last_z_m, pts, pass_m, self.sites.service, j
        )
        other = ~same
        for k in same.nonzero()[0].tolist():
            other[k] = self.map.narrowed_by_walls(int(rows[k]))  # its own site's, in an aisle
        other &= rows != j
        rows = rows[other]
        if not len(rows):
            return False
        gap = path_gaps(f.last_z_m[rows], pts)
        near_end = np.abs(f.last_z_m[rows] - pts[-1]) < pass_m
        rows = rows[(gap < pass_m - 1e-3) & ~near_end]
        if not len(rows):
            return False
        z = complex(pts[0])
        site = (f.site[j].real, f.site[j].imag)
        plain = self.planner.path((z.real, z.imag), site)
        length = left_along(pts)[0]
        if (
            not len(plain)
            or _length_m(plain) < length - DETOUR_M
            or abs(complex(*site) - pts[-1]) > 1e-6
        ):
            return False  # a way another rule chose (going round, giving way): left as it is
        path = self.planner.path_around((z.real, z.imag), site, f.last_z_m[rows], r + ROUND_AIR_M)
        if not len(path):
            return False
        extra = _length_m(path) - length
        closed = [w for w in rows.tolist() if not self.map.passable(w)]
        wait_s = max((f.work_end_s[w] - t for w in closed), default=0.0)
        if extra > self.pass_extra_m and extra / self.follower.v_max_mps >= wait_s:
            return False
        self.follower.set_path(j, path)
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.counts["round"] += 1
        self.refresh()
        return True

    def _keep_sig(self, j: int) -> None:
        fol = self.follower
        last = int(fol.last[j])
        self.sig[:, j] = [fol.points[j, 0], fol.points[j, max(last, 0)], last, fol.after_m[j, 0]]
        self.sig_sets[j], self.renewed[j] = fol.sets_[j], False

    # -- holding --------------------------------------------------------------------------
    def _hold(self, j: int, t: float) -> None:
        """Robot j was kept out of its chain: it drives to a holding point (:meth:`_spot`) and
        waits there, its stuck clock stopped, its deadline moved on ``hold_max_s`` for now."""
        f, spec = self.fleet, self.spec
        z = complex(f.last_z_m[j])
        spot = self._spot(j)
        path = None
        if spot is not None:
            path = self.planner.path((z.real, z.imag), (spot.real, spot.imag))
        if path is None or not len(path):
            spot, path = z, np.array([[z.real, z.imag]] * 2)
        self.follower.set_path(j, path)
        self._keep_sig(j)
        self.held[j], self.hold_since_s[j], self.hold_at[j] = True, t, spot
        self.aside[j] = spot != z
        f.progress_m[j], f.t_progress_s[j] = -np.inf, np.inf  # no stuck clock
        f.deadline_s[j] += spec.hold_max_s
        self.counts["holds"] += 1
        self.refresh()

    def _spot(self, j: int) -> complex | None:
        """Robot j's holding point before its chain (``PassageMap.spot``, else one round it:
        ``PassageMap.spot_near``), clear of the other robots and of the points others hold
        at; None if there is none."""
        fol = self.follower
        last = int(fol.last[j])
        if last < 0:
            return None
        z = complex(self.fleet.last_z_m[j])
        pts = np.concatenate([[z], fol.points[j, int(fol.index[j]) : last + 1]])
        others = np.concatenate([np.delete(self.fleet.last_z_m, j), self.hold_at[self.held]])
        chain, keep_m = self.chains[j][0], self.near_m + 0.1
        spot = self.map.spot(pts, chain, others, keep_m)
        if spot is None:  # none on its way: look round it rather than stand in the lane out
            spot = self.map.spot_near(z, chain, others, keep_m)
            self.counts["spot_near"] += spot is not None
        return spot

    def _unhold(self, j: int, t: float, replan: bool) -> None:
        """Robot j stops holding: its deadline counts the time it held; with ``replan`` it
        plans its way on from where it is and drives."""
        f = self.fleet
        held_s = t - self.hold_since_s[j]
        self.held[j], self.hold_since_s[j], self.aside[j] = False, np.inf, False
        self.blockers.pop(j, None)
        self.counts["hold_s"] += held_s
        f.deadline_s[j] += held_s - self.spec.hold_max_s
        if replan:
            z = complex(f.last_z_m[j])
            path = self.planner.path((z.real, z.imag), (f.site[j].real, f.site[j].imag))
            if len(path):
                self.follower.set_path(j, path)
            f.progress_m[j], f.t_progress_s[j] = np.inf, t
            self.annotate(j, t)
            self.refresh()

    def _drop(self, j: int, t: float) -> None:
        """Robot j no longer drives (it works, or its task ended): no lock, no request."""
        if self.held[j]:
            self._unhold(j, t, replan=False)
        self.locks.release_all(j)
        self.chains[j], self.granted[j] = [], None
        self.gave_up[j] = frozenset()

    # -- outputs --------------------------------------------------------------------------
    def summary(self) -> dict[str, float]:
        """``traffic_<count>``: the locks' and this module's counts since reset, and
        ``traffic_passages`` (the geometry's passages)."""
        out = {"traffic_passages": self.map.n_static}
        out |= {f"traffic_{k}": v for k, v in self.locks.counts().items()}
        out |= {f"traffic_{k}": v for k, v in self.counts.items()}
        return out

    def count_array(self) -> np.ndarray:
        """The counts as one array (a checkpoint's part), in :meth:`summary`'s order."""
        return np.array([*self.locks.counts().values(), *self.counts.values()], dtype=float)

    def restore_counts(self, arr: np.ndarray) -> None:
        """Inverse of :meth:`count_array`."""
        arr = np.asarray(arr, dtype=float)
        locks = self.locks
        locks.granted, locks.forced, locks.turns, locks.turns_forced = (int(x) for x in arr[:4])
        self.counts = dict(zip(COUNTS, arr[4:].tolist(), strict=True))


def _length_m(path: np.ndarray) -> float:
    """Length of a path of (P, 2) points, m."""
    return float(np.abs(np.diff(path[:, 0] + 1j * path[:, 1])).sum())
