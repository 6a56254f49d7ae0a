"""Task bookkeeping of the pymunk world: assign, start work, finish, stuck, recover, make way.

:class:`Jobs` owns the life of each robot's task, from the auction's assignment to the reported
:class:`~sim.world.Completion`, over the fleet state it is handed (``sim.fleet``). A control
period (``sim.control``) steers the robots and calls it on events only (arrival, end of work,
deadline, stuck, yield request, replanning); after each event :meth:`Jobs.refresh` brings the
schedule of checks up to date.
"""

from __future__ import annotations

import numpy as np

from sim.drive import DiffDriveController
from sim.drive_law import SPEED_BOUND, next_check_s
from sim.fleet import Clock, FleetState, Schedule
from sim.paths import PathFollower
from sim.planning import GridPlanner
from sim.recording import DRIVING, IDLE, WORKING
from sim.scenario import SpatialSpec
from sim.stalls import NEAR_M, STILL_MPS, nearest_other
from sim.tasks import Batch
from sim.world import Abandon, Completion

BACKOFF_S = 1.5  # a stuck robot reverses on a random arc this long, then replans
RECOVERED_M = 5.0  # this much closer to its site than where it got stuck, its tries start again
YIELD_TRIGGER_M = 0.3  # a driving robot this close (beyond contact) to an idle one asks it to move
YIELD_STEP_M = 1.0  # how far an idle robot steps aside
YIELD_TIMEOUT_S = 6.0
DETOUR_M = 1.0  # a robot blocked by one that stands still passes it this far to the side
DEADLOCK_M = 1.5  # driving robots this close, one of them stuck: a deadlock (avoidance on)
SLOTS = 4  # service slots on a ring around each service point (collision avoidance on)
SLOT_GAP_M = 0.35  # a robot in a slot keeps this much air to the one on the service point, m
PROGRESS_M = 0.05  # less progress than this along the path does not reset the stuck clock
QUEUE_M = 2.5  # avoidance on: a robot this close to a site with every place taken holds here
CROWD_M = 1.0  # ... as does one this close (centres) to a robot already holding for that site
EXIT_M = 1.5  # a robot that finished where others hold drives this far beyond QUEUE_M out
EXIT_TIMEOUT_S = 20.0  # ... and gives up driving out after this long
HOLD_MAX_S = 300.0  # a robot may hold in a site's queue this long before its task times out
AROUND_M = 3.0  # avoidance on: a stuck robot plans round the robots this close (centres), m
DETOUR_FACTOR = 3.0  # ... and takes that path if at most this times the path it had ...
DETOUR_EXTRA_M = 10.0  # ... plus this, m
PASS_S = 2.0  # avoidance on: a robot stood this long beside a driving robot acts on the jam
# (break_jams) ...
LANE_GAP_M = 0.1  # ... in a place where it cannot step this far beyond a robot's width aside;
# beside a robot at work at another site (pass_workers) it ...
PASS_EXTRA_M = 3.0  # ... plans round it, and takes that path if at most this much longer, m


