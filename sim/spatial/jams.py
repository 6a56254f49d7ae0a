"""Jams between driving robots (collision avoidance on): going round, giving way, passing a
robot at work.

No robot pushes under collision avoidance, so robots that stop each other must act.
:class:`Jams` holds the rules: a robot stuck among others plans round them
(:meth:`Jams.go_round`) or, in a deadlock, the one that can backs out (:meth:`Jams.give_way`);
a robot standing beside one at work for another site goes round it (:meth:`Jams.pass_workers`),
and, with ``[spatial] look_ahead = "on"``, a robot whose way runs past one at work that will
still be there when it comes plans round it beforehand, if that is quicker than waiting
(:meth:`Jams.look_ahead`);
a jam in a single-lane place, or two robots standing together alone, is acted on after
``pass_s`` rather than at the stuck timeout (:meth:`Jams.break_jams`).
:class:`~sim.spatial.jobs.Jobs` owns one: its stuck recovery calls the first two, and the pymunk
world calls the last two after each control period.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sim.scenario import SpatialSpec
from sim.spatial.controller import DiffDriveController
from sim.spatial.fleet import FleetState
from sim.spatial.navigation.paths import PathFollower
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.plane import way_waits
from sim.spatial.sites import Sites
from sim.spatial.stalls import nearest_other
from sim.states import DRIVING, WORKING

# the rules, as counted (Jams.fired): a jam acted on at once, a way round taken, a wait for one
# of the jam that went round, a back-out, a wait for the one backing out, a way round a robot
# at work, a way planned past robots at work ahead
JAM_RULES = (
    "break_jams",
    "go_round",
    "wait_round",
    "give_way",
    "wait_give_way",
    "pass_workers",
    "look_ahead",
)

SMALL = 64  # an array of at most this many entries is reduced in plain Python (quicker)


def _least(a: np.ndarray) -> float:
    """The least entry of a float array without NaN (as ``float(a.min())``)."""
    return min(a.tolist()) if len(a) <= SMALL else float(a.min())


class Jams:
    """The jam rules for a fleet of robots.

    Args:
        fleet: per-robot state, read and written in place.
        sites: the sites' queues (a robot holding in one is not in a jam).
        follower: the robots' paths.
        planner: plans the ways round robots and back.
        controller: the drive limits (robot radius).
        spatial: the world's spatial table (``[spatial.jams]``: the rules' distances and times;
            ``max_recoveries``: tries, shared with the stuck recovery).
        refresh: brings the schedule up to date after an event
        (:meth:`sim.spatial.jobs.Jobs.refresh`).
        held: (m,) robots holding before a passage (``sim.spatial.traffic``), shared with the
            owner: like a robot holding in a site's queue, not in a jam.

    Attributes:
        fired: how often each rule acted since reset, by name (``JAM_RULES``).

    Attributes (per robot, (m,)):
        origin: where it was given its task (x + iy), m: a robot that gives way backs out
            toward it.
        around_s: when it last planned round others, s.
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
        refresh: Callable[[], None],
        held: np.ndarray | None = None,
    ) -> None:
        self.fleet, self.sites = fleet, sites
        self.follower, self.planner, self.controller = follower, planner, controller
        self.spatial = spatial
        self.rules = spatial.jams
        self.refresh = refresh
        m = len(fleet.state)
        self.held = np.zeros(m, dtype=bool) if held is None else held
        self.fired = dict.fromkeys(JAM_RULES, 0)
        self.origin = fleet.site.copy()
        self.around_s = np.full(m, -np.inf)
        self.due = np.zeros(m, dtype=bool)  # look_ahead: robots given a task ...
        self.began = np.zeros(m, dtype=bool)  # ... and robots that began work, since the last

    def go_round(self, j: int, t: float) -> bool:
        """Robot j is stuck among other robots (collision avoidance on; within ``around_m``):
        it plans a path to its site with them as obstacles (``GridPlanner.path_around``) and
        takes it if it is at most ``detour_factor`` times the path it had plus
        ``detour_extra_m``, counting a try. If one of them has just done so in this check, j
        waits one stuck timeout for it instead. False, and nothing changes, when no robot is
        near, j has used its tries or no such path exists (then :meth:`give_way`)."""
        f, z = self.fleet, self.fleet.last_z_m
        close = np.abs(z - z[j]) < self.rules.around_m
        close[j] = False
        if not close.any() or f.recoveries[j] >= self.spatial.max_recoveries:
            return False
        if (self.around_s[close] == t).any():  # another of this jam just went round
            f.t_progress_s[j] = t
            self.fired["wait_round"] += 1
            return True
        site = (f.site[j].real, f.site[j].imag)
        path = self.planner.path_around(
            (z[j].real, z[j].imag), site, z[close], self.controller.radius_m
        )
        if not len(path):
            return False
        length = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
        if length > self.rules.detour_factor * f.left_m[j] + self.rules.detour_extra_m:
            return False
        f.recoveries[j] += 1
        self.around_s[j] = t
        self.follower.set_path(j, path)
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.fired["go_round"] += 1
        self.refresh()
        return True

    def look_ahead(self, t: float) -> None:
        """Collision avoidance on and ``[spatial] look_ahead = "on"`` (the world calls it
        before a control period's jam rules): robot-aware planning.
        A robot given a task (``due``), or one whose way a robot that began work (``began``)
        blocks, is looked at (the marks are cleared): if it drives toward its place (not
        holding in a queue or let in at its site) and its way passes within ``ahead_block_m``
        of a robot at work for another site, at a point more than that far along it (ahead,
        not beside it already: :meth:`pass_workers`), that will still work more than
        ``ahead_wait_s`` when it gets there at top speed, it plans its way round the robots
        at work at other sites within ``around_m`` of its way, each grown by
        ``ahead_grow_m`` (``GridPlanner.path_around``), and takes that way if its extra
        length at top speed takes less than the longest such wait. Without it a robot drives
        up to one at work in a 2 m aisle, where ORCA leaves a band of about 10 cm to pass
        in, and stands there."""
        if not (np.count_nonzero(self.due) or np.count_nonzero(self.began)):
            return  # (count_nonzero: quicker than any() on a small array, once a period)
        f, fol, z = self.fleet, self.follower, self.fleet.last_z_m
        drive = (f.state == DRIVING) & ~f.replan & (f.backoff_until_s <= t)
        drive &= ~self.sites.holding & ~self.sites.admitted & (fol.last >= 0)
        look = self.due & drive
        began = (self.began & (f.state == WORKING)).nonzero()[0]
        self.due[:] = self.began[:] = False
        work = (f.state == WORKING).nonzero()[0]
        if not len(work):
            return
        if len(began) and drive.any():  # whose way a robot that began work blocks
            rows = drive.nonzero()[0]
            look[rows[self.waits(rows, began, t)[0].max(axis=1) > self.rules.ahead_wait_s]] = True
        rows = look.nonzero()[0]
        if not len(rows):
            return
        v_max, radius = fol.v_max_mps, self.controller.radius_m
        wait, _, gap = self.waits(rows, work, t)
        for row in (wait.max(axis=1) > self.rules.ahead_wait_s).nonzero()[0].tolist():
            j = int(rows[row])
            site = (f.site[j].real, f.site[j].imag)
            start = (z[j].real, z[j].imag)
            round_them = z[work[gap[row] < self.rules.around_m]]
            path = self.planner.path_around(
                start, site, round_them, radius + self.rules.ahead_grow_m
            )
            if not len(path):
                continue
            length = float(np.abs(np.diff(path[:, 0] + 1j * path[:, 1])).sum())
            if (length - self.way_left_m(j)) / v_max >= wait[row].max():
                continue
            fol.set_path(j, path)
            f.progress_m[j], f.t_progress_s[j] = np.inf, t
            self.fired["look_ahead"] += 1
            self.refresh()

    def way_left_m(self, j: int) -> float:
        """Length of robot j's way from where it is along the rest of its path, m."""
        fol, i = self.follower, int(self.follower.index[j])
        return float(abs(fol.points[j, i] - self.fleet.last_z_m[j]) + fol.after_m[j, i])

    def waits(self, rows: np.ndarray, work: np.ndarray, t: float):
        """For robots ``rows`` and robots at work ``work``, each (n, w): how long each would wait
        for each (work left after getting there along its way at top speed; 0 where the way
        does not pass within ``ahead_block_m``, or the robot at work is at its own site), the
        way's length to the point nearest it, m, and how near the way passes it (inf: it
        works at the robot's own site), m."""
        f, fol, z, service = self.fleet, self.follower, self.fleet.last_z_m, self.sites.service
        return way_waits(
            fol.points[rows],
            fol.index[rows],
            fol.last[rows],
            fol.after_m[rows],
            z[rows],
            service[rows],
            z[work],
            service[work],
            f.work_end_s[work],
            float(t),
            float(fol.v_max_mps),
            float(self.rules.ahead_block_m),
        )

    def standing_near(self, t: float) -> list[tuple[int, int]]:
        """Collision avoidance on: (j, k) for each driving robot j commanded to stand (below
        ``stalls.still_mps``; not holding in a queue, backing off or replanning) for ``pass_s``
        since its last progress whose nearest robot k is within ``stalls.near_m``. Found once per
        control period for :meth:`pass_workers` and :meth:`break_jams` (the nearest-robot search is
        a k-d tree over the fleet in a large team)."""
        f = self.fleet
        if t - _least(f.t_progress_s) < self.rules.pass_s:
            return []
        still = (
            (f.state == DRIVING)
            & (np.abs(f.v_cmd_mps) < self.spatial.stalls.still_mps)
            & ~self.sites.holding
            & ~self.held
        )
        still &= ~f.replan & (f.backoff_until_s <= t) & (t - f.t_progress_s >= self.rules.pass_s)
        rows = still.nonzero()[0]
        if not len(rows):
            return []
        other, dist = nearest_other(f.last_z_m, rows, self.spatial.stalls.near_m)
        pairs = zip(rows.tolist(), other.tolist(), dist.tolist(), strict=True)
        return [(j, k) for j, k, d in pairs if d < self.spatial.stalls.near_m]

    def pass_workers(self, t: float, near: list[tuple[int, int]] | None = None) -> None:
        """Collision avoidance on, after a control period: a robot standing beside a robot at
        work (:meth:`standing_near`) for another site with more than ``pass_s`` of work
        left plans its way to its
        place (``fleet.site``: the service point, or the slot it was let in to) round the
        robots within ``around_m`` (``GridPlanner.path_around``) and takes that path if it is
        longer than the path it has left (else no robot is in its way: it stands for another
        reason, such as turning) by at most ``pass_extra_m``, and the extra drive at top speed
        takes less than the work left. Not a recovery try: waiting beside a robot at
        work that is in the way is not being stuck, only slow (docs/model/spatial-world.md,
        "Jams and deadlock"); a robot that does not take the path is asked again in the next
        period."""
        f, z = self.fleet, self.fleet.last_z_m
        v_max, radius = self.follower.v_max_mps, self.controller.radius_m
        service = self.sites.service
        near = self.standing_near(t) if near is None else near
        for j, k in near:
            if f.state[k] != WORKING:
                continue
            if abs(service[j] - service[k]) < 1e-6:  # k works at j's site: the site's
                continue  # queue decides (service: the site; f.site: the place to go)
            left_s = f.work_end_s[k] - t
            if left_s <= self.rules.pass_s:
                continue
            close = np.abs(z - z[j]) < self.rules.around_m
            close[j] = False
            site = (f.site[j].real, f.site[j].imag)
            path = self.planner.path_around((z[j].real, z[j].imag), site, z[close], radius)
            if not len(path):
                continue
            extra = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) - f.left_m[j]
            if (
                extra <= self.spatial.recovery.progress_m
                or extra > self.rules.pass_extra_m
                or extra / v_max >= left_s
            ):
                continue  # the way it has (no robot in it), too long, or slower than waiting
            self.follower.set_path(j, path)
            f.progress_m[j], f.t_progress_s[j] = np.inf, t
            self.fired["pass_workers"] += 1
            self.refresh()

    def break_jams(self, t: float, near: list[tuple[int, int]] | None = None) -> None:
        """Collision avoidance on, after :meth:`pass_workers`: a robot standing beside a driving
        robot (:meth:`standing_near`) is in a jam, and acts on it now as it
        would at the stuck timeout: it goes round (:meth:`go_round`) or gives way
        (:meth:`give_way`: backs out, or waits for the one chosen to), if the meeting is in a
        single-lane place for either robot (:meth:`single_lane`) or the two stand together
        alone (:meth:`standoff`); in a crowd on open floor robots stop a moment in turn
        and ORCA sorts them out, so the rule stays out of its way. Robots facing each other
        in a gap stand until one of them acts: without this rule each such meeting cost the
        whole ``stuck_timeout_s`` (6 s in the warehouse) before anyone moved. The tries are
        counted as in :meth:`sim.spatial.jobs.Jobs.recover`; a robot for which neither applies waits
        for the stuck timeout as before."""
        f, z = self.fleet, self.fleet.last_z_m
        near = self.standing_near(t) if near is None else near
        if not near:
            return
        drives = f.state == DRIVING
        driving, standing = z[drives], z[~drives]  # (no robot stops or starts in the loop)
        for j, k in near:
            if not drives[k] or t - f.t_progress_s[j] < self.rules.pass_s:
                continue  # (pass_workers may have given j a path in this period)
            lane = self.single_lane(j, k, standing) or self.single_lane(k, j, standing)
            if not (lane or self.standoff(j, k, driving)):
                continue
            self.fired["break_jams"] += 1
            if not self.go_round(j, t):
                self.give_way(j, t)

    def single_lane(self, j: int, k: int, standing: np.ndarray | None = None) -> bool:
        """True if robot j cannot step aside of the line toward robot k: neither point two
        radii plus ``lane_gap_m`` to its side is on the planner's free space (which keeps a
        radius and the clearance from obstacles) clear of the robots that stand (at work or
        idle) by two radii. A gap or door narrower than about 2 x (2 radii + clearance) +
        ``lane_gap_m`` is single-lane, as is an aisle a robot at work narrows so; open floor,
        or a 2 m aisle (for 0.25 m robots), is not. ``standing``: the positions of the robots
        not driving, if the caller has them."""
        f, r = self.fleet, self.controller.radius_m
        z = f.last_z_m
        u = (z[k] - z[j]) / max(abs(z[k] - z[j]), 1e-9)
        side = z[j] + 1j * u * np.array([1.0, -1.0]) * (2.0 * r + self.rules.lane_gap_m)
        free = np.array([self.planner.free_one(p.real, p.imag) for p in side.tolist()])
        if not free.any():
            return True
        standing = z[f.state != DRIVING] if standing is None else standing
        if len(standing):
            free &= (np.abs(side[:, None] - standing[None, :]) >= 2.0 * r).all(axis=1)
        return not free.any()

    def standoff(self, j: int, k: int, driving: np.ndarray | None = None) -> bool:
        """True if robots j and k stand together alone: k too is commanded to stand, and no
        other driving robot is within ``deadlock_m`` of j (which way they face is not looked
        at). Two robots whose ways cross
        can stop each other for good where ORCA's half-planes leave each only a standstill; in a
        crowd (the circle swap) robots stop a moment in turn, and ORCA sorts them out.
        ``driving``: the positions of the driving robots, if the caller has them."""
        f, z = self.fleet, self.fleet.last_z_m
        if abs(f.v_cmd_mps[k]) >= self.spatial.stalls.still_mps:
            return False
        driving = z[f.state == DRIVING] if driving is None else driving
        return int(np.count_nonzero(np.abs(driving - z[j]) < self.rules.deadlock_m)) == 2  # j and k

    def give_way(self, j: int, t: float) -> bool:
        """Deadlock between driving robots (collision avoidance on; no robot pushes): of robot
        j and the driving robots within ``deadlock_m``, the one with the highest index that can
        back out (:meth:`backed_in`: its way back is free; and it has tries left; the highest
        index if none can) goes back to ``deadlock_m`` beyond where it was given its task (or
        there, if that is not free) and only then on to its site, so the others get through;
        the others wait. A robot with another in its way back cannot back out: choosing it
        would leave the jam as it was. Giving way is a try (``max_recoveries``): a robot chosen
        again and again while it cannot move (a robot that waits for it boxes it in) is not
        chosen once its tries are used, so the choice passes to another, and the wait is
        bounded. True if j gave way or waits."""
        f, z = self.fleet, self.fleet.last_z_m
        close = (
            (f.state == DRIVING)
            & ~self.sites.holding
            & ~self.held
            & (np.abs(z - z[j]) < self.rules.deadlock_m)
        )
        close[j] = False
        if not close.any():
            return False
        jam = np.append(close.nonzero()[0], j)
        tries = self.spatial.max_recoveries
        free = [k for k in jam.tolist() if f.recoveries[k] < tries and not self.backed_in(k)]
        if j != max(free or jam.tolist()):
            f.t_progress_s[j] = t  # the other one gives way: wait for it
            self.fired["wait_give_way"] += 1
            return True
        if f.recoveries[j] >= tries:
            return False
        refuge = self.refuge(j)
        xy, spot = (z[j].real, z[j].imag), (refuge.real, refuge.imag)
        back = self.planner.path(xy, spot)
        on = self.planner.path(spot, (f.site[j].real, f.site[j].imag))
        if not (len(back) and len(on)) or abs(z[j] - refuge) < 0.5 * self.rules.deadlock_m:
            return False
        f.recoveries[j] += 1
        self.follower.set_path(j, np.concatenate([back, on[1:]]))
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.fired["give_way"] += 1
        self.refresh()
        return True

    def refuge(self, j: int) -> complex:
        """Where robot j backs out to when it gives way: ``deadlock_m`` beyond where it was
        given its task, away from where it is (that place itself if the point is not free)."""
        z = self.fleet.last_z_m[j]
        away = self.origin[j] - z
        refuge = self.origin[j] + self.rules.deadlock_m * away / max(abs(away), 1e-9)
        if not self.planner.free(np.array([[refuge.real, refuge.imag]]))[0]:
            refuge = self.origin[j]
        return refuge

    def backed_in(self, j: int) -> bool:
        """True if another robot stands in robot j's way back: within two radii plus
        ``queue.slot_gap_m`` of the first ``deadlock_m`` of the path toward its :meth:`refuge`, and
        nearest to a point of it more than a radius along (past j's own body) and short of
        that stretch's end: a robot beside j, in front of it or beyond that stretch is not in
        the way. The way is the planned path, which in a narrow place can leave in another
        direction than the straight line back (its first leg may be a short step sideways onto
        the planner's free space); the straight line where no path is found."""
        f, r = self.fleet, self.controller.radius_m
        z = f.last_z_m
        refuge = self.refuge(j)
        if abs(refuge - z[j]) < 1e-9:
            return False
        path = self.planner.path((z[j].real, z[j].imag), (refuge.real, refuge.imag))
        way = path @ np.array([1.0, 1j]) if len(path) >= 2 else np.array([z[j], refuge])
        way[0] = z[j]
        seg = np.diff(way)
        keep = np.abs(seg) > 1e-12
        way, seg = np.append(way[:1], way[1:][keep]), seg[keep]
        if not len(seg):
            return False
        start = np.concatenate([[0.0], np.cumsum(np.abs(seg))[:-1]])
        take = start < self.rules.deadlock_m  # the segments of the first deadlock_m of the way
        a, d, s0 = way[:-1][take], seg[take], start[take]
        others = np.delete(np.arange(len(z)), j)
        rel = (z[others, None] - a[None, :]) / d[None, :]  # in each segment's frame, / length
        u = np.clip(rel.real, 0.0, 1.0)
        dist = np.abs(z[others, None] - (a[None, :] + u * d[None, :]))
        best = dist.argmin(axis=1)
        rows = np.arange(len(others))
        along = s0[best] + u[rows, best] * np.abs(d[best])
        near = dist[rows, best] < 2.0 * r + self.spatial.queue.slot_gap_m
        return bool((near & (along > r) & (along < self.rules.deadlock_m)).any())
