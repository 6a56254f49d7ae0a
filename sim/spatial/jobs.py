"""Task bookkeeping of the pymunk world: assign, start work, finish, stuck, recover, make way.

:class:`Jobs` owns the life of each robot's task, from the auction's assignment to the reported
:class:`~sim.world.Completion`, over the fleet state it is handed (``sim.spatial.fleet``). A control
period (``sim.spatial.control``) steers the robots and calls it on events only (arrival, end of
work, deadline, stuck, yield request, replanning); after each event :meth:`Jobs.refresh` brings the
schedule of checks up to date. With collision avoidance on it also keeps the sites' service
slots and queues (``sim.spatial.sites``, ``Jobs.sites``) and the rules for jams between driving
robots (``sim.spatial.jams``, ``Jobs.jams``).
"""

from __future__ import annotations

import functools
import weakref
from collections.abc import Callable
from typing import Any

import numpy as np

from sim.scenario import SpatialSpec
from sim.spatial.controller import DiffDriveController
from sim.spatial.fleet import Clock, FleetState, Schedule, refresh_schedule
from sim.spatial.jams import Jams
from sim.spatial.navigation.paths import PathFollower
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.sites import Sites
from sim.spatial.traffic import Traffic
from sim.states import DRIVING, IDLE, WORKING
from sim.tasks import Batch
from sim.world import Abandon, Completion

# what the stuck recovery does, counted (Jobs.fired): an idle robot asked aside, a wait for a
# robot at work nearby or at its site, a detour round a robot that stands, a blind back-off, a
# task failed for good
RECOVERY_RULES = ("ask_idle", "wait_worker", "wait_site", "detour", "backoff", "failed")


