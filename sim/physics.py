"""The spatial world: differential-drive robots in a pymunk arena (SPEC §6).

One ``pymunk.Space`` (no gravity, SI units, fixed step ``dt_s``, collision slop in metres) holds
the arena walls, the static obstacles and the robots, which ``sim.motors.Motors`` drives with motor
joints (never by writing body velocities, which would discard the contact solution).

What runs at which rate:

- every physics step (``dt_s``, 60 Hz in the bundled scenarios): chipmunk's step and nothing
  else while no contact touches (with one solver iteration, exact then); while one does, ten
  iterations and one batched read of the contact depths (``sim.contacts``: that is how
  ``contacts_max_overlap_m`` is the worst penetration of any step).
- every control period (``1 / control_hz``): one batched read of all poses; odometry; for every
  robot that drives or yields, path following and steering (``sim.paths``); progress; the wheel
  limits and one batched write of every motor command; the trajectory recorder. Checks that
  cannot fire yet are skipped until the earliest time they could: the proximity caps between
  robots, keep-right and make-way until two robots could be within ``DiffDriveController.look_m``
  of each other (beyond, no cap binds); the arrival check until a driving robot could be in its
  arrival zone; the stuck check until the stalest robot could be stuck. The distance to the
  nearest obstacle (and the speed cap toward it) is measured only for robots beyond the free
  width of their path, or that could be before they stop (``PathFollower.drifting``), or backing
  off without one. While no robot drives, yields or backs off and every wheel has stopped, a
  period does only the recorder (with the poses it has) and the task clock.
- on events only (allocation, arrival, end of work, deadline, stuck, yield request, waypoint
  reached): per-robot Python, planning, and the refresh of the scalar next-event times.

The control period exists twice with the same formulas: over numpy arrays (``sim.jobs``,
``sim.drive``), and robot by robot in plain Python for teams of up to ``SMALL_TEAM`` robots
(``sim.small``), where numpy's per-call overhead would dominate; the tests run both and check
that they command the same wheels period by period. The scalar one also skips what cannot
change: it looks only at pairs with a steering robot (a standing robot has no speed to cap)
and sleeps the proximity check until a steering robot could come within ``look_m`` of
another (every event wakes it), and it writes only the motors whose command changed (a robot
stopped and staying stopped keeps its control body as it is: with ``max_bias = 0`` the joints
match velocities only, so where that body stands does not matter).

A task's robot plans a path to the site, drives, arrives within ``arrive_tol_m`` (or beside robots
already standing at the site), works for the type's execution time and stays where it finished.
A robot that makes no progress for ``stuck_timeout_s`` drives round the robot in its way or backs
off on a random arc (from the world's generator) and replans; one boxed in by a robot at work that
will be done within ``stuck_timeout_s`` waits for it instead. After ``max_recoveries`` tries, or
past its deadline, or if no path exists, the task is reported as a failed Completion with a reason.
"""

from __future__ import annotations

import numpy as np
import pymunk

from sim.contacts import ContactMonitor
from sim.drive import DiffDriveController
from sim.jobs import BACKOFF_S, SPEED_BOUND, YIELD_TRIGGER_M, JobsMixin, _xy
from sim.motors import Motors
from sim.paths import PathFollower
from sim.planning import GridPlanner
from sim.recording import DRIVING, IDLE, WORKING
from sim.scenario import Scenario
from sim.small import SMALL_TEAM, SmallTeamMixin
from sim.tasks import Batch
from sim.world import Completion, WorldState

ROBOT, WALL = 1, 2  # pymunk collision types
WALL_THICKNESS_M = 1.0
FREE_CAP_M = 2.0  # free widths of side steps as far as this (the step is 1 m), then on demand


