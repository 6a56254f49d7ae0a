"""The task side of :class:`sim.physics.PymunkWorld`: arrive, work, finish, stuck, recover, yield.

The array part runs every control period over the robot axis (steering targets, progress); the
checks that can only fire later (arrival, stuck, end of work, deadline) are skipped until the
earliest time they could; the per-robot Python runs on events only.
"""

from __future__ import annotations

import numpy as np

from sim.recording import DRIVING, IDLE, WORKING
from sim.world import Completion

BACKOFF_S = 1.5  # a stuck robot reverses on a random arc this long, then replans
RECOVERED_M = 5.0  # this much closer to its site than where it got stuck, its tries start again
YIELD_TRIGGER_M = 0.3  # a driving robot this close (beyond contact) to an idle one asks it to move
YIELD_STEP_M = 1.0  # how far an idle robot steps aside
YIELD_TIMEOUT_S = 6.0
DETOUR_M = 1.0  # a robot blocked by one that stands still passes it this far to the side
PROGRESS_M = 0.05  # less progress than this along the path does not reset the stuck clock
SPEED_BOUND = 1.25  # no robot moves faster than this times the top speed, even when pushed


class JobsMixin:
    """Task bookkeeping of the pymunk world (its arrays are created by ``PymunkWorld.reset``)."""

    def _jobs(self, z: np.ndarray, hc: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance every robot's task (arrive, work, finish, stuck, recover); desired twists."""
        self.off_path_ = None
        go = self.state_ == DRIVING
        steered = go | self.yielding_ if self.n_yield_ else go
        back = None
        if self.n_backoff_:
            back = go & (self.backoff_until_s_ > t)
            for j in (self.replan_ & ~back).nonzero()[0].tolist():
                self._replan(j, (z[j].real, z[j].imag), t)
            go = (self.state_ == DRIVING) & ~back
            steered = go | self.yielding_
        if self.n_steer_ if back is None else np.count_nonzero(steered):
            aim, gap, left, corner2, self.off_path_ = self.follower.targets(z)
            v, w = self.controller.steer(hc, aim, gap, corner2)
            if back is not None or self.n_steer_ < len(v):
                v *= steered
                w *= steered
            np.copyto(self.left_m_, left, where=steered)
            if self.n_yield_:
                stop = self.yielding_ & ((left < 0.15) | (self.yield_until_s_ < t))
                if np.count_nonzero(stop):
                    for j in stop.nonzero()[0].tolist():
                        self._stop_yield(j, refresh=False)
                        v[j] = w[j] = 0.0
                    self._events()
            better = left < self.progress_m_
            better &= go
            if np.count_nonzero(better):
                np.putmask(self.progress_m_, better, left - PROGRESS_M)
                np.putmask(self.t_progress_s_, better, t)
                if self.recovering_:  # got past where it last got stuck: tries start again
                    past = better & (left < self.stuck_left_m_ - RECOVERED_M)
                    if np.count_nonzero(past):
                        self._recovered(past.nonzero()[0].tolist())
            if t > self.stuck_check_s_:
                self._stuck(go, t)
            if t >= self.site_check_s_:
                self._arrive(z, go, v, w, t)
        else:
            v, w = np.zeros(len(z)), np.zeros(len(z))
        if back is not None:
            v[back], w[back] = self.backoff_cmd_[back].T
        self._clock(t)
        return v, w

    def _stuck(self, go: np.ndarray, t: float) -> None:
        """Recover robots without progress for ``stuck_timeout_s``; schedule the next check."""
        timeout = self.spatial.stuck_timeout_s
        stalest = float(self.t_progress_s_.min())  # only rises: set to t, later or inf
        if t - stalest > timeout:
            for j in (go & (t - self.t_progress_s_ > timeout)).nonzero()[0].tolist():
                self._recover(j, t)
            stalest = float(self.t_progress_s_.min())
        self.stuck_check_s_ = stalest + timeout

    def _arrive(self, z: np.ndarray, go: np.ndarray, v: np.ndarray, w: np.ndarray, t: float):
        """Robots at their site (or beside robots standing there) start work; schedule the next
        check for when the driving robot nearest its arrival zone could first be in it."""
        sp = self.spatial
        gap = np.abs(self.site_ - z)
        zone = sp.arrive_tol_m + 2 * self.reach_m_
        there = go & (gap <= zone)
        if np.count_nonzero(there):  # near the site: arrived, or beside robots standing there
            queue = (there & (gap > sp.arrive_tol_m) & (self.near_ <= self.reach_m_)).nonzero()[0]
            there &= gap <= sp.arrive_tol_m
            if queue.size:  # touching a robot that stands nearer the site: the site is taken,
                # and working beside the robots already there counts as arrived
                standing = (self.state_ != DRIVING) & ~self.yielding_
                if len(z) <= self.controller.dense_max:  # every queued robot, every standing one
                    zs = z[standing.nonzero()[0]]
                    nearer = np.abs(zs[None, :] - self.site_[queue, None]) < gap[queue, None]
                    nearer &= np.abs(zs[None, :] - z[queue, None]) <= self.reach_m_  # touching
                    there[queue] = nearer.any(axis=1)
                else:  # ... against its neighbours only (look_m > reach_m_)
                    i, k = self.controller.neighbour_pairs(z)
                    queued = np.zeros(len(z), dtype=bool)
                    queued[queue] = True
                    sel = (queued[i] & standing[k]).nonzero()[0]
                    i, k = i[sel], k[sel]
                    nearer = np.abs(z[k] - self.site_[i]) < gap[i]
                    nearer &= np.abs(z[k] - z[i]) <= self.reach_m_  # touching
                    there[queue] = False
                    there[i[nearer]] = True
            self._start_work(there.nonzero()[0].tolist(), v, w, t)
        nearest = float(np.where(go, gap, np.inf).min()) - zone
        self.site_check_s_ = t + max(nearest, 0.0) / (SPEED_BOUND * self.controller.v_max_mps)

    def _start_work(self, arrived: list[int], v, w, t: float) -> None:
        """The robots ``arrived`` start work now; their commands ``v``, ``w`` become zero."""
        for j in arrived:
            self.state_[j] = WORKING
            self.work_end_s_[j] = t + self.exec_time_s_[self.type_[j]]
            self.t_progress_s_[j] = np.inf
            self.follower.clear(j)
            v[j] = w[j] = 0.0
            self.next_end_s_ = min(self.next_end_s_, self.work_end_s_[j])
        if arrived:
            self._events()

    def _clock(self, t: float) -> None:
        """End the work that is done and the tasks past their deadline."""
        if t + 1e-9 >= self.next_end_s_:
            self._finish_work(t)
        if t > self.next_deadline_s_:
            late = ((self.task_ >= 0) & (self.deadline_s_ < t)).nonzero()[0]
            for j in late.tolist():
                self._finish(j, t, False, "timeout: task not finished by its deadline", False)
            if late.size:
                self._events()

    def _finish_work(self, t: float) -> None:
        done = ((self.state_ == WORKING) & (self.work_end_s_ <= t + 1e-9)).nonzero()[0]
        for j in done.tolist():
            self._finish(j, float(self.work_end_s_[j]), True, refresh=False)
        if done.size:
            self._events()

    def _make_way(self, pushers, blocker, z, h, v, t: float) -> None:
        """Idle robots standing in a driving robot's way step aside (planning ignores robots)."""
        rows, paths = [], []
        for j in pushers.tolist():
            b = int(blocker[j])
            if self.yielding_[b]:  # asked by another robot in this period
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
                self.yielding_[b], self.yield_until_s_[b] = True, t + YIELD_TIMEOUT_S
        self.follower.set_paths(rows, paths)
        self._events()

    def _stop_yield(self, j: int, refresh: bool = True) -> None:
        """Robot j stops yielding (``refresh=False``: the caller calls ``_events`` after)."""
        self.yielding_[j] = False
        self.follower.clear(j)
        if refresh:
            self._events()

    def _events(self) -> None:
        """Refresh the scalar next-event times and counts after a task event."""
        busy = self.task_ >= 0
        work = self.state_ == WORKING
        self.next_end_s_ = float(self.work_end_s_[work].min(initial=np.inf))
        self.next_deadline_s_ = float(self.deadline_s_[busy].min(initial=np.inf))
        backing = self.replan_ | (self.backoff_until_s_ > self.time_s)
        self.n_backoff_ = int(np.count_nonzero(backing))
        self.n_yield_ = int(np.count_nonzero(self.yielding_))
        self.n_steer_ = int(np.count_nonzero(self.state_ == DRIVING)) + self.n_yield_
        if self.small_:  # the same as Python lists, for the scalar control period
            self.state_list_ = self.state_.tolist()
            steering = (self.state_ == DRIVING) | self.yielding_  # driving, backing off, yielding
            self.steer_list_ = steering.nonzero()[0].tolist()
        self.stuck_check_s_ = self.prox_check_s_ = -np.inf
        self.resting_ = False

    def _recover(self, j: int, t: float) -> None:
        sp = self.spatial
        b, z = int(self.blocker_[j]), self.last_z_
        blocked = b >= 0 and self.near_[j] < self.reach_m_ + YIELD_TRIGGER_M
        if blocked and self.state_[b] == WORKING and self.work_end_s_[b] - t <= sp.stuck_timeout_s:
            # boxed in by a robot at work that is nearly done: not stuck, wait for it
            self.t_progress_s_[j] = self.work_end_s_[b]
            return
        self.recoveries_[j] += 1
        self.stuck_left_m_[j] = self.left_m_[j]  # where it got stuck (path left to drive)
        self.recovering_ = True
        if self.recoveries_[j] > sp.max_recoveries:
            why = f"stuck: no progress for {sp.stuck_timeout_s:g} s after {sp.max_recoveries} tries"
            return self._finish(j, t, False, why)
        if blocked and self.state_[b] != DRIVING:
            travel = np.exp(1j * self.robots_[j].angle)
            site = (self.site_[j].real, self.site_[j].imag)
            others = np.delete(z, j)
            path = self.planner.detour(z[j], z[b], travel, DETOUR_M, site, others)
            if len(path):  # go round the robot that stands in the way
                self.follower.set_path(j, path)
                self.progress_m_[j], self.t_progress_s_[j] = np.inf, t
                return
        c = self.controller
        turn = self.rng_.uniform(-0.5, 0.5) * c.omega_max_radps
        self.backoff_cmd_[j] = (-0.3 * c.v_max_mps, turn)
        self.backoff_until_s_[j] = t + BACKOFF_S
        self.t_progress_s_[j] = np.inf
        self.replan_[j] = True
        self.follower.clear(j)
        self._events()

    def _recovered(self, rows: list[int]) -> None:
        """Robots ``rows`` came ``RECOVERED_M`` closer to their site than where they last got
        stuck: that obstruction is behind them, and their tries start again."""
        for j in rows:
            self.recoveries_[j] = 0
            self.stuck_left_m_[j] = np.inf
        self.recovering_ = bool(np.isfinite(self.stuck_left_m_).any())

    def _replan(self, j: int, xy: np.ndarray, t: float) -> None:
        self.replan_[j] = False
        path = self.planner.path(xy, (self.site_[j].real, self.site_[j].imag))
        if not len(path):
            self._finish(j, t, False, f"unreachable: no path from {_xy(xy)} after a recovery")
            return
        self.follower.set_path(j, path)
        self.progress_m_[j], self.t_progress_s_[j] = np.inf, t
        self.site_check_s_ = -np.inf
        self._events()

    def _finish(
        self, j: int, t_done_s: float, ok: bool, reason: str = "", refresh: bool = True
    ) -> None:
        """Report robot j's task as a Completion and free the robot (``refresh=False``: the
        caller calls ``_events`` once after a batch; nothing reads the event times between)."""
        task, t_alloc, bid = int(self.task_[j]), float(self.t_alloc_s_[j]), float(self.bid_[j])
        odo = float(self.moved_m_[j] - self.odo0_m_[j])
        self.done_.append(Completion(task, j, t_alloc, t_done_s, bid, odo, ok, reason))
        self.failures_ += not ok
        self.task_[j] = -1
        self.state_[j] = IDLE
        self.stuck_left_m_[j] = np.inf
        self.replan_[j] = False
        self.backoff_until_s_[j] = -np.inf
        self.t_progress_s_[j] = np.inf
        self.follower.clear(j)
        if refresh:
            self._events()


def _xy(p) -> str:
    return f"({float(p[0]):.2f}, {float(p[1]):.2f})"
