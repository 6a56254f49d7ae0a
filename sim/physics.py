"""The spatial world: differential-drive robots in a pymunk arena (SPEC §6).

One ``pymunk.Space`` (no gravity, SI units, fixed step ``dt_s``, collision slop in metres) holds
the arena walls, the static obstacles and the robots, which ``sim.drive.Motors`` drives with motor
joints (never by writing body velocities, which would discard the contact solution). Control runs
at ``control_hz``: each period reads every pose with one ``pymunk.batch`` call, advances the
robots' tasks (plan, drive, arrive, work, finish; stuck detection and recovery), computes wheel
commands with numpy over the robot axis and writes them back with one batch call; then several
``space.step`` calls run with no Python around them.

A task's robot plans a path to the site, drives, arrives within ``arrive_tol_m`` (or beside robots
already standing at the site), works for the type's execution time and stays where it finished.
A robot that makes no progress for ``stuck_timeout_s`` drives round the robot in its way or backs
off on a random arc (from the world's generator) and replans; after ``max_recoveries`` tries, or
past its deadline, or if no path exists, the task is reported as a failed Completion with a reason.
"""

from __future__ import annotations

import numpy as np
import pymunk
import pymunk.batch as pb

from sim.drive import DiffDriveController, Motors, PathFollower
from sim.planning import GridPlanner
from sim.recording import DRIVING, IDLE, WORKING
from sim.scenario import Scenario
from sim.tasks import Batch
from sim.world import Completion, WorldState

ROBOT, WALL = 1, 2  # pymunk collision types
_GAP = pb.ArbiterFields.DISTANCE_1 | pb.ArbiterFields.DISTANCE_2
BACKOFF_S = 1.5  # a stuck robot reverses on a random arc this long, then replans
YIELD_TRIGGER_M = 0.3  # a driving robot this close (beyond contact) to an idle one asks it to move
YIELD_STEP_M = 1.0  # how far an idle robot steps aside
YIELD_TIMEOUT_S = 6.0
DETOUR_M = 1.0  # a robot blocked by one that stands still passes it this far to the side
PROGRESS_M = 0.05  # less progress than this along the path does not reset the stuck clock
WALL_THICKNESS_M = 1.0