class PymunkWorld(SmallTeamMixin, JobsMixin):
    """The pymunk world behind the :class:`sim.world.World` interface.

    Args:
        scenario: a scenario with a ``spatial`` table.
        recorder: optional ``sim.recording.TrajectoryRecorder`` fed robot poses while running.

    Attributes:
        planner: the :class:`GridPlanner` the distance and time cost models bid with.
        contacts_max_overlap_m: deepest robot-robot or robot-wall penetration at the end of any
            physics step (measured after every step in which a contact touches).
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
        self.small_ = scenario.n_robots <= SMALL_TEAM  # control periods in scalar Python
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
        self.contacts = ContactMonitor(space, ROBOT, WALL)
        self.space = space
        self.steps_, self.goal_s_, self.last_ctrl_step_ = 0, 0.0, -1
        self.state_ = np.full(m, IDLE, dtype=np.int8)
        self.task_ = np.full(m, -1, dtype=np.int64)
        self.type_ = np.zeros(m, dtype=np.int64)
        self.t_alloc_s_ = np.zeros(m)
        self.bid_ = np.zeros(m)
        self.site_ = self.starts_ @ np.array([1.0, 1j])  # x + iy
        self.work_end_s_ = np.zeros(m)
        self.deadline_s_ = np.zeros(m)
        self.odo0_m_ = np.zeros(m)  # moved_m_ when the current task was allocated
        self.left_m_ = np.zeros(m)  # planned path length still to drive
        self.progress_m_ = np.full(m, np.inf)  # path left below this is progress (stuck clock)
        self.t_progress_s_ = np.full(m, np.inf)  # inf unless driving: min() finds the stalest
        self.next_end_s_ = self.next_deadline_s_ = np.inf  # earliest end of work, of deadline
        self.stuck_check_s_ = self.site_check_s_ = self.prox_check_s_ = -np.inf
        self.n_backoff_ = self.n_yield_ = self.n_steer_ = 0
        self.resting_ = self.calm_ = True  # nothing steered and every wheel stopped (twice)
        self.state_list_, self.steer_list_ = self.state_.tolist(), []  # kept by _events
        self.recoveries_ = np.zeros(m, dtype=int)  # tries since the robot last got going
        self.stuck_left_m_ = np.full(m, np.inf)  # path left when it last got stuck (inf: never)
        self.recovering_ = False  # any robot with a finite stuck_left_m_
        self.backoff_until_s_ = np.full(m, -np.inf)
        self.backoff_cmd_ = np.zeros((m, 2))
        self.replan_ = np.zeros(m, dtype=bool)
        self.yielding_ = np.zeros(m, dtype=bool)  # idle, stepping out of a driving robot's way
        self.yield_until_s_ = np.zeros(m)
        self.v_cmd_ = np.zeros(m)  # forward speed commanded last period, m/s
        self.q_cmd_ = np.zeros(m)  # ... and half the rim speed difference: rims v +- q
        self.nobody_ = np.full(m, -1), np.full(m, np.inf)  # no robot in the way of any
        self.blocker_, self.near_ = self.nobody_
        self.last_z_ = self.site_.copy()
        self.last_th_ = np.zeros(m)
        walls = [((0, 0), (sp.width_m, 0)), ((sp.width_m, 0), (sp.width_m, sp.height_m))]
        walls += [((sp.width_m, sp.height_m), (0, sp.height_m)), ((0, sp.height_m), (0, 0))]
        v_max = drive.max_wheel_speed_radps * drive.wheel_radius_m
        # beyond a small team (scalar control), free widths of side steps are computed only
        # as far as FREE_CAP_M, and exactly when a robot gets farther off (PathFollower.cap_m)
        cap = np.inf if self.small_ else FREE_CAP_M
        self.follower = PathFollower(m, v_max, [*sp.obstacles, *walls], drive.radius_m, cap)
        self.done_: list[Completion] = []
        self.failures_ = 0
        self.moved_m_ = np.zeros(m)  # driven since reset

    @property
    def contacts_max_overlap_m(self) -> float:
        return self.contacts.max_overlap_m

    @property
    def collisions_robot_(self) -> int:
        return self.contacts.robot_hits

    @property
    def collisions_wall_(self) -> int:
        return self.contacts.wall_hits

    @property
    def touching_(self) -> int:
        return self.contacts.touching

    @property
    def time_s(self) -> float:
        return self.steps_ * self.dt_s

    @property
    def collision_count(self) -> int:
        """Contacts begun robot-robot plus robot-wall since ``reset``."""
        return self.collisions_robot_ + self.collisions_wall_

    def poses(self) -> tuple[np.ndarray, np.ndarray]:
        """Robot positions (m, 2) and headings (m,) now."""
        rob = self.motors.read()
        return self.motors.flat[:, :2].copy(), rob["th"].copy()

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
        slack = (sp.max_recoveries + 1) * (sp.stuck_timeout_s + BACKOFF_S) + 30.0
        rows, paths = [], []
        for k in won.tolist():
            j = int(assignment[k])
            if self.task_[j] >= 0:
                raise RuntimeError(f"invariant violated: robot {j} given a task while busy")
            site = np.asarray(batch.sites[k], dtype=float)
            if not np.isfinite(site).all():
                raise ValueError(f"task {int(batch.ids[k])} has no site: a spatial world needs one")
            self.task_[j], self.type_[j] = int(batch.ids[k]), int(batch.types[k])
            self.t_alloc_s_[j], self.bid_[j], self.site_[j] = t, float(bids[k]), complex(*site)
            self.odo0_m_[j], self.recoveries_[j], self.replan_[j] = self.moved_m_[j], 0, False
            self.stuck_left_m_[j] = np.inf
            self.backoff_until_s_[j] = -np.inf
            self.yielding_[j] = False
            self.follower.clear(j)
            path = self.planner.path(xy[j], site)
            if not len(path):
                self._finish(j, t, False, f"unreachable: no path from {_xy(xy[j])} to {_xy(site)}")
                continue
            rows.append(j)
            paths.append(path)
        for j, length in zip(rows, self.follower.set_paths(rows, paths), strict=True):
            self.state_[j] = DRIVING
            self.left_m_[j], self.progress_m_[j], self.t_progress_s_[j] = length, np.inf, t
            self.deadline_s_[j] = t + self.exec_time_s_[self.type_[j]] + 4 * length / v_max + slack
        self.site_check_s_ = -np.inf
        self._events()

    def advance(self, duration_s: float) -> list[Completion]:
        self.goal_s_ += duration_s
        target = round(self.goal_s_ / self.dt_s)
        k, dt, run = self.substeps, self.dt_s, self.contacts.run
        while self.steps_ < target:
            if self.steps_ % k == 0 and self.steps_ != self.last_ctrl_step_:
                self._control()
            n = min(k - self.steps_ % k, target - self.steps_)
            run(n, dt)
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
        if self.resting_ and not (self.n_steer_ or self.n_backoff_):
            self._clock(t)  # nothing moves: poses, commands and caps are as they were
            if self.recorder is not None:
                z = self.last_z_
                xy = np.column_stack([z.real, z.imag])
                self.recorder.poses(t, xy, self.last_th_, self.state_)
            return
        if self.small_:
            return self._control_small(t)
        motors = self.motors
        rob = motors.read()
        z, th = rob["z"], rob["th"]
        h = np.exp(1j * th)
        hc = h.conj()
        self.moved_m_ += np.abs(z - self.last_z_)
        self.last_z_[:] = z
        self.last_th_[:] = th
        v, w = self._jobs(z, hc, t)
        if t >= self.prox_check_s_:
            self._near(z, th, h, hc, v, w, t)
        else:
            self.blocker_, self.near_ = self.nobody_
        rows = self.off_path_
        if self.n_steer_:  # ... and the robots whose heading could carry them out of it
            v_cmd = self.v_cmd_  # the speed next period lies between v_cmd and v
            reach = np.where(np.abs(v) >= np.abs(v_cmd), v, v_cmd)
            c = self.controller
            rows = self.follower.drifting(z, h, reach, c.react_s, c.inv2a_)
        if self.n_backoff_:  # backing off blind, without a path: mind the obstacles too
            back = (self.backoff_until_s_ > t).nonzero()[0]
            rows = back if rows is None else np.union1d(rows, back)
        if rows is not None and len(rows):
            self._obstacle_caps(z, hc, v, rows)
        v, w, self.q_cmd_ = self.controller.limit(v, w, self.v_cmd_, self.q_cmd_)
        self.v_cmd_ = v
        motors.write(z, th, h, v, w)
        calm = not (self.n_steer_ or self.n_backoff_)
        calm = calm and not (np.count_nonzero(v) or np.count_nonzero(w))
        self.resting_, self.calm_ = calm and self.calm_, calm  # stopped for a whole period
        if self.recorder is not None:
            self.recorder.poses(t, motors.flat[:, :2], th, self.state_)

    def _obstacle_caps(self, z, hc, v, rows) -> None:
        """Cap the speed of robots ``rows`` toward their nearest obstacle (writes ``v``)."""
        rows = np.asarray(rows)
        gap = self.follower.to_obstacle(z[rows])
        capped = self.controller.wall_cap(hc[rows], np.asarray(v)[rows], gap)
        for j, vj in zip(rows.tolist(), capped.tolist(), strict=True):
            v[j] = vj

    def _near(self, z, th, h, hc, v, w, t: float) -> None:
        """Proximity caps, keep-right and make-way (writes ``v``, ``w`` in place)."""
        c = self.controller
        cap, blocker, near, apart = c.proximity(z, hc, v, self.v_cmd_)
        if cap is None:  # no cap binds before two robots could be look_m apart
            gap = apart - c.look_m
            self.prox_check_s_ = t + gap / (2.0 * SPEED_BOUND * c.v_max_mps)
            self.blocker_, self.near_ = self.nobody_
            return
        v[:] = cap
        self.blocker_, self.near_ = blocker, near
        closest = float(near.min())
        if closest < c.keep_right_m:
            w[:] = c.keep_right(th, w, blocker, near, self.state_ == DRIVING)
        if closest < self.reach_m_ + YIELD_TRIGGER_M:
            pushing = (self.state_ == DRIVING) & (near < self.reach_m_ + YIELD_TRIGGER_M)
            standing = (self.state_ == IDLE) & ~self.yielding_
            pushing &= standing[np.maximum(blocker, 0)]
            if np.count_nonzero(pushing):
                self._make_way(pushing.nonzero()[0], blocker, z, h, v, t)