class Jobs:
    """The tasks of a fleet of robots, kept in its :class:`~sim.spatial.fleet.FleetState`.

    Args:
        fleet: per-robot state, read and written in place.
        schedule: the next-check times and counts that :meth:`refresh` keeps.
        clock: the world's physics-step clock.
        follower: the robots' paths.
        planner: plans paths to sites, side steps and detours (it ignores robots).
        controller: the drive limits (top speed, top turn rate).
        spatial: the world's spatial table (stuck timeout, tries, arrival tolerance).
        exec_time_s: (n_types,) execution time of each task type, s.
        reach_m: robot centres closer than this are touching, m.
        bodies: the robots' pymunk bodies (a detour starts along the body's heading now).
        rng: the world's generator (back-off arcs).
        keep_lists: keep the state and the steering robots as Python lists in the schedule
            (the scalar control period reads them).
        avoid: under collision avoidance robots never push: a robot that finished and
            stands on the service point another robot comes for steps ``make_way.step_m`` clear
            of it, one at work there sends the newcomer to a service slot
            (:meth:`sim.spatial.sites.Sites.take_slots`), and a robot whose site is taken by a robot
            at work waits for that work to end instead of recovering. Sites also keep a queue
            (:meth:`sim.spatial.sites.Sites.queue`): within ``QUEUE_M`` of a site whose every place
            (service point and free slots) is taken, a robot holds where it is, first come
            first served, and one that finished there drives out past the crowd
            (:meth:`sim.spatial.sites.Sites.leave`). A stuck robot goes round the robots near it or
            gives way (:meth:`sim.spatial.jams.Jams.go_round`,
            :meth:`~sim.spatial.jams.Jams.give_way`) before it backs off on a random arc.

    Attributes:
        done: completions not yet handed out by the world.
        failures: tasks that failed since reset.
        broken: (m,) robots broken down, written in place by the world (``sim.faults``).
        sites: the sites' service slots and queues (:class:`sim.spatial.sites.Sites`).
        jams: the rules for jams between driving robots (:class:`sim.spatial.jams.Jams`).
        traffic: the traffic rules for single-lane passages
            (:class:`sim.spatial.traffic.Traffic`; None unless avoidance is on and
            ``[spatial.traffic] rules = "on"``).
        held: (m,) robots holding before a passage (written by ``traffic``).
        fired: how often each of the stuck recovery's rules acted since reset, by name
            (``ask_idle``, ``wait_worker``, ``wait_site``, ``detour``, ``backoff``, ``failed``);
            the jam rules' are ``jams.fired``.
    """

    def __init__(
        self,
        *,
        fleet: FleetState,
        schedule: Schedule,
        clock: Clock,
        follower: PathFollower,
        planner: GridPlanner,
        controller: DiffDriveController,
        spatial: SpatialSpec,
        exec_time_s: np.ndarray,
        reach_m: float,
        bodies: list,
        rng: np.random.Generator,
        keep_lists: bool,
        avoid: bool = False,
    ) -> None:
        self.fleet, self.schedule, self.clock = fleet, schedule, clock
        self.follower, self.planner, self.controller = follower, planner, controller
        self.spatial = spatial
        self.recovery, self.stepping = spatial.recovery, spatial.make_way
        self.exec_time_s = exec_time_s
        self.reach_m = reach_m
        self.bodies = bodies
        self.rng = rng
        self.keep_lists = keep_lists
        self.avoid = avoid
        self.done: list[Completion] = []
        self.failures = 0
        self.broken = np.zeros(len(fleet.state), dtype=bool)  # set by the world (sim.faults)
        self.base_planner = planner  # the scenario's obstacles alone (use_planner adds robots)
        self.blocked = np.zeros(len(fleet.state), dtype=bool)  # waiting for a repair
        self.held = np.zeros(len(fleet.state), dtype=bool)  # holding before a passage
        self.fired = dict.fromkeys(RECOVERY_RULES, 0)
        # the same refresh as refresh(), without a reference back to the jobs (no cycle to collect)
        refresh = functools.partial(refresh_schedule, fleet, schedule, clock, keep_lists)
        self.sites = Sites(
            fleet=fleet,
            schedule=schedule,
            follower=follower,
            planner=planner,
            controller=controller,
            bodies=bodies,
            spatial=spatial,
            reach_m=reach_m,
            broken=self.broken,
            blocked=self.blocked,
            refresh=refresh,
            held=self.held,
        )
        self.jams = Jams(
            fleet=fleet,
            sites=self.sites,
            follower=follower,
            planner=planner,
            controller=controller,
            spatial=spatial,
            refresh=refresh,
            held=self.held,
        )
        self.traffic = None
        if avoid and spatial.traffic.rules == "on":
            self.traffic = Traffic(
                fleet=fleet,
                sites=self.sites,
                follower=follower,
                planner=planner,
                controller=controller,
                spatial=spatial,
                held=self.held,
                refresh=refresh,
                clear_way=_weak(self.clear_way),  # no cycle: a dropped world goes at once
            )

    def use_planner(self, planner: GridPlanner) -> None:
        """Plan with ``planner`` from now on, here and in the sites' and jam rules (the world's
        fault model hands over one that knows where the broken robots stand)."""
        self.planner = self.sites.planner = self.jams.planner = planner
        if self.traffic is not None:
            self.traffic.planner = planner

    def assign(
        self, batch: Batch, assignment: np.ndarray, bids: np.ndarray, won: np.ndarray, xy_m
    ) -> None:
        """Start the tasks ``won`` of ``batch``: plan each robot's path from ``xy_m`` (m, 2).

        A task whose site has no path from its robot fails at once as unreachable, unless only
        broken robots stand in every way: then the robot waits for a repair
        (:meth:`wait_for_repair`).
        """
        f, t = self.fleet, self.clock.time_s
        rows, paths, blocked = [], [], []
        for k in won.tolist():
            j = int(assignment[k])
            if f.task[j] >= 0:
                raise RuntimeError(f"invariant violated: robot {j} given a task while busy")
            site = np.asarray(batch.sites[k], dtype=float)
            if not np.isfinite(site).all():
                raise ValueError(f"task {int(batch.ids[k])} has no site: a spatial world needs one")
            f.task[j], f.task_type[j] = int(batch.ids[k]), int(batch.types[k])
            f.t_alloc_s[j], f.bid[j], f.site[j] = t, float(bids[k]), complex(*site)
            f.odo0_m[j], f.recoveries[j], f.replan[j] = f.moved_m[j], 0, False
            f.stuck_left_m[j] = np.inf
            f.backoff_until_s[j] = -np.inf
            f.yielding[j] = False
            self.sites.assign(j)
            self.jams.origin[j] = complex(*xy_m[j])
            self.follower.clear(j)
            path = self.planner.path(xy_m[j], site)
            if not len(path):
                if self.blocked_by_broken(xy_m[j], site):
                    blocked.append(j)
                    continue
                self.finish(j, t, False, f"unreachable: no path from {_xy(xy_m[j])} to {_xy(site)}")
                continue
            rows.append(j)
            paths.append(path)
        for j, length in zip(rows, self.follower.set_paths(rows, paths), strict=True):
            f.state[j] = DRIVING
            self.jams.due[j] = True
            f.left_m[j], f.progress_m[j], f.t_progress_s[j] = length, np.inf, t
            f.deadline_s[j] = self.deadline_s(j, length, t)
        for j in blocked:
            f.state[j] = DRIVING
            self.wait_for_repair(j, (float(xy_m[j][0]), float(xy_m[j][1])), t)
        self.schedule.site_check_s = -np.inf
        self.sites.queue_check_s = -np.inf
        self.refresh()

    def deadline_s(self, j: int, length_m: float, t: float) -> float:
        """When robot j, given its way of ``length_m`` at ``t``, must begin work by: four times
        the way at top speed, the work, every recovery try and half a minute."""
        sp = self.spatial
        slack = (sp.max_recoveries + 1) * (sp.stuck_timeout_s + self.recovery.backoff_s) + 30.0
        v_max = self.follower.v_max_mps
        return t + self.exec_time_s[self.fleet.task_type[j]] + 4 * length_m / v_max + slack

    def blocked_by_broken(self, xy, site) -> bool:
        """True if only broken robots stand between ``xy`` and ``site``: the planner that knows
        where they stand finds no way, the one with the scenario's obstacles alone does."""
        if self.planner is self.base_planner or not self.broken.any():
            return False
        return bool(len(self.base_planner.path(xy, site)))

    def wait_for_repair(self, j: int, xy: tuple[float, float], t: float) -> None:
        """Robot j (driving) has no way to its site while broken robots stand in it: it holds
        where it is (a path to its own position; its stuck clock stopped, so it is drawn as
        waiting) until a repair opens a way (:meth:`retry_blocked`), for at most
        ``recovery.repair_wait_s`` more than its task would have had."""
        f = self.fleet
        site = (f.site[j].real, f.site[j].imag)
        way = self.base_planner.path(xy, site)
        length = float(np.linalg.norm(np.diff(way, axis=0), axis=1).sum()) if len(way) else 0.0
        self.blocked[j] = True
        self.follower.set_path(j, np.array([xy, xy], dtype=float))
        f.left_m[j] = length
        f.progress_m[j], f.t_progress_s[j] = -np.inf, np.inf  # no stuck clock
        f.deadline_s[j] = self.deadline_s(j, length, t) + self.recovery.repair_wait_s

    def retry_blocked(self, t: float) -> None:
        """Broken robots were repaired (or moved): each robot waiting for a repair plans again
        and, with a way now, drives on, its deadline counted afresh from now."""
        rows = self.blocked.nonzero()[0].tolist()
        if not rows:
            return
        f, z = self.fleet, self.fleet.last_z_m
        changed = False
        for j in rows:
            path = self.planner.path((z[j].real, z[j].imag), (f.site[j].real, f.site[j].imag))
            if not len(path):
                continue
            self.blocked[j] = False
            length = self.follower.set_paths([j], [path])[0]
            f.left_m[j], f.progress_m[j], f.t_progress_s[j] = length, np.inf, t
            f.deadline_s[j] = self.deadline_s(j, length, t)
            changed = True
        if changed:
            self.schedule.site_check_s = -np.inf
            self.refresh()

    def busy_until_s(self, t: float) -> np.ndarray:
        """(m,) estimated end of each robot's task (``t`` if free): path left at top speed plus
        the execution time while driving, the end of work while working."""
        f = self.fleet
        busy = np.full(len(f.state), t)
        drv, wrk = f.state == DRIVING, f.state == WORKING
        v_max = self.follower.v_max_mps
        busy[drv] = t + f.left_m[drv] / v_max + self.exec_time_s[f.task_type[drv]]
        busy[wrk] = np.maximum(f.work_end_s[wrk], t)
        return busy

    def refresh_lists(self) -> None:
        """The schedule's state and steering lists from the fleet state (scalar control)."""
        if self.keep_lists:
            f = self.fleet
            self.schedule.state_list = f.state.tolist()
            self.schedule.steer_list = ((f.state == DRIVING) | f.yielding).nonzero()[0].tolist()

    def refresh(self) -> None:
        """Refresh the schedule's next-event times and counts after a task event
        (:func:`sim.spatial.fleet.refresh_schedule`)."""
        refresh_schedule(self.fleet, self.schedule, self.clock, self.keep_lists)

    def start_work(self, arrived: list[int], v, w, t: float) -> None:
        """The robots ``arrived`` start work now; their commands ``v``, ``w`` become zero."""
        f, sch = self.fleet, self.schedule
        for j in arrived:
            f.state[j] = WORKING
            f.work_end_s[j] = t + self.exec_time_s[f.task_type[j]]
            f.t_progress_s[j] = np.inf
            self.follower.clear(j)
            v[j] = w[j] = 0.0
            sch.next_end_s = min(sch.next_end_s, f.work_end_s[j])
        if arrived:
            self.jams.began[arrived] = True  # ways may pass them (Jams.look_ahead)
            self.refresh()

    def end_due(self, t: float) -> None:
        """End the work that is done and the tasks whose robot has not begun work by their
        deadline (work begun is finished: the deadline bounds getting there)."""
        f = self.fleet
        if self.avoid and t >= self.sites.queue_check_s:
            self.sites.queue(t)
        if t + 1e-9 >= self.schedule.next_end_s:
            self.finish_work(t)
        if t > self.schedule.next_deadline_s:
            late = ((f.task >= 0) & (f.state == DRIVING) & (f.deadline_s < t)).nonzero()[0]
            for j in late.tolist():
                why = "timeout: not at work by its deadline"
                if self.blocked[j]:
                    why = "unreachable: broken robots in every way to its site until its deadline"
                self.finish(j, t, False, why, False)
            if late.size:
                self.refresh()

    def finish_work(self, t: float) -> None:
        """Report the work that has ended by ``t`` as done."""
        f = self.fleet
        done = ((f.state == WORKING) & (f.work_end_s <= t + 1e-9)).nonzero()[0]
        for j in done.tolist():
            self.finish(j, float(f.work_end_s[j]), True, refresh=False)
        if done.size:
            self.refresh()

    def finish(
        self, j: int, t_done_s: float, ok: bool, reason: str = "", refresh: bool = True
    ) -> None:
        """Report robot j's task as a Completion and free the robot (``refresh=False``: the
        caller calls :meth:`refresh` once after a batch; nothing reads the schedule between)."""
        f = self.fleet
        task, t_alloc, bid = int(f.task[j]), float(f.t_alloc_s[j]), float(f.bid[j])
        odo = float(f.moved_m[j] - f.odo0_m[j])
        self.done.append(Completion(task, j, t_alloc, t_done_s, bid, odo, ok, reason))
        self.failures += not ok
        f.task[j] = -1
        f.state[j] = IDLE
        f.stuck_left_m[j] = np.inf
        f.replan[j] = False
        f.backoff_until_s[j] = -np.inf
        f.t_progress_s[j] = np.inf
        self.blocked[j] = False
        self.follower.clear(j)
        if self.avoid:
            self.sites.release(j)
            if not self.sites.leave(j, t_done_s):
                self.sites.pull_over(j, t_done_s)
        if refresh:
            self.refresh()

    def abandon(self, j: int, t: float) -> Abandon:
        """Robot j broke down (``sim.faults``): it gives up its task where it is and stands."""
        f = self.fleet
        out = Abandon(int(f.task[j]), j, float(f.t_alloc_s[j]), t, float(f.bid[j]))
        f.task[j] = -1
        f.state[j] = IDLE
        f.stuck_left_m[j] = np.inf
        f.replan[j] = False
        f.backoff_until_s[j] = -np.inf
        f.t_progress_s[j] = np.inf
        f.yielding[j] = False
        self.blocked[j] = False
        self.sites.release(j)
        self.follower.clear(j)
        self.refresh()
        return out

    def check_stuck(self, go: np.ndarray, t: float) -> None:
        """Recover the robots ``go`` without progress for ``stuck_timeout_s``; schedule the next
        check."""
        timeout = self.spatial.stuck_timeout_s
        f = self.fleet
        stalest = float(f.t_progress_s.min())  # only rises: set to t, later or inf
        if t - stalest > timeout:
            for j in (go & (t - f.t_progress_s > timeout)).nonzero()[0].tolist():
                self.recover(j, t)
        self.schedule.stuck_check_s = self.next_stuck_check_s()

    def next_stuck_check_s(self) -> float:
        """When the robot longest without progress could first be stuck, s."""
        return float(self.fleet.t_progress_s.min()) + self.spatial.stuck_timeout_s

    def recover(self, j: int, t: float) -> None:
        """Robot j is stuck: wait for a robot at work that boxes it in; with collision avoidance
        on, have an idle robot beside it step aside (:meth:`ask_idle`), go round or give way
        (``sim.spatial.jams``); go round a standing one, or back off on a random arc and replan;
        after ``max_recoveries`` tries, fail."""
        sp, f = self.spatial, self.fleet
        b, z = int(f.blocker[j]), f.last_z_m
        blocked = b >= 0 and f.near_m[j] < self.reach_m + self.stepping.trigger_m
        if blocked and f.state[b] == WORKING and f.work_end_s[b] - t <= sp.stuck_timeout_s:
            # boxed in by a robot at work that is nearly done: not stuck, wait for it
            f.t_progress_s[j] = f.work_end_s[b]
            self.fired["wait_worker"] += 1
            return
        if self.avoid:
            taken = (f.state == WORKING) & (np.abs(z - f.site[j]) < 2.0 * self.controller.radius_m)
            if taken.any():  # its site is taken by a robot at work: wait for it to step clear
                f.t_progress_s[j] = float(f.work_end_s[taken].min())
                self.fired["wait_site"] += 1
                return
            if self.ask_idle(j, t) or self.jams.go_round(j, t) or self.jams.give_way(j, t):
                return
        f.recoveries[j] += 1
        f.stuck_left_m[j] = f.left_m[j]  # where it got stuck (path left to drive)
        self.schedule.recovering = True
        if f.recoveries[j] > sp.max_recoveries:
            why = f"stuck: no progress for {sp.stuck_timeout_s:g} s after {sp.max_recoveries} tries"
            self.fired["failed"] += 1
            return self.finish(j, t, False, why)
        if blocked and f.state[b] != DRIVING:
            travel = np.exp(1j * self.bodies[j].angle)
            site = (f.site[j].real, f.site[j].imag)
            others = np.delete(z, j)
            path = self.planner.detour(z[j], z[b], travel, self.recovery.detour_m, site, others)
            if len(path):  # go round the robot that stands in the way
                self.follower.set_path(j, path)
                f.progress_m[j], f.t_progress_s[j] = np.inf, t
                self.fired["detour"] += 1
                return
        self.fired["backoff"] += 1
        c = self.controller
        top = c.omega_max_radps
        if self.avoid:  # a slow arc: the speed caps hold a heading over a period
            top = min(2.0 * self.recovery.avoid_turn_radps, top)
        turn = self.rng.uniform(-0.5, 0.5) * top
        f.backoff_cmd[j] = (-0.3 * c.v_max_mps, turn)
        f.backoff_until_s[j] = t + self.recovery.backoff_s
        f.t_progress_s[j] = np.inf
        f.replan[j] = True
        self.follower.clear(j)
        self.refresh()

    def ask_idle(self, j: int, t: float) -> bool:
        """Collision avoidance on, robot j stuck: the nearest idle robot within ``stalls.near_m``
        (not broken) that has a step off j's way (:meth:`step_off`) takes it, and j waits one stuck
        timeout for it, spending a try.

        Why beyond :meth:`make_way`: the speed caps ask only an idle robot straight ahead, while
        ORCA also stops a robot for one beside it (an idle robot against the wall at the mouth of
        a single-lane gap can hold a robot in the gap). The nearest idle robot may have no free
        step where a farther one has (two robots pulled over to the two walls of a 2 m aisle
        leave no lane between them). One already stepping aside or driving out of a site is asked
        too if it stands (commanded below ``stalls.still_mps``): it may stand face to face with
        the robot sent to the slot it left.

        Returns:
            False, and nothing changes, if no idle robot is near, j has used its tries or no
            step is free; else True.
        """
        f = self.fleet
        if f.recoveries[j] >= self.spatial.max_recoveries:
            return False
        z = f.last_z_m
        standing = (
            np.abs(f.v_cmd_mps) < self.spatial.stalls.still_mps
        )  # stepping aside, but not moving
        idle = (f.state == IDLE) & (~f.yielding | standing) & ~self.broken
        dist = np.where(idle, np.abs(z - z[j]), np.inf)
        for k in np.argsort(dist, kind="stable").tolist():
            if not dist[k] < self.spatial.stalls.near_m:
                return False
            path = self.step_off(k, j, z)
            if len(path):
                break
        else:
            return False
        self.follower.set_paths([k], [path])
        f.yielding[k], f.yield_until_s[k] = True, t + self.stepping.timeout_s
        f.recoveries[j] += 1
        f.t_progress_s[j] = t
        self.fired["ask_idle"] += 1
        self.refresh()
        return True

    def step_off(self, k: int, j: int, z: np.ndarray, way: np.ndarray | None = None) -> np.ndarray:
        """A short path (collision avoidance on) that takes idle robot k off the way of robot j:
        ``make_way.step_m``, else twice that, to the side of j's way away from j, the other side or
        straight on along it (j's next path segment; its heading without a path); failing all six,
        the same two lengths at 45 degrees off j's way toward k's side and the other, at 135 degrees
        toward each, then straight back (in an aisle, along the wall k stands against); to the first
        end point that is free, half a step clear of the other robots, at least two radii and
        ``jams.lane_gap_m`` off the rest of j's path, and reached by a planned path at most twice
        the step long that keeps from j two radii and ``lane_gap_m`` (or as far as k stands, if
        nearer) less half ``lane_gap_m``, and never less than two radii (a robot closer to a wall
        than the planner's free space can step off it too). A way that passes j at two radii
        leaves both standing; a step along j's way, or into a gap j's path runs through, only
        moves the jam to the gap's mouth. (0, 2) if no step will do. ``way``: j's way ahead
        (x + iy) if not its path (a robot holding before a passage: its way through it)."""
        r = self.controller.radius_m
        fol = self.follower
        if way is None:
            ahead = fol.points[j, fol.index[j] : fol.last[j] + 1] if fol.last[j] >= 0 else z[j:j]
        else:
            ahead = np.asarray(way, dtype=complex)
        way = np.concatenate([[z[j]], ahead])
        travel = next((d / abs(d) for d in ahead - z[j] if abs(d) > 1e-6), None)
        if travel is None:
            travel = np.exp(1j * self.bodies[j].angle)
        lateral = 1j * travel
        side = 1.0 if ((z[k] - z[j]) * lateral.conj()).real >= 0.0 else -1.0
        close = np.abs(z - z[k]) < 3.0 * self.stepping.step_m
        close[k] = False
        # the way there keeps two radii and lane_gap_m from j (or as far as k stands, if
        # nearer), less half lane_gap_m, and never less than two radii
        gap = self.spatial.jams.lane_gap_m
        lane = 2.0 * r + gap
        keep = max(2.0 * r, min(lane, float(abs(z[k] - z[j]))) - 0.5 * gap)
        steps = (self.stepping.step_m, 2.0 * self.stepping.step_m)
        half = np.exp(0.25j * np.pi * side)  # 45 degrees toward k's side of j's way
        first = (side * lateral, -side * lateral, travel)
        then = (travel * half, travel / half, -travel / half, -travel * half, -travel)
        for step, toward in [(step, d) for group in (first, then) for step in steps for d in group]:
            end = z[k] + step * toward
            if not self.planner.free_one(end.real, end.imag):
                continue
            if close.any() and np.abs(z[close] - end).min() < 0.5 * self.stepping.step_m:
                continue
            if _to_polyline(np.array([end]), way)[0] < lane:
                continue
            path = self.planner.path((z[k].real, z[k].imag), (end.real, end.imag))
            if not len(path):
                continue
            pts = path @ np.array([1.0, 1j])
            if np.abs(np.diff(pts)).sum() > 2.0 * step:
                continue
            if _to_polyline(np.array([z[j]]), pts)[0] < keep:
                continue
            return path
        return np.zeros((0, 2))

    def clear_way(self, k: int, j: int, way: np.ndarray, t: float) -> bool:
        """Idle robot k stands on ``way``, robot j's way through a passage it holds for: k
        steps off it (:meth:`step_off`); not a recovery try. True if it does."""
        f = self.fleet
        if f.yielding[k] or self.broken[k] or f.state[k] != IDLE:
            return False
        path = self.step_off(k, j, f.last_z_m, way)
        if not len(path):
            return False
        self.follower.set_paths([k], [path])
        f.yielding[k], f.yield_until_s[k] = True, t + self.stepping.timeout_s
        self.refresh()
        return True

    def recovered(self, rows: list[int]) -> None:
        """Robots ``rows`` came ``recovered_m`` closer to their site than where they last got
        stuck: that obstruction is behind them, and their tries start again."""
        f = self.fleet
        for j in rows:
            f.recoveries[j] = 0
            f.stuck_left_m[j] = np.inf
        self.schedule.recovering = bool(np.isfinite(f.stuck_left_m).any())

    def replan(self, j: int, xy: tuple[float, float], t: float) -> None:
        """Robot j has backed off: a new path from ``xy`` to its site, or fail as unreachable."""
        f = self.fleet
        f.replan[j] = False
        site = (f.site[j].real, f.site[j].imag)
        path = self.planner.path(xy, site)
        if not len(path):
            if self.blocked_by_broken(xy, site):
                self.wait_for_repair(j, xy, t)
                self.refresh()
                return
            self.finish(j, t, False, f"unreachable: no path from {_xy(xy)} after a recovery")
            return
        self.follower.set_path(j, path)
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.schedule.site_check_s = -np.inf
        self.refresh()

    def make_way(self, pushers, blocker, z, h, v, t: float) -> None:
        """Idle robots standing in a driving robot's way step aside (planning ignores robots):
        with collision avoidance on, off its way (:meth:`step_off`); without, sideways of its
        heading (``GridPlanner.side_step``).

        Args:
            pushers: driving robots that asked; blocker: (m,) the robot in each one's way;
            z, h: (m,) positions and unit headings (complex); v: (m,) speed commands; t: now.
        """
        f = self.fleet
        rows, paths = [], []
        for j in pushers.tolist():
            b = int(blocker[j])
            if f.yielding[b] or self.broken[b]:  # asked in this period, or cannot move
                continue
            if self.avoid:  # collision avoidance on: off the driving robot's way
                path = self.step_off(b, j, z)
            else:
                travel = h[j] if v[j] >= 0 else -h[j]
                # the side step's end point must keep make_way.step_m / 2 from the other robots:
                # only those within 1.5 make_way.step_m of b could be that close (2 for rounding)
                close = np.abs(z - z[b]) < 2.0 * self.stepping.step_m
                close[b] = False
                path = self.planner.side_step(z[b], z[j], travel, self.stepping.step_m, z[close])
            if len(path):
                rows.append(b)
                paths.append(path)
                f.yielding[b], f.yield_until_s[b] = True, t + self.stepping.timeout_s
        self.follower.set_paths(rows, paths)
        self.refresh()

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Service slots and queues, where each robot was given its task and the failures so
        far (between sets: no completion is waiting to be handed out)."""
        if self.done:
            raise RuntimeError("jobs state requested with completions not handed out")
        sites = self.sites.state_arrays()
        out = {
            "slotted": sites.pop("slotted"),
            "origin": self.jams.origin.copy(),
            **sites,
            "failures": np.array(self.failures, dtype=np.int64),
        }
        if self.traffic is not None:  # the counts of the rules (between sets nobody holds)
            out["traffic_counts"] = self.traffic.count_array()
            out["rule_counts"] = np.array([*self.fired.values(), *self.jams.fired.values()])
        return out

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays`."""
        self.sites.restore_arrays(arrays)
        self.jams.origin = np.array(arrays["origin"], dtype=complex)
        self.failures = int(arrays["failures"])
        if self.traffic is not None and "traffic_counts" in arrays:
            self.traffic.restore_counts(arrays["traffic_counts"])
            counts = np.asarray(arrays["rule_counts"]).tolist()
            n = len(self.fired)
            self.fired = dict(zip(self.fired, counts[:n], strict=True))
            self.jams.fired = dict(zip(self.jams.fired, counts[n:], strict=True))

    def traffic_summary(self) -> dict[str, float]:
        """With the traffic rules on: their counts (``traffic_*``) and how often each jam
        and recovery rule acted (``traffic_jam_<rule>``, :attr:`fired` and ``jams.fired``);
        empty otherwise."""
        if self.traffic is None:
            return {}
        fired = {**self.fired, **self.jams.fired}
        return {**self.traffic.summary(), **{f"traffic_jam_{k}": v for k, v in fired.items()}}

    def stop_yield(self, j: int) -> None:
        """Robot j stops yielding (the caller calls :meth:`refresh` after)."""
        self.fleet.yielding[j] = False
        self.follower.clear(j)


def _xy(p) -> str:
    return f"({float(p[0]):.2f}, {float(p[1]):.2f})"


def _to_polyline(p: np.ndarray, way: np.ndarray) -> np.ndarray:
    """(len(p),) distance of each point ``p`` (x + iy) to the polyline ``way``, m."""
    if len(way) < 2:
        return np.abs(p - way[0]) if len(way) else np.full(len(p), np.inf)
    a, d = way[:-1], np.diff(way)
    u = ((p[:, None] - a[None, :]) * d.conj()[None, :]).real
    u = np.clip(u / np.maximum((d * d.conj()).real, 1e-18)[None, :], 0.0, 1.0)
    return np.abs(p[:, None] - (a[None, :] + u * d[None, :])).min(axis=1)


def _weak(method: Callable) -> Callable:
    """A bound method that does not keep its object alive (a collaborator that calls back
    would otherwise make a reference cycle, freed only by a garbage collection)."""
    ref = weakref.WeakMethod(method)

    def call(*args: Any) -> Any:
        return ref()(*args)

    return call