class PymunkWorld:
    """The pymunk world behind the :class:`sim.world.World` interface.

    Args:
        scenario: a scenario with a ``spatial`` table.
        recorder: optional ``sim.recording.TrajectoryRecorder`` fed robot poses while running.

    Attributes:
        planner: the :class:`GridPlanner` the distance and time cost models bid with.
        contacts_max_overlap_m: deepest robot-robot or robot-wall penetration seen (sampled every
            control period).
        collisions_robot_, collisions_wall_: contacts begun between robots, robot and wall.
    """

    def __init__(self, scenario: Scenario, recorder=None) -> None:
        if scenario.spatial is None:
            raise ValueError(f"scenario {scenario.name!r} has no [spatial] table")
        self.scenario = scenario
        self.spatial = sp = scenario.spatial
        self.planner = GridPlanner(sp)
        self.recorder = recorder
        self.dt_s = sp.dt_s
        self.substeps = max(1, round(1.0 / (sp.control_hz * sp.dt_s)))
        self.controller = DiffDriveController(sp.drive, self.substeps * sp.dt_s)
        self.exec_time_s_ = np.asarray(scenario.exec_time_s, dtype=float)
        self.starts_ = np.array([r.start_xy for r in scenario.robots], dtype=float)
        self.reach_m_ = 2.0 * sp.drive.radius_m + 0.1  # centres closer than this are touching
        self.reset(np.random.default_rng(0))

    def reset(self, rng: np.random.Generator) -> None:
        """Rebuild the space with every robot at its start, facing +x, free."""
        sp, drive, m = self.spatial, self.spatial.drive, self.scenario.n_robots
        self.rng_ = rng
        space = pymunk.Space()
        space.collision_slop = sp.collision_slop_m
        w, h, t = sp.width_m, sp.height_m, WALL_THICKNESS_M
        walls = [(-t, -t, w + t, 0), (-t, h, w + t, h + t), (-t, 0, 0, h), (w, 0, w + t, h)]
        polys = [[(x0, y0), (x1, y0), (x1, y1), (x0, y1)] for x0, y0, x1, y1 in walls]
        for poly in polys + [list(p) for p in sp.obstacles]:
            shape = pymunk.Poly(space.static_body, poly)
            shape.friction, shape.collision_type = 0.3, WALL
            space.add(shape)
        self.motors = Motors(space, drive, self.starts_, ROBOT)
        self.robots_ = self.motors.bodies
        space.on_collision(ROBOT, ROBOT, begin=self._hit_robot, separate=self._part)
        space.on_collision(ROBOT, WALL, begin=self._hit_wall, separate=self._part)
        self.space = space
        self.abuf_ = pb.Buffer()
        self.steps_, self.goal_s_, self.last_ctrl_step_ = 0, 0.0, -1
        self.state_ = np.full(m, IDLE, dtype=np.int8)
        self.task_ = np.full(m, -1, dtype=np.int64)
        self.type_ = np.zeros(m, dtype=np.int64)
        self.t_alloc_s_ = np.zeros(m)
        self.bid_ = np.zeros(m)
        self.site_ = self.starts_ @ np.array([1.0, 1j])  # x + iy
        self.work_end_s_ = np.zeros(m)
        self.deadline_s_ = np.zeros(m)
        self.odo_m_ = np.zeros(m)  # driven since the current task was allocated
        self.left_m_ = np.zeros(m)  # planned path length still to drive
        self.best_left_m_ = np.full(m, np.inf)
        self.t_progress_s_ = np.full(m, np.inf)  # inf unless driving: min() finds the stalest
        self.next_end_s_ = self.next_deadline_s_ = np.inf  # earliest end of work, of deadline
        self.n_backoff_ = self.n_yield_ = 0
        self.recoveries_ = np.zeros(m, dtype=int)
        self.backoff_until_s_ = np.full(m, -np.inf)
        self.backoff_cmd_ = np.zeros((m, 2))
        self.replan_ = np.zeros(m, dtype=bool)
        self.yielding_ = np.zeros(m, dtype=bool)  # idle, stepping out of a driving robot's way
        self.yield_until_s_ = np.zeros(m)
        self.rims_ = np.zeros((2, m))  # wheel rim speeds commanded last period, m/s
        self.blocker_, self.near_ = np.full(m, -1), np.full(m, np.inf)
        self.last_z_ = self.site_.copy()
        self.follower = PathFollower(m, sp.drive.max_wheel_speed_radps * sp.drive.wheel_radius_m)
        self.done_: list[Completion] = []
        self.contacts_max_overlap_m = 0.0
        self.collisions_robot_ = self.collisions_wall_ = self.failures_ = 0
        self.touching_ = 0  # contacts begun and not yet separated: sample overlaps only then
        self.moved_m_ = np.zeros(m)  # driven since reset

    def _hit_robot(self, arbiter, space, data) -> None:
        self.collisions_robot_ += 1
        self.touching_ += 1

    def _hit_wall(self, arbiter, space, data) -> None:
        self.collisions_wall_ += 1
        self.touching_ += 1

    def _part(self, arbiter, space, data) -> None:
        self.touching_ -= 1

    @property
    def time_s(self) -> float:
        return self.steps_ * self.dt_s

    @property
    def collision_count(self) -> int:
        """Contacts begun robot-robot plus robot-wall since ``reset``."""
        return self.collisions_robot_ + self.collisions_wall_

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Robot positions (m, 2) and headings (m,) now."""
        rob = self.motors.read()[self.motors.rob_]
        return rob[:, :2].copy(), rob[:, 2].copy()

    def snapshot(self) -> WorldState:
        xy, _ = self.poses()
        t = self.time_s
        v_max = self.follower.v_max_mps
        busy = np.full(len(xy), t)
        drv, wrk = self.state_ == DRIVING, self.state_ == WORKING
        busy[drv] = t + self.left_m_[drv] / v_max + self.exec_time_s_[self.type_[drv]]
        busy[wrk] = np.maximum(self.work_end_s_[wrk], t)
        return WorldState(t, self.task_ < 0, busy, xy)

    def apply(self, batch: Batch, assignment: np.ndarray, bids: np.ndarray) -> None:
        won = np.flatnonzero(np.asarray(assignment) >= 0)
        if not won.size:
            return
        xy, _ = self.poses()
        t, sp = self.time_s, self.spatial
        v_max = self.follower.v_max_mps
        for k in won.tolist():
            j = int(assignment[k])
            if self.task_[j] >= 0:
                raise RuntimeError(f"invariant violated: robot {j} given a task while busy")
            site = np.asarray(batch.sites[k], dtype=float)
            if not np.isfinite(site).all():
                raise ValueError(f"task {int(batch.ids[k])} has no site: a spatial world needs one")
            self.task_[j], self.type_[j] = int(batch.ids[k]), int(batch.types[k])
            self.t_alloc_s_[j], self.bid_[j], self.site_[j] = t, float(bids[k]), complex(*site)
            self.odo_m_[j], self.recoveries_[j], self.replan_[j] = 0.0, 0, False
            self.backoff_until_s_[j] = -np.inf
            self.yielding_[j] = False
            self.follower.clear(j)
            path = self.planner.path(xy[j], site)
            if not len(path):
                self._finish(j, t, False, f"unreachable: no path from {_xy(xy[j])} to {_xy(site)}")
                continue
            length = float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())
            self.follower.set_path(j, path)
            self.state_[j] = DRIVING
            self.left_m_[j], self.best_left_m_[j], self.t_progress_s_[j] = length, np.inf, t
            slack = (sp.max_recoveries + 1) * (sp.stuck_timeout_s + BACKOFF_S) + 30.0
            self.deadline_s_[j] = t + self.exec_time_s_[self.type_[j]] + 4 * length / v_max + slack
        self._events()

    def advance(self, duration_s: float) -> list[Completion]:
        self.goal_s_ += duration_s
        target = round(self.goal_s_ / self.dt_s)
        k, dt, step = self.substeps, self.dt_s, self.space.step
        while self.steps_ < target:
            if self.steps_ % k == 0 and self.steps_ != self.last_ctrl_step_:
                self._control()
            n = min(k - self.steps_ % k, target - self.steps_)
            for _ in range(n):
                step(dt)
            self.steps_ += n
        if self.steps_ % k == 0 and self.steps_ != self.last_ctrl_step_:
            self._control()
        elif self.time_s >= self.next_end_s_ - 1e-9:  # work ended since the last period
            self._finish_work(self.time_s)
        out, self.done_ = self.done_, []
        return out

    def drain(self) -> list[Completion]:
        """Run until every task in progress is done or has failed; bounded by the task deadlines."""
        out = []
        busy = self.task_ >= 0
        limit_s = float(self.deadline_s_[busy].max(initial=self.time_s)) + 60.0
        while (self.task_ >= 0).any() and self.time_s < limit_s:
            out += self.advance(0.5)
        for j in np.flatnonzero(self.task_ >= 0).tolist():
            self._finish(j, self.time_s, False, "drain: still unfinished at the time limit")
        out += self.done_
        self.done_ = []
        return out

    def summary(self, record=None) -> dict:
        """JSON-able physics statistics of the run so far."""
        return {
            "sim_time_s": self.time_s,
            "physics_steps": self.steps_,
            "distance_driven_m": float(self.moved_m_.sum()),
            "collisions_robot": self.collisions_robot_,
            "collisions_wall": self.collisions_wall_,
            "max_overlap_m": self.contacts_max_overlap_m,
            "failed_tasks": self.failures_,
        }

    def _control(self) -> None:
        """One control period: read poses, advance tasks, command the wheels, write, record."""
        self.last_ctrl_step_ = self.steps_
        t = self.time_s
        raw = self.motors.read()
        rob = raw[self.motors.rob_]
        th = rob[:, 2]
        z = rob[:, 0] + 1j * rob[:, 1]
        h = np.exp(1j * th)
        moved = np.abs(z - self.last_z_)
        self.odo_m_ += moved
        self.moved_m_ += moved
        self.last_z_ = z
        v, w = self._jobs(z, h, t)
        v, blocker, near = self.controller.proximity(z, h, v)
        self.blocker_, self.near_ = blocker, near
        if near.min(initial=np.inf) < self.controller.keep_right_m:
            w = self.controller.keep_right(h, w, blocker, near, self.state_ == DRIVING)
        pushing = (self.state_ == DRIVING) & (near < self.reach_m_ + YIELD_TRIGGER_M)
        if np.count_nonzero(pushing):
            standing = (self.state_ == IDLE) & ~self.yielding_
            pushing &= standing[np.maximum(blocker, 0)]
        if np.count_nonzero(pushing):
            self._make_way(pushing.nonzero()[0], blocker, z, h, v, t)
        v, w, self.rims_ = self.controller.limit(v, w, self.rims_)
        self.motors.write(raw, z, th, h, v, w)
        if self.touching_:
            self.abuf_.clear()
            pb.get_space_arbiters(self.space, _GAP, self.abuf_)
            gaps = np.frombuffer(self.abuf_.float_buf())
            if gaps.size:
                overlap = -float(gaps.min())
                self.contacts_max_overlap_m = max(self.contacts_max_overlap_m, overlap)
        if self.recorder is not None:
            self.recorder.poses(t, rob[:, :2], th, self.state_)

    def _jobs(self, z: np.ndarray, h: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance every robot's task (arrive, work, finish, stuck, recover); desired twists.

        Full-array numpy every period; the per-robot Python below runs only on events, which the
        scalar next-event times let the common case skip.
        """
        sp = self.spatial
        go = self.state_ == DRIVING
        steered = go | self.yielding_ if self.n_yield_ else go
        back = None
        if self.n_backoff_:
            back = go & (self.backoff_until_s_ > t)
            for j in (self.replan_ & ~back).nonzero()[0].tolist():
                self._replan(j, (z[j].real, z[j].imag), t)
            go = (self.state_ == DRIVING) & ~back
            steered = go | self.yielding_
        if np.count_nonzero(steered):
            tgt, corner, left = self.follower.targets(z)
            v, w = self.controller.steer(z, h, tgt, corner)
            v *= steered
            w *= steered
            self.left_m_ = left
            if self.n_yield_:
                stop = self.yielding_ & ((left < 0.15) | (self.yield_until_s_ < t))
                for j in stop.nonzero()[0].tolist():
                    self._stop_yield(j)
                    v[j] = w[j] = 0.0
            better = (left < self.best_left_m_ - PROGRESS_M) & go
            np.putmask(self.best_left_m_, better, left)
            np.putmask(self.t_progress_s_, better, t)
            if t - self.t_progress_s_.min() > sp.stuck_timeout_s:
                stuck = go & (t - self.t_progress_s_ > sp.stuck_timeout_s)
                for j in stuck.nonzero()[0].tolist():
                    self._recover(j, t)
            gap = np.abs(self.site_ - z)
            there = go & (gap <= sp.arrive_tol_m + 2 * self.reach_m_)
            if np.count_nonzero(there):  # near the site: arrived, or beside robots standing there
                queue = (there & (gap > sp.arrive_tol_m) & (self.near_ <= self.reach_m_)).nonzero()[
                    0
                ]
                there &= gap <= sp.arrive_tol_m
                if queue.size:  # touching a robot that stands nearer the site: the site is taken,
                    # and working beside the robots already there counts as arrived
                    still = (self.state_ != DRIVING) & ~self.yielding_
                    nearer = np.abs(z[None, :] - self.site_[queue, None]) < gap[queue, None]
                    touch = np.abs(z[None, :] - z[queue, None]) <= self.reach_m_
                    there[queue] = (still & nearer & touch).any(axis=1)
                for j in there.nonzero()[0].tolist():
                    self.state_[j] = WORKING
                    self.work_end_s_[j] = t + self.exec_time_s_[self.type_[j]]
                    self.t_progress_s_[j] = np.inf
                    self.follower.clear(j)
                    v[j] = w[j] = 0.0
                    self.next_end_s_ = min(self.next_end_s_, self.work_end_s_[j])
        else:
            v, w = np.zeros(len(z)), np.zeros(len(z))
        if back is not None:
            v[back], w[back] = self.backoff_cmd_[back].T
        if t + 1e-9 >= self.next_end_s_:
            self._finish_work(t)
        if t > self.next_deadline_s_:
            for j in ((self.task_ >= 0) & (self.deadline_s_ < t)).nonzero()[0].tolist():
                self._finish(j, t, False, "timeout: task not finished by its deadline")
        return v, w

    def _finish_work(self, t: float) -> None:
        for j in ((self.state_ == WORKING) & (self.work_end_s_ <= t + 1e-9)).nonzero()[0]:
            self._finish(int(j), float(self.work_end_s_[j]), True)

    def _make_way(self, pushers, blocker, z, h, v, t: float) -> None:
        """Idle robots standing in a driving robot's way step aside (planning ignores robots)."""
        for j in pushers.tolist():
            b = int(blocker[j])
            if self.yielding_[b]:  # asked by another robot in this period
                continue
            travel = h[j] if v[j] >= 0 else -h[j]
            others = np.delete(z, b)
            path = self.planner.side_step(z[b], z[j], travel, YIELD_STEP_M, others)
            if len(path):
                self.follower.set_path(b, path)
                self.yielding_[b], self.yield_until_s_[b] = True, t + YIELD_TIMEOUT_S
        self._events()

    def _stop_yield(self, j: int) -> None:
        self.yielding_[j] = False
        self.follower.clear(j)
        self._events()

    def _events(self) -> None:
        """Refresh the scalar next-event times after a task event."""
        busy = self.task_ >= 0
        work = self.state_ == WORKING
        self.next_end_s_ = float(self.work_end_s_[work].min(initial=np.inf))
        self.next_deadline_s_ = float(self.deadline_s_[busy].min(initial=np.inf))
        backing = self.replan_ | (self.backoff_until_s_ > self.time_s)
        self.n_backoff_ = int(np.count_nonzero(backing))
        self.n_yield_ = int(np.count_nonzero(self.yielding_))

    def _recover(self, j: int, t: float) -> None:
        self.recoveries_[j] += 1
        sp = self.spatial
        if self.recoveries_[j] > sp.max_recoveries:
            why = f"stuck: no progress for {sp.stuck_timeout_s:g} s after {sp.max_recoveries} tries"
            return self._finish(j, t, False, why)
        b, z = int(self.blocker_[j]), self.last_z_
        if b >= 0 and self.near_[j] < self.reach_m_ + YIELD_TRIGGER_M and self.state_[b] != DRIVING:
            travel = np.exp(1j * self.robots_[j].angle)
            site = (self.site_[j].real, self.site_[j].imag)
            others = np.delete(z, j)
            path = self.planner.detour(z[j], z[b], travel, DETOUR_M, site, others)
            if len(path):  # go round the robot that stands in the way
                self.follower.set_path(j, path)
                self.best_left_m_[j], self.t_progress_s_[j] = np.inf, t
                return
        c = self.controller
        turn = self.rng_.uniform(-0.5, 0.5) * c.omega_max_radps
        self.backoff_cmd_[j] = (-0.3 * c.v_max_mps, turn)
        self.backoff_until_s_[j] = t + BACKOFF_S
        self.t_progress_s_[j] = np.inf
        self.replan_[j] = True
        self.follower.clear(j)
        self._events()

    def _replan(self, j: int, xy: np.ndarray, t: float) -> None:
        self.replan_[j] = False
        path = self.planner.path(xy, (self.site_[j].real, self.site_[j].imag))
        if not len(path):
            self._finish(j, t, False, f"unreachable: no path from {_xy(xy)} after a recovery")
            return
        self.follower.set_path(j, path)
        self.best_left_m_[j], self.t_progress_s_[j] = np.inf, t
        self._events()

    def _finish(self, j: int, t_done_s: float, ok: bool, reason: str = "") -> None:
        task, t_alloc, bid = int(self.task_[j]), float(self.t_alloc_s_[j]), float(self.bid_[j])
        self.done_.append(
            Completion(task, j, t_alloc, t_done_s, bid, float(self.odo_m_[j]), ok, reason)
        )
        self.failures_ += not ok
        self.task_[j] = -1
        self.state_[j] = IDLE
        self.replan_[j] = False
        self.backoff_until_s_[j] = -np.inf
        self.t_progress_s_[j] = np.inf
        self.follower.clear(j)
        self._events()


def _xy(p) -> str:
    return f"({float(p[0]):.2f}, {float(p[1]):.2f})"
