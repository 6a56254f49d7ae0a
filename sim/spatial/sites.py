"""Task sites with room for more than one robot (collision avoidance on): service slots and
queues.

A site has a service point and up to ``slots`` service slots round it. :class:`Sites` lets
robots in to a free place, first come first served, holds the others in the site's queue
(drawn as waiting, not stuck), sends a robot that finds the service point taken to a slot, and
makes a robot that finished (or stands idle) near a site others come to step clear or drive
out past the crowd; one that finished where nobody comes pulls over in a narrow place.
:class:`~sim.spatial.jobs.Jobs` owns one and calls it on task events; the control period
(``sim.spatial.control``) asks it for slots when a robot near its site finds the service point
taken. Without collision avoidance robots push and none of this runs.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sim.scenario import SpatialSpec
from sim.spatial.controller import DiffDriveController
from sim.spatial.fleet import FleetState, Schedule
from sim.spatial.law.drive import next_check_s
from sim.spatial.navigation.paths import PathFollower
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.plane import (
    coming_to,
    exit_clearances,
    free_place,
    near_sites,
    queue_scan,
)
from sim.states import DRIVING, IDLE, WORKING

_TURNS = np.radians(np.arange(-150, 151, 30))  # a robot leaving a site: the ways out it tries,
TURNED = np.exp(1j * _TURNS)  # turned from straight away by these (Sites.leave)
TURNS_ABS = np.abs(_TURNS)


class Sites:
    """The service places and queues of the task sites, for a fleet of robots.

    Args:
        fleet: per-robot state, read and written in place (``site`` becomes the place a
            robot is let in to: its service point or a slot).
        schedule: the world's check schedule (a robot let in checks its site next period).
        follower: the robots' paths.
        planner: plans the ways to a place and out of a site.
        controller: the drive limits (robot radius).
        bodies: the robots' pymunk bodies (which way a robot on a service point faces).
        spatial: the world's spatial table (``[spatial.queue]``: slots and queues;
            ``[spatial.make_way]``: stepping aside).
        reach_m: robot centres closer than this are touching, m.
        broken: (m,) robots broken down (``sim.faults``), shared with the owner and written
            by the world in place; a broken robot steps nowhere.
        blocked: (m,) driving robots waiting for a repair (every way to their site blocked by
            broken robots), shared with the owner: they are not in a site's queue.
        refresh: brings the schedule up to date after an event
        (:meth:`sim.spatial.jobs.Jobs.refresh`).
        held: (m,) robots holding before a passage (``sim.spatial.traffic``), shared with the
            owner: the traffic rules decide where they wait, not a site's queue.

    Attributes (per robot, (m,)):
        service: the service point of its task (x + iy), m; ``fleet.site`` is its place.
        slotted: working toward a service slot.
        admitted: let in to its site: a place is kept for it.
        holding: holding in its site's queue; ``hold_since_s``: since when, s.
        queue_check_s: no robot can come within ``queue_m`` of its site before this, s.
    """

    def __init__(
        self,
        *,
        fleet: FleetState,
        schedule: Schedule,
        follower: PathFollower,
        planner: GridPlanner,
        controller: DiffDriveController,
        bodies: list,
        spatial: SpatialSpec,
        reach_m: float,
        broken: np.ndarray,
        blocked: np.ndarray,
        refresh: Callable[[], None],
        held: np.ndarray | None = None,
    ) -> None:
        self.fleet, self.schedule = fleet, schedule
        self.follower, self.planner, self.controller = follower, planner, controller
        self.bodies = bodies
        self.rules, self.stepping = spatial.queue, spatial.make_way
        self.reach_m = reach_m
        self.broken = broken
        self.blocked = blocked
        self.refresh = refresh
        m = len(fleet.state)
        self.held = np.zeros(m, dtype=bool) if held is None else held
        self.slotted = np.zeros(m, dtype=bool)
        self.service = fleet.site.copy()
        self.admitted = np.zeros(m, dtype=bool)
        self.holding = np.zeros(m, dtype=bool)
        self.hold_since_s = np.full(m, np.inf)
        self.queue_check_s = -np.inf
        self._places: dict[complex, np.ndarray] = {}  # service point and free slots per site

    def assign(self, j: int) -> None:
        """Robot j was given a task at ``fleet.site[j]``: its service point; no place, no
        queue yet."""
        self.slotted[j] = False
        self.service[j] = self.fleet.site[j]
        self.admitted[j] = self.holding[j] = False
        self.hold_since_s[j] = np.inf

    def release(self, j: int) -> None:
        """Robot j's task ended: it keeps no place and holds in no queue."""
        self.admitted[j] = self.holding[j] = False

    def take_slots(self, rows: list[int], z: np.ndarray, t: float) -> None:
        """Robots ``rows`` are near their site and not there: where a standing robot takes the
        service point, each goes to the nearest free service slot instead (``slots`` points on
        a ring two robot radii plus ``slot_gap_m`` around it, clear of obstacles, of standing
        robots and of the slots other robots drive to) and works there; with none free it
        waits where it is for the service point."""
        f, r = self.fleet, self.controller.radius_m
        ring, room = 2.0 * r + self.rules.slot_gap_m, 2.0 * r + 0.5 * self.rules.slot_gap_m
        standing = ((f.state != DRIVING) & ~f.yielding).nonzero()[0]
        changed, idle = False, []
        for j in rows:
            site = f.site[j]
            if self.slotted[j] or self.holding[j] or self.held[j]:
                continue  # a slot already, holding in the site's queue or before a passage
            if not len(standing) or np.abs(z[standing] - site).min() >= room:
                continue  # the service point is free
            on_it = standing[np.abs(z[standing] - site) < room]
            if (f.state[on_it] == IDLE).all():  # finished there: it steps clear
                idle += [int(b) for b in on_it if not f.yielding[b] and int(b) not in idle]
                continue
            cand = site + ring * np.exp(2j * np.pi * np.arange(self.rules.slots) / self.rules.slots)
            ok = self.planner.free(np.column_stack([cand.real, cand.imag]))
            ok &= np.abs(z[standing][:, None] - cand[None]).min(axis=0) >= room
            driving = (f.state == DRIVING).nonzero()[0]
            ok &= np.abs(f.site[driving][:, None] - cand[None]).min(axis=0) > 1e-6
            if not ok.any():
                continue
            k = int(np.where(ok, np.abs(cand - z[j]), np.inf).argmin())
            path = self.planner.path((z[j].real, z[j].imag), (cand[k].real, cand[k].imag))
            if not len(path):
                continue
            f.site[j] = cand[k]
            self.slotted[j] = True
            self.blocked[j] = False  # a robot waiting for a repair has a way to a slot
            self.follower.set_path(j, path)
            f.progress_m[j], f.t_progress_s[j] = np.inf, t
            changed = True
        if idle:
            self.step_clear(idle, t)
        if changed or idle:
            self.refresh()

    def queue(self, t: float) -> None:
        """Site queues (collision avoidance on). A driving robot not yet let in that is within
        ``queue_m`` of its site, or within ``crowd_m`` of a robot holding for that site, is let
        in while the site has a free place (its service point and obstacle-free slots, less
        the robots let in or at work there), first come first served; otherwise it holds
        where it is (a path to its own position; its stuck clock stopped, so it is drawn as
        waiting) until a place is free. Holding does not use up a task's time: the deadline
        of a robot let in after holding moves on by the time it held, and while it holds it
        has ``hold_max_s`` more. Schedules the next check."""
        driving, gap, near, coming, close_any, far = self._scan(t)
        if not driving.any():
            self.queue_check_s = np.inf
            return
        # robots hold or come in: look next period
        self.queue_check_s = t if close_any else self._later_s(far, t)
        rows = near.nonzero()[0]
        if len(rows):  # (robots let in or holding now: those whose sites are cleared change)
            self.let_in_or_hold(rows, gap, t)
            close = gap < self.rules.queue_m
            coming = driving & ((self.admitted & close) | self.holding)
        self.clear_loiterers(coming, t)

    def _scan(self, t: float) -> tuple:
        """The fleet as the queues see it at ``t`` (``sim.spatial.plane.queue_scan``): the
        robots driving (not backing off, replanning, waiting for a repair or held before a
        passage), each one's gap to its service point, those that ask for a place now, those
        whose sites idle robots clear, whether one is within ``queue_m`` and the least gap of
        the others."""
        f = self.fleet
        return queue_scan(
            f.state,
            DRIVING,
            f.backoff_until_s,
            f.replan,
            self.blocked,
            self.held,
            f.last_z_m,
            self.service,
            self.admitted,
            self.holding,
            t,
            self.rules.queue_m,
            self.rules.crowd_m,
        )

    def _later_s(self, far: float, t: float) -> float:
        """With no robot driving within ``queue_m`` of its site and the nearest ``far`` from
        its own: when it could first come that near, s."""
        closing = self.controller.speed_bound * self.follower.v_max_mps
        return next_check_s(t, far - self.rules.queue_m, closing)

    def later_check_s(self, t: float) -> float:
        """The next check :meth:`queue` sets at ``t`` when it finds some robot driving and none
        within ``queue_m`` of its site (the compiled control period's ``quiet.LATER``)."""
        return self._later_s(self._scan(t)[5], t)

    def let_in_or_hold(self, rows: np.ndarray, gap: np.ndarray, t: float) -> None:
        """:meth:`queue` for the robots ``rows`` near their sites (``gap`` m from them), first
        come first served per site."""
        f, z = self.fleet, self.fleet.last_z_m
        changed = False
        order = rows[np.lexsort((gap[rows], self.hold_since_s[rows]))]
        for j in order.tolist():
            place = self.free_place(j)
            if place is not None:
                changed |= self.let_in(j, place, t)
            elif not self.holding[j]:
                self.holding[j], self.hold_since_s[j] = True, t
                f.deadline_s[j] += (
                    self.rules.hold_max_s
                )  # waiting its turn does not run its clock out
                here = np.array([[z[j].real, z[j].imag]] * 2)
                self.follower.set_path(j, here)
                f.progress_m[j], f.t_progress_s[j] = -np.inf, np.inf  # no stuck clock
                changed = True
        if changed:
            self.refresh()

    def free_place(self, j: int) -> complex | None:
        """The place robot j would be given at its site now: the service point if free, else
        the free slot nearest to it; a place is taken when a robot let in to or at work at any
        site keeps a place, or a robot that is not driving (at work, idle, on its way out)
        stands, within two radii and half ``slot_gap_m`` of it (a site's own places are further
        apart than that, so a place kept for a site less than a slot ring away takes the places
        it overlaps). None if every place is taken."""
        f, r = self.fleet, self.controller.radius_m
        z, site = f.last_z_m, self.service[j]
        cand = self.place_points(site)
        keeping = self.admitted | (f.state == WORKING)
        keeping[j] = False
        room = 2.0 * r + 0.5 * self.rules.slot_gap_m
        # only a point this near the site in x and in y can be within room of one of its places
        # (each within a slot ring of it; the margin is far above any rounding)
        lim = 2.0 * r + self.rules.slot_gap_m + room + 1e-6
        k = free_place(
            cand, complex(site), f.site, keeping, z, f.state != DRIVING, lim, room, complex(z[j])
        )
        return None if k < 0 else complex(cand[k])

    def let_in(self, j: int, place: complex, t: float) -> bool:
        """Robot j goes to ``place`` (:meth:`free_place`) at its site now; one that held has its
        deadline moved on by the time it held. True if its path changed."""
        f, z, site = self.fleet, self.fleet.last_z_m, self.service[j]
        self.admitted[j] = True
        held = self.holding[j]
        if held:
            self.holding[j] = False
            f.deadline_s[j] += t - self.hold_since_s[j] - self.rules.hold_max_s
            self.hold_since_s[j] = np.inf
        if place == f.site[j] and not held:
            return False
        f.site[j] = place
        self.slotted[j] = place != site
        path = self.planner.path((z[j].real, z[j].imag), (place.real, place.imag))
        if len(path):
            self.follower.set_path(j, path)
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.schedule.site_check_s = -np.inf
        return True

    def place_points(self, site: complex) -> np.ndarray:
        """The places of ``site``: its service point, then its obstacle-free service slots
        (``slots`` on a ring two robot radii plus ``slot_gap_m`` round it), x + iy (cached)."""
        if site not in self._places:
            ring = 2.0 * self.controller.radius_m + self.rules.slot_gap_m
            cand = site + ring * np.exp(2j * np.pi * np.arange(self.rules.slots) / self.rules.slots)
            ok = self.planner.free(np.column_stack([cand.real, cand.imag]))
            self._places[site] = np.concatenate([[site], cand[ok]])
        return self._places[site]

    def clear_loiterers(self, coming: np.ndarray, t: float) -> None:
        """Idle robots standing within ``queue_m`` of a site that robots ``coming`` (a mask:
        let in to it, or holding in its queue) come to drive out (:meth:`leave`)."""
        f = self.fleet
        idle = (f.state == IDLE) & ~(f.yielding | self.broken)
        if not (idle.any() and coming.any()):
            return
        rows, reach = idle.nonzero()[0], self.rules.queue_m
        if not len(near_sites(f.last_z_m, rows, self.service[coming], reach, True)[0]):
            return  # no idle robot near such a site (the usual case): the test below, shorter
        sites = np.unique(self.service[coming])
        near, at = near_sites(f.last_z_m, rows, sites, reach, False)
        moved = False
        for j, k in zip(rows[near].tolist(), at.tolist(), strict=True):
            if not f.yielding[j]:
                moved |= self.leave(j, t, complex(sites[k]))
        if moved:
            self.refresh()

    def leave(self, j: int, t: float, site: complex | None = None) -> bool:
        """Robot j finished (or failed, or stands idle) near ``site`` (its task's by default)
        that other robots come to (within ``self.rules.queue_m + self.rules.exit_m``): it drives
        out, ``exit_m`` beyond ``queue_m`` from the site, to the free one of 11 end points (straight
        away from the site, then turned by 30 to 150 degrees either way) whose straight line
        passes farthest from the robots around it (clearances of two robot reaches and more
        count alike; then the least turned), so the next in the queue gets its place; a line
        closer than one reach to a robot let in to that site does not count (if none is left
        it stays, and is asked again). True if it drives out; the caller calls
        ``refresh``."""
        f, z = self.fleet, self.fleet.last_z_m[j]
        site = self.service[j] if site is None else site
        if abs(z - site) >= self.rules.queue_m or self.broken[j]:
            return False
        out_m = self.rules.queue_m + self.rules.exit_m
        coming, anyone = coming_to(f.state, DRIVING, self.service, f.last_z_m, site, out_m)
        if not anyone:
            return False
        away = z - site
        if abs(away) < 1e-3:
            away = -np.exp(1j * self.bodies[j].angle)
        away /= abs(away)
        ends = site + out_m * away * TURNED
        ok = self.planner.free(np.column_stack([ends.real, ends.imag]))
        # the straight way out that passes farthest from the robots around (ties: least
        # turned), and never straight at a robot driving in (let in, not holding): both would
        # stop (the clearances of :meth:`clearance`, of the robots around and of those of them
        # coming in, computed together)
        clear, clear_in = exit_clearances(
            complex(z), ends, f.last_z_m, j, out_m, coming, self.admitted
        )
        ok &= clear_in >= self.reach_m
        order = np.lexsort((TURNS_ABS, -np.minimum(clear, 2.0 * self.reach_m)))
        for k in order[ok[order]].tolist():
            path = self.planner.path((z.real, z.imag), (ends[k].real, ends[k].imag))
            if len(path):
                self.follower.set_path(j, path)
                f.yielding[j], f.yield_until_s[j] = True, t + self.rules.exit_timeout_s
                return True
        return False

    def pull_over(self, j: int, t: float) -> bool:
        """Robot j, idle where no robot comes to its site, stands in a narrow place (less than
        ``make_way.pull_room_m`` between its body and the nearest obstacle): it pulls over toward
        that obstacle to ``make_way.pull_gap_m`` of air, so a robot can pass it. True if it drives
        there; the caller calls ``refresh``."""
        f, r = self.fleet, self.controller.radius_m
        z = complex(f.last_z_m[j])
        if self.broken[j]:
            return False
        ob = complex(self.follower.to_obstacle(np.array([z]))[0])
        d = abs(ob)
        if not np.isfinite(d) or not (
            self.stepping.pull_gap_m + 0.05 < d - r < self.stepping.pull_room_m
        ):
            return False
        end = z + ob / d * (d - r - self.stepping.pull_gap_m)
        if not self.planner.free_one(end.real, end.imag):
            return False
        others = np.delete(f.last_z_m, j)
        if len(others) and np.abs(others - end).min() < 2.0 * r + self.rules.slot_gap_m:
            return False
        path = self.planner.path((z.real, z.imag), (end.real, end.imag))
        if not len(path):
            return False
        self.follower.set_path(j, path)
        f.yielding[j], f.yield_until_s[j] = True, t + self.stepping.timeout_s
        return True

    @staticmethod
    def clearance(z: complex, ends: np.ndarray, others: np.ndarray) -> np.ndarray:
        """(len(ends),) how close the points ``others`` come to each segment from ``z`` to an
        end, m (inf without others)."""
        if not len(others):
            return np.full(len(ends), np.inf)
        seg = ends - z
        u = ((others[None, :] - z) * seg.conj()[:, None]).real / np.abs(seg)[:, None] ** 2
        near = z + np.clip(u, 0.0, 1.0) * seg[:, None]
        return np.abs(others[None, :] - near).min(axis=1)

    def step_clear(self, rows: list[int], t: float) -> None:
        """Idle robots ``rows`` stand on a service point another robot comes for: each steps
        ``make_way.step_m`` aside (to the left or right of its heading, whichever is free); one
        with no free step stays where it is. The caller calls ``refresh``."""
        f, z = self.fleet, self.fleet.last_z_m
        steps, paths = [], []
        for j in rows:
            if self.broken[j]:  # a broken robot cannot step anywhere
                continue
            travel = np.exp(1j * self.bodies[j].angle)
            close = np.abs(z - z[j]) < 2.0 * self.stepping.step_m
            close[j] = False
            path = self.planner.side_step(
                z[j], z[j] - travel, travel, self.stepping.step_m, z[close]
            )
            if len(path):
                steps.append(j)
                paths.append(path)
                f.yielding[j], f.yield_until_s[j] = True, t + self.stepping.timeout_s
        self.follower.set_paths(steps, paths)

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The per-robot site state and the next queue check (a checkpoint's part)."""
        return {
            "slotted": self.slotted.copy(),
            "service": self.service.copy(),
            "admitted": self.admitted.copy(),
            "holding": self.holding.copy(),
            "hold_since_s": self.hold_since_s.copy(),
            "queue_check_s": np.array(self.queue_check_s),
        }

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays`; checkpoints written before site queues existed
        hold only ``slotted``: nobody queued."""
        self.slotted = np.array(arrays["slotted"], dtype=bool)
        m = len(self.slotted)
        self.service = np.array(arrays.get("service", self.fleet.site), dtype=complex)
        self.admitted = np.array(arrays.get("admitted", np.zeros(m)), dtype=bool)
        self.holding = np.array(arrays.get("holding", np.zeros(m)), dtype=bool)
        self.hold_since_s = np.array(arrays.get("hold_since_s", np.full(m, np.inf)), dtype=float)
        self.queue_check_s = float(arrays.get("queue_check_s", -np.inf))