class Jobs:
    """The tasks of a fleet of robots, kept in its :class:`~sim.fleet.FleetState`.

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
        clear_sites: under collision avoidance robots never push: a robot that finished and
            stands on the service point another robot comes for steps ``YIELD_STEP_M`` clear
            of it, one at work there sends the newcomer to a service slot
            (:meth:`take_slots`), and a robot whose site is taken by a robot at work waits for
            that work to end instead of recovering. Sites also keep a queue (:meth:`queue`):
            within ``QUEUE_M`` of a site whose every place (service point and free slots) is
            taken, a robot holds where it is, first come first served, and one that finished
            there drives out past the crowd (:meth:`leave`).

    Attributes:
        done: completions not yet handed out by the world.
        failures: tasks that failed since reset.
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
        clear_sites: bool = False,
    ) -> None:
        self.fleet, self.schedule, self.clock = fleet, schedule, clock
        self.follower, self.planner, self.controller = follower, planner, controller
        self.spatial = spatial
        self.exec_time_s = exec_time_s
        self.reach_m = reach_m
        self.bodies = bodies
        self.rng = rng
        self.keep_lists = keep_lists
        self.clear_sites = clear_sites
        self.slotted = np.zeros(len(fleet.state), dtype=bool)  # working toward a service slot
        self.origin = fleet.site.copy()  # where each robot was given its task (x + iy), m
        m = len(fleet.state)
        self.service = fleet.site.copy()  # the service point of each robot's task (x + iy), m
        self.admitted = np.zeros(m, dtype=bool)  # let in to its site: a place is kept for it
        self.holding = np.zeros(m, dtype=bool)  # holding in its site's queue
        self.hold_since_s = np.full(m, np.inf)  # when it began to hold, s
        self.queue_check_s = -np.inf  # no robot can come within QUEUE_M of its site before
        self.around_s = np.full(m, -np.inf)  # when each robot last planned round others, s
        self._places: dict[complex, np.ndarray] = {}  # service point and free slots per site
        self.done: list[Completion] = []
        self.failures = 0
        self.broken = np.zeros(len(fleet.state), dtype=bool)  # set by the world (sim.faults)

    def assign(
        self, batch: Batch, assignment: np.ndarray, bids: np.ndarray, won: np.ndarray, xy_m
    ) -> None:
        """Start the tasks ``won`` of ``batch``: plan each robot's path from ``xy_m`` (m, 2).

        A task whose site has no path from its robot fails at once as unreachable.
        """
        f, t, sp = self.fleet, self.clock.time_s, self.spatial
        v_max = self.follower.v_max_mps
        slack = (sp.max_recoveries + 1) * (sp.stuck_timeout_s + BACKOFF_S) + 30.0
        rows, paths = [], []
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
            self.slotted[j] = False
            self.origin[j] = complex(*xy_m[j])
            self.service[j] = f.site[j]
            self.admitted[j] = self.holding[j] = False
            self.hold_since_s[j] = np.inf
            self.follower.clear(j)
            path = self.planner.path(xy_m[j], site)
            if not len(path):
                self.finish(j, t, False, f"unreachable: no path from {_xy(xy_m[j])} to {_xy(site)}")
                continue
            rows.append(j)
            paths.append(path)
        for j, length in zip(rows, self.follower.set_paths(rows, paths), strict=True):
            f.state[j] = DRIVING
            f.left_m[j], f.progress_m[j], f.t_progress_s[j] = length, np.inf, t
            f.deadline_s[j] = t + self.exec_time_s[f.task_type[j]] + 4 * length / v_max + slack
        self.schedule.site_check_s = -np.inf
        self.queue_check_s = -np.inf
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
        """Refresh the schedule's next-event times and counts after a task event."""
        f, sch = self.fleet, self.schedule
        busy = f.task >= 0
        work = f.state == WORKING
        sch.next_end_s = float(f.work_end_s[work].min(initial=np.inf))
        driving = busy & (f.state == DRIVING)  # a deadline is one to begin work by
        sch.next_deadline_s = float(f.deadline_s[driving].min(initial=np.inf))
        backing = f.replan | (f.backoff_until_s > self.clock.time_s)
        sch.n_backoff = int(np.count_nonzero(backing))
        sch.n_yield = int(np.count_nonzero(f.yielding))
        sch.n_steer = int(np.count_nonzero(f.state == DRIVING)) + sch.n_yield
        if self.keep_lists:
            sch.state_list = f.state.tolist()
            steering = (f.state == DRIVING) | f.yielding  # driving, backing off, yielding
            sch.steer_list = steering.nonzero()[0].tolist()
        sch.stuck_check_s = sch.prox_check_s = -np.inf
        sch.resting = False

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
            self.refresh()

    def end_due(self, t: float) -> None:
        """End the work that is done and the tasks whose robot has not begun work by their
        deadline (work begun is finished: the deadline bounds getting there)."""
        f = self.fleet
        if self.clear_sites and t >= self.queue_check_s:
            self.queue(t)
        if t + 1e-9 >= self.schedule.next_end_s:
            self.finish_work(t)
        if t > self.schedule.next_deadline_s:
            late = ((f.task >= 0) & (f.state == DRIVING) & (f.deadline_s < t)).nonzero()[0]
            for j in late.tolist():
                self.finish(j, t, False, "timeout: not at work by its deadline", False)
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
        self.follower.clear(j)
        if self.clear_sites:
            self.admitted[j] = self.holding[j] = False
            self.leave(j, t_done_s)
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
        self.admitted[j] = self.holding[j] = False
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
            stalest = float(f.t_progress_s.min())
        self.schedule.stuck_check_s = stalest + timeout

    def recover(self, j: int, t: float) -> None:
        """Robot j is stuck: wait for a robot at work that boxes it in, go round a standing one,
        or back off on a random arc and replan; after ``max_recoveries`` tries, fail."""
        sp, f = self.spatial, self.fleet
        b, z = int(f.blocker[j]), f.last_z_m
        blocked = b >= 0 and f.near_m[j] < self.reach_m + YIELD_TRIGGER_M
        if blocked and f.state[b] == WORKING and f.work_end_s[b] - t <= sp.stuck_timeout_s:
            # boxed in by a robot at work that is nearly done: not stuck, wait for it
            f.t_progress_s[j] = f.work_end_s[b]
            return
        if self.clear_sites:
            taken = (f.state == WORKING) & (np.abs(z - f.site[j]) < 2.0 * self.controller.radius_m)
            if taken.any():  # its site is taken by a robot at work: wait for it to step clear
                f.t_progress_s[j] = float(f.work_end_s[taken].min())
                return
            if self.go_round(j, t) or self.give_way(j, t):
                return
        f.recoveries[j] += 1
        f.stuck_left_m[j] = f.left_m[j]  # where it got stuck (path left to drive)
        self.schedule.recovering = True
        if f.recoveries[j] > sp.max_recoveries:
            why = f"stuck: no progress for {sp.stuck_timeout_s:g} s after {sp.max_recoveries} tries"
            return self.finish(j, t, False, why)
        if blocked and f.state[b] != DRIVING:
            travel = np.exp(1j * self.bodies[j].angle)
            site = (f.site[j].real, f.site[j].imag)
            others = np.delete(z, j)
            path = self.planner.detour(z[j], z[b], travel, DETOUR_M, site, others)
            if len(path):  # go round the robot that stands in the way
                self.follower.set_path(j, path)
                f.progress_m[j], f.t_progress_s[j] = np.inf, t
                return
        c = self.controller
        turn = self.rng.uniform(-0.5, 0.5) * c.omega_max_radps
        f.backoff_cmd[j] = (-0.3 * c.v_max_mps, turn)
        f.backoff_until_s[j] = t + BACKOFF_S
        f.t_progress_s[j] = np.inf
        f.replan[j] = True
        self.follower.clear(j)
        self.refresh()

    def recovered(self, rows: list[int]) -> None:
        """Robots ``rows`` came ``RECOVERED_M`` closer to their site than where they last got
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
        path = self.planner.path(xy, (f.site[j].real, f.site[j].imag))
        if not len(path):
            self.finish(j, t, False, f"unreachable: no path from {_xy(xy)} after a recovery")
            return
        self.follower.set_path(j, path)
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.schedule.site_check_s = -np.inf
        self.refresh()

    def make_way(self, pushers, blocker, z, h, v, t: float) -> None:
        """Idle robots standing in a driving robot's way step aside (planning ignores robots).

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
            travel = h[j] if v[j] >= 0 else -h[j]
            # the side step's end point must keep YIELD_STEP_M / 2 from the other robots: only
            # those within 1.5 YIELD_STEP_M of b could be that close (2 for rounding)
            close = np.abs(z - z[b]) < 2.0 * YIELD_STEP_M
            close[b] = False
            path = self.planner.side_step(z[b], z[j], travel, YIELD_STEP_M, z[close])
            if len(path):
                rows.append(b)
                paths.append(path)
                f.yielding[b], f.yield_until_s[b] = True, t + YIELD_TIMEOUT_S
        self.follower.set_paths(rows, paths)
        self.refresh()

    def go_round(self, j: int, t: float) -> bool:
        """Robot j is stuck among other robots (collision avoidance on; within ``AROUND_M``):
        it plans a path to its site with them as obstacles (``GridPlanner.path_around``) and
        takes it if it is at most ``DETOUR_FACTOR`` times the path it had plus
        ``DETOUR_EXTRA_M``, counting a try. If one of them has just done so in this check, j
        waits one stuck timeout for it instead. False, and nothing changes, when no robot is
        near, j has used its tries or no such path exists (then :meth:`give_way`)."""
        f, z = self.fleet, self.fleet.last_z_m
        close = np.abs(z - z[j]) < AROUND_M
        close[j] = False
        if not close.any() or f.recoveries[j] >= self.spatial.max_recoveries:
            return False
        if (self.around_s[close] == t).any():  # another of this jam just went round
            f.t_progress_s[j] = t
            return True
        site = (f.site[j].real, f.site[j].imag)
        path = self.planner.path_around(
            (z[j].real, z[j].imag), site, z[close], self.controller.radius_m
        )
        if not len(path):
            return False
        length = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
        if length > DETOUR_FACTOR * f.left_m[j] + DETOUR_EXTRA_M:
            return False
        f.recoveries[j] += 1
        self.around_s[j] = t
        self.follower.set_path(j, path)
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.refresh()
        return True

    def standing_near(self, t: float) -> list[tuple[int, int]]:
        """Collision avoidance on: (j, k) for each driving robot j commanded to stand (below
        ``STILL_MPS``; not holding in a queue, backing off or replanning) for ``PASS_S`` since
        its last progress whose nearest robot k is within ``NEAR_M``. Found once per control
        period for :meth:`pass_workers` and :meth:`break_jams` (the nearest-robot search is
        a k-d tree over the fleet in a large team)."""
        f = self.fleet
        if t - float(f.t_progress_s.min()) < PASS_S:
            return []
        still = (f.state == DRIVING) & (np.abs(f.v_cmd_mps) < STILL_MPS) & ~self.holding
        still &= ~f.replan & (f.backoff_until_s <= t) & (t - f.t_progress_s >= PASS_S)
        rows = still.nonzero()[0]
        if not len(rows):
            return []
        other, dist = nearest_other(f.last_z_m, rows)
        pairs = zip(rows.tolist(), other.tolist(), dist.tolist(), strict=True)
        return [(j, k) for j, k, d in pairs if d < NEAR_M]

    def pass_workers(self, t: float, near: list[tuple[int, int]] | None = None) -> None:
        """Collision avoidance on, after a control period: a robot standing beside a robot at
        work (:meth:`standing_near`) for another site with more than ``PASS_S`` of work
        left plans its way to its
        place (``fleet.site``: the service point, or the slot it was let in to) round the
        robots within ``AROUND_M`` (``GridPlanner.path_around``) and takes that path if it is
        longer than the path it has left (else no robot is in its way: it stands for another
        reason, such as turning) by at most ``PASS_EXTRA_M``, and the extra drive at top speed
        takes less than the work left. Not a recovery try: waiting beside a robot at
        work that is in the way is not being stuck, only slow (README, "Collision
        avoidance"); a robot that does not take the path is asked again in the next period."""
        f, z = self.fleet, self.fleet.last_z_m
        v_max, radius = self.follower.v_max_mps, self.controller.radius_m
        near = self.standing_near(t) if near is None else near
        for j, k in near:
            if f.state[k] != WORKING:
                continue
            if abs(self.service[j] - self.service[k]) < 1e-6:  # k works at j's site: the
                continue  # site's queue decides (service: the site; f.site: the place to go)
            left_s = f.work_end_s[k] - t
            if left_s <= PASS_S:
                continue
            close = np.abs(z - z[j]) < AROUND_M
            close[j] = False
            site = (f.site[j].real, f.site[j].imag)
            path = self.planner.path_around((z[j].real, z[j].imag), site, z[close], radius)
            if not len(path):
                continue
            extra = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum()) - f.left_m[j]
            if extra <= PROGRESS_M or extra > PASS_EXTRA_M or extra / v_max >= left_s:
                continue  # the way it has (no robot in it), too long, or slower than waiting
            self.follower.set_path(j, path)
            f.progress_m[j], f.t_progress_s[j] = np.inf, t
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
        counted as in :meth:`recover`; a robot for which neither applies waits for the stuck
        timeout as before."""
        f, z = self.fleet, self.fleet.last_z_m
        near = self.standing_near(t) if near is None else near
        if not near:
            return
        drives = f.state == DRIVING
        driving, standing = z[drives], z[~drives]  # (no robot stops or starts in the loop)
        for j, k in near:
            if not drives[k] or t - f.t_progress_s[j] < PASS_S:
                continue  # (pass_workers may have given j a path in this period)
            lane = self.single_lane(j, k, standing) or self.single_lane(k, j, standing)
            if not (lane or self.standoff(j, k, driving)):
                continue
            if not self.go_round(j, t):
                self.give_way(j, t)

    def single_lane(self, j: int, k: int, standing: np.ndarray | None = None) -> bool:
        """True if robot j cannot step aside of the line toward robot k: neither point two
        radii plus ``LANE_GAP_M`` to its side is on the planner's free space (which keeps a
        radius and the clearance from obstacles) clear of the robots that stand (at work or
        idle) by two radii. A gap or door narrower than about 2 x (2 radii + clearance) +
        ``LANE_GAP_M`` is single-lane, as is an aisle a robot at work narrows so; open floor,
        or a 2 m aisle (for 0.25 m robots), is not. ``standing``: the positions of the robots
        not driving, if the caller has them."""
        f, r = self.fleet, self.controller.radius_m
        z = f.last_z_m
        u = (z[k] - z[j]) / max(abs(z[k] - z[j]), 1e-9)
        side = z[j] + 1j * u * np.array([1.0, -1.0]) * (2.0 * r + LANE_GAP_M)
        free = self.planner.free(np.column_stack([side.real, side.imag]))
        if not free.any():
            return True
        standing = z[f.state != DRIVING] if standing is None else standing
        if len(standing):
            free &= (np.abs(side[:, None] - standing[None, :]) >= 2.0 * r).all(axis=1)
        return not free.any()

    def standoff(self, j: int, k: int, driving: np.ndarray | None = None) -> bool:
        """True if robots j and k stand together alone: k too is commanded to stand, and no
        other driving robot is within ``DEADLOCK_M`` of j (which way they face is not looked
        at). Two robots whose ways cross
        can stop each other for good where ORCA's half-planes leave each only a standstill; in a
        crowd (the circle swap) robots stop a moment in turn, and ORCA sorts them out.
        ``driving``: the positions of the driving robots, if the caller has them."""
        f, z = self.fleet, self.fleet.last_z_m
        if abs(f.v_cmd_mps[k]) >= STILL_MPS:
            return False
        driving = z[f.state == DRIVING] if driving is None else driving
        return int(np.count_nonzero(np.abs(driving - z[j]) < DEADLOCK_M)) == 2  # j and k

    def give_way(self, j: int, t: float) -> bool:
        """Deadlock between driving robots (collision avoidance on; no robot pushes): of robot
        j and the driving robots within ``DEADLOCK_M``, the one with the highest index that can
        back out (:meth:`backed_in`: its way back is free; and it has tries left; the highest
        index if none can) goes back to ``DEADLOCK_M`` beyond where it was given its task (or
        there, if that is not free) and only then on to its site, so the others get through;
        the others wait. A robot with another in its way back cannot back out: choosing it
        would leave the jam as it was. Giving way is a try (``max_recoveries``): a robot chosen
        again and again while it cannot move (a robot that waits for it boxes it in) is not
        chosen once its tries are used, so the choice passes to another, and the wait is
        bounded. True if j gave way or waits."""
        f, z = self.fleet, self.fleet.last_z_m
        close = (f.state == DRIVING) & ~self.holding & (np.abs(z - z[j]) < DEADLOCK_M)
        close[j] = False
        if not close.any():
            return False
        jam = np.append(close.nonzero()[0], j)
        tries = self.spatial.max_recoveries
        free = [k for k in jam.tolist() if f.recoveries[k] < tries and not self.backed_in(k)]
        if j != max(free or jam.tolist()):
            f.t_progress_s[j] = t  # the other one gives way: wait for it
            return True
        if f.recoveries[j] >= tries:
            return False
        refuge = self.refuge(j)
        xy, spot = (z[j].real, z[j].imag), (refuge.real, refuge.imag)
        back = self.planner.path(xy, spot)
        on = self.planner.path(spot, (f.site[j].real, f.site[j].imag))
        if not (len(back) and len(on)) or abs(z[j] - refuge) < 0.5 * DEADLOCK_M:
            return False
        f.recoveries[j] += 1
        self.follower.set_path(j, np.concatenate([back, on[1:]]))
        f.progress_m[j], f.t_progress_s[j] = np.inf, t
        self.refresh()
        return True

    def refuge(self, j: int) -> complex:
        """Where robot j backs out to when it gives way: ``DEADLOCK_M`` beyond where it was
        given its task, away from where it is (that place itself if the point is not free)."""
        z = self.fleet.last_z_m[j]
        away = self.origin[j] - z
        refuge = self.origin[j] + DEADLOCK_M * away / max(abs(away), 1e-9)
        if not self.planner.free(np.array([[refuge.real, refuge.imag]]))[0]:
            refuge = self.origin[j]
        return refuge

    def backed_in(self, j: int) -> bool:
        """True if another robot stands in robot j's way back: within two radii plus
        ``SLOT_GAP_M`` of the first ``DEADLOCK_M`` of the path toward its :meth:`refuge`, and
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
        take = start < DEADLOCK_M  # the segments of the first DEADLOCK_M of the way
        a, d, s0 = way[:-1][take], seg[take], start[take]
        others = np.delete(np.arange(len(z)), j)
        rel = (z[others, None] - a[None, :]) / d[None, :]  # in each segment's frame, / length
        u = np.clip(rel.real, 0.0, 1.0)
        dist = np.abs(z[others, None] - (a[None, :] + u * d[None, :]))
        best = dist.argmin(axis=1)
        rows = np.arange(len(others))
        along = s0[best] + u[rows, best] * np.abs(d[best])
        near = dist[rows, best] < 2.0 * r + SLOT_GAP_M
        return bool((near & (along > r) & (along < DEADLOCK_M)).any())

    def take_slots(self, rows: list[int], z: np.ndarray, t: float) -> None:
        """Robots ``rows`` are near their site and not there: where a standing robot takes the
        service point, each goes to the nearest free service slot instead (``SLOTS`` points on
        a ring two robot radii plus ``SLOT_GAP_M`` around it, clear of obstacles, of standing
        robots and of the slots other robots drive to) and works there; with none free it
        waits where it is for the service point."""
        f, r = self.fleet, self.controller.radius_m
        ring, room = 2.0 * r + SLOT_GAP_M, 2.0 * r + 0.5 * SLOT_GAP_M
        standing = ((f.state != DRIVING) & ~f.yielding).nonzero()[0]
        changed, idle = False, []
        for j in rows:
            site = f.site[j]
            if self.slotted[j] or self.holding[j]:
                continue  # a slot already, or holding in the site's queue
            if not len(standing) or np.abs(z[standing] - site).min() >= room:
                continue  # the service point is free
            on_it = standing[np.abs(z[standing] - site) < room]
            if (f.state[on_it] == IDLE).all():  # finished there: it steps clear
                idle += [int(b) for b in on_it if not f.yielding[b] and int(b) not in idle]
                continue
            cand = site + ring * np.exp(2j * np.pi * np.arange(SLOTS) / SLOTS)
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
            self.follower.set_path(j, path)
            f.progress_m[j], f.t_progress_s[j] = np.inf, t
            changed = True
        if idle:
            self.step_clear(idle, t)
        if changed or idle:
            self.refresh()

    def queue(self, t: float) -> None:
        """Site queues (collision avoidance on). A driving robot not yet let in that is within
        ``QUEUE_M`` of its site, or within ``CROWD_M`` of a robot holding for that site, is let
        in while the site has a free place (its service point and obstacle-free slots, less
        the robots let in or at work there), first come first served; otherwise it holds
        where it is (a path to its own position; its stuck clock stopped, so it is drawn as
        waiting) until a place is free. Holding does not use up a task's time: the deadline
        of a robot let in after holding moves on by the time it held, and while it holds it
        has ``HOLD_MAX_S`` more. Schedules the next check."""
        f, z = self.fleet, self.fleet.last_z_m
        driving = (f.state == DRIVING) & ~f.replan & (f.backoff_until_s <= t)
        if not driving.any():
            self.queue_check_s = np.inf
            return
        gap = np.abs(z - self.service)
        cand = driving & ~self.admitted
        near = cand & (gap < QUEUE_M)
        held = self.holding.nonzero()[0]
        if len(held):
            rest = cand.nonzero()[0]
            same = np.abs(self.service[rest, None] - self.service[held][None, :]) < 1e-6
            crowd = same & (np.abs(z[rest, None] - z[held][None, :]) < CROWD_M)
            near[rest[crowd.any(axis=1)]] = True
        far = float(np.where(driving & (gap >= QUEUE_M), gap, np.inf).min()) - QUEUE_M
        self.queue_check_s = next_check_s(t, far, SPEED_BOUND * self.follower.v_max_mps)
        if (driving & (gap < QUEUE_M)).any():  # robots hold or come in: look next period
            self.queue_check_s = t
        rows = near.nonzero()[0]
        if len(rows):
            self.let_in_or_hold(rows, gap, t)
        self.clear_loiterers(driving & ((self.admitted & (gap < QUEUE_M)) | self.holding), t)

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
                f.deadline_s[j] += HOLD_MAX_S  # waiting its turn does not run its clock out
                here = np.array([[z[j].real, z[j].imag]] * 2)
                self.follower.set_path(j, here)
                f.progress_m[j], f.t_progress_s[j] = -np.inf, np.inf  # no stuck clock
                changed = True
        if changed:
            self.refresh()

    def free_place(self, j: int) -> complex | None:
        """The place robot j would be given at its site now: the service point if free, else
        the free slot nearest to it; a place is taken when a robot let in to or at work at that
        site keeps it or a robot that is not driving (at work, idle, on its way out) stands
        within two radii and half ``SLOT_GAP_M`` of it. None if every place is taken."""
        f, r = self.fleet, self.controller.radius_m
        z, site = f.last_z_m, self.service[j]
        cand = self.place_points(site)
        mine = (self.admitted | (f.state == WORKING)) & (np.abs(self.service - site) < 1e-6)
        mine[j] = False
        kept = f.site[mine]
        standing = (f.state != DRIVING).nonzero()[0]
        room = 2.0 * r + 0.5 * SLOT_GAP_M
        taken = np.zeros(len(cand), dtype=bool)
        if len(kept):
            taken |= np.abs(kept[:, None] - cand[None, :]).min(axis=0) < 1e-6
        if len(standing):
            taken |= np.abs(z[standing][:, None] - cand[None, :]).min(axis=0) < room
        if taken.all():
            return None
        free = (~taken).nonzero()[0]
        return complex(cand[0] if free[0] == 0 else cand[free[np.abs(cand[free] - z[j]).argmin()]])

    def let_in(self, j: int, place: complex, t: float) -> bool:
        """Robot j goes to ``place`` (:meth:`free_place`) at its site now; one that held has its
        deadline moved on by the time it held. True if its path changed."""
        f, z, site = self.fleet, self.fleet.last_z_m, self.service[j]
        self.admitted[j] = True
        held = self.holding[j]
        if held:
            self.holding[j] = False
            f.deadline_s[j] += t - self.hold_since_s[j] - HOLD_MAX_S
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
        (``SLOTS`` on a ring two robot radii plus ``SLOT_GAP_M`` round it), x + iy (cached)."""
        if site not in self._places:
            ring = 2.0 * self.controller.radius_m + SLOT_GAP_M
            cand = site + ring * np.exp(2j * np.pi * np.arange(SLOTS) / SLOTS)
            ok = self.planner.free(np.column_stack([cand.real, cand.imag]))
            self._places[site] = np.concatenate([[site], cand[ok]])
        return self._places[site]

    def clear_loiterers(self, coming: np.ndarray, t: float) -> None:
        """Idle robots standing within ``QUEUE_M`` of a site that robots ``coming`` (a mask:
        let in to it, or holding in its queue) come to drive out (:meth:`leave`)."""
        f = self.fleet
        idle = (f.state == IDLE) & ~f.yielding & ~self.broken
        if not (idle.any() and coming.any()):
            return
        sites = np.unique(self.service[coming])
        near = np.abs(f.last_z_m[idle][:, None] - sites[None, :]) < QUEUE_M
        moved = False
        for j, k in zip(*near.nonzero(), strict=True):
            j = int(idle.nonzero()[0][j])
            if not f.yielding[j]:
                moved |= self.leave(j, t, complex(sites[k]))
        if moved:
            self.refresh()

    def leave(self, j: int, t: float, site: complex | None = None) -> bool:
        """Robot j finished (or failed, or stands idle) near ``site`` (its task's by default)
        that other robots come to (within ``QUEUE_M + EXIT_M``): it drives out,
        ``EXIT_M`` beyond ``QUEUE_M`` from the site, to the free one of 11 end points (straight
        away from the site, then turned by 30 to 150 degrees either way) whose straight line
        passes farthest from the robots around it (clearances of two robot reaches and more
        count alike; then the least turned), so the next in the queue gets its place; a line
        closer than one reach to a robot let in to that site does not count (if none is left
        it stays, and is asked again). True if it drives out; the caller calls
        :meth:`refresh`."""
        f, z = self.fleet, self.fleet.last_z_m[j]
        site = self.service[j] if site is None else site
        if abs(z - site) >= QUEUE_M or self.broken[j]:
            return False
        coming = (f.state == DRIVING) & (np.abs(self.service - site) < 1e-6)
        coming &= np.abs(f.last_z_m - site) < QUEUE_M + EXIT_M
        if not coming.any():
            return False
        away = z - site
        if abs(away) < 1e-3:
            away = -np.exp(1j * self.bodies[j].angle)
        away /= abs(away)
        turns = np.radians(np.arange(-150, 151, 30))
        ends = site + (QUEUE_M + EXIT_M) * away * np.exp(1j * turns)
        ok = self.planner.free(np.column_stack([ends.real, ends.imag]))
        # the straight way out that passes farthest from the robots around (ties: least turned)
        around = np.abs(f.last_z_m - z) < QUEUE_M + EXIT_M
        around[j] = False
        clear = self.clearance(z, ends, f.last_z_m[around])
        # ... and never straight at a robot driving in (let in, not holding): both would stop
        ok &= self.clearance(z, ends, f.last_z_m[around & coming & self.admitted]) >= self.reach_m
        order = np.lexsort((np.abs(turns), -np.minimum(clear, 2.0 * self.reach_m)))
        for k in order[ok[order]].tolist():
            path = self.planner.path((z.real, z.imag), (ends[k].real, ends[k].imag))
            if len(path):
                self.follower.set_path(j, path)
                f.yielding[j], f.yield_until_s[j] = True, t + EXIT_TIMEOUT_S
                return True
        return False

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
        ``YIELD_STEP_M`` aside (to the left or right of its heading, whichever is free); one
        with no free step stays where it is. The caller calls :meth:`refresh`."""
        f, z = self.fleet, self.fleet.last_z_m
        steps, paths = [], []
        for j in rows:
            if self.broken[j]:  # a broken robot cannot step anywhere
                continue
            travel = np.exp(1j * self.bodies[j].angle)
            close = np.abs(z - z[j]) < 2.0 * YIELD_STEP_M
            close[j] = False
            path = self.planner.side_step(z[j], z[j] - travel, travel, YIELD_STEP_M, z[close])
            if len(path):
                steps.append(j)
                paths.append(path)
                f.yielding[j], f.yield_until_s[j] = True, t + YIELD_TIMEOUT_S
        self.follower.set_paths(steps, paths)

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Service slots, where each robot was given its task and the failures so far (between
        sets: no completion is waiting to be handed out)."""
        if self.done:
            raise RuntimeError("jobs state requested with completions not handed out")
        return {
            "slotted": self.slotted.copy(),
            "origin": self.origin.copy(),
            "service": self.service.copy(),
            "admitted": self.admitted.copy(),
            "holding": self.holding.copy(),
            "hold_since_s": self.hold_since_s.copy(),
            "queue_check_s": np.array(self.queue_check_s),
            "failures": np.array(self.failures, dtype=np.int64),
        }

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays`, then the schedule's lists and counts again."""
        self.slotted = np.array(arrays["slotted"], dtype=bool)
        self.origin = np.array(arrays["origin"], dtype=complex)
        m = len(self.origin)
        # checkpoints written before site queues existed hold none of these: nobody queued
        self.service = np.array(arrays.get("service", self.fleet.site), dtype=complex)
        self.admitted = np.array(arrays.get("admitted", np.zeros(m)), dtype=bool)
        self.holding = np.array(arrays.get("holding", np.zeros(m)), dtype=bool)
        self.hold_since_s = np.array(arrays.get("hold_since_s", np.full(m, np.inf)), dtype=float)
        self.queue_check_s = float(arrays.get("queue_check_s", -np.inf))
        self.failures = int(arrays["failures"])

    def stop_yield(self, j: int) -> None:
        """Robot j stops yielding (the caller calls :meth:`refresh` after)."""
        self.fleet.yielding[j] = False
        self.follower.clear(j)


def _xy(p) -> str:
    return f"({float(p[0]):.2f}, {float(p[1]):.2f})"
