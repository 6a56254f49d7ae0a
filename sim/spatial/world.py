"""The spatial world: differential-drive robots in a pymunk arena (SPEC §6).

One ``pymunk.Space`` (no gravity, SI units, fixed step ``dt_s``, collision slop in metres) holds
the arena walls, the static obstacles and the robots, which ``sim.spatial.motors.Motors`` drives
with motor joints (never by writing body velocities, which would discard the contact solution).

What runs at which rate:

- every physics step (``dt_s``, 60 Hz in the bundled scenarios): chipmunk's step and nothing
  else while no contact touches (with one solver iteration, exact then); while one does, ten
  iterations and one batched read of the contact depths (``sim.spatial.contacts``: that is how
  ``contacts_max_overlap_m`` is the worst penetration of any step).
- every control period (``1 / control_hz``): one batched read of all poses; odometry; for every
  robot that drives or yields, path following and steering (``sim.spatial.navigation.paths``);
  progress; the wheel limits and one batched write of every motor command; the trajectory recorder.
  Checks that cannot fire yet are skipped until the earliest time they could: the proximity caps
  between robots, keep-right and make-way until two robots could be within
  ``DiffDriveController.look_m`` of each other (beyond, no cap binds); the arrival check until a
  driving robot could be in its arrival zone; the stuck check until the stalest robot could be
  stuck. The distance to the nearest obstacle (and the speed cap toward it) is measured only for
  robots beyond the free width of their path, or that could be before they stop
  (``PathFollower.drifting``), or backing off without one. While no robot drives, yields or backs
  off and every wheel has stopped, a period does only the recorder (with the poses it has) and the
  task clock.
- on events only (allocation, arrival, end of work, deadline, stuck, yield request, waypoint
  reached): per-robot Python, planning, and the refresh of the schedule of checks.

Who does what: the world builds the space and owns the fleet state (``sim.spatial.fleet``: per-robot
arrays, the schedule of checks, the clock), which it hands to its collaborators: the task
bookkeeping (``sim.spatial.jobs.Jobs``, with the sites' slots and queues, ``sim.spatial.sites``, and
the jam rules, ``sim.spatial.jams``), the control period (``sim.spatial.control``), the motors
(``sim.spatial.motors.Motors``) and the contact monitor. The control period is chosen by the
``control`` argument: by default the compiled one (``CompiledControl``: numba, one call per period
for the whole fleet, events in Python) for every team size; its numpy twins over arrays
(``ArrayControl``) and robot by robot (``ScalarControl``) stay as the reference the tests compare
it with, from copies of the same state.

A task's robot plans a path to the site, drives, arrives within ``arrive_tol_m`` (or beside robots
already standing at the site), works for the type's execution time and stays where it finished.
A robot that makes no progress for ``stuck_timeout_s`` drives round the robot in its way or backs
off on a random arc (from the world's generator) and replans; one boxed in by a robot at work that
will be done within ``stuck_timeout_s`` waits for it instead; with avoidance on, one that stands
2 s in a jam in a single-lane place, or alone with one other, acts then (``Jams.break_jams``),
and with ``[spatial] look_ahead = "on"`` a robot whose way runs past a robot at work that would
keep it waiting plans round it when it is given its task or that robot begins work
(``Jams.look_ahead``).
After ``max_recoveries`` tries, or
not at work by its deadline (work begun is finished), or if no path exists, the task is reported
as a failed Completion with a reason.
"""

from __future__ import annotations

import gc

import numpy as np
import pymunk
import pymunk.batch as pb

from sim.faults import build_faults, fault_seed_sequence
from sim.scenario import Scenario
from sim.spatial import layout
from sim.spatial.contacts import ContactMonitor
from sim.spatial.control import CONTROLS, ControlParts, control_kind
from sim.spatial.controller import DiffDriveController
from sim.spatial.fleet import Clock, FleetState, Schedule, shown_now
from sim.spatial.jobs import Jobs
from sim.spatial.law.orca import OrcaLaw
from sim.spatial.motors import Motors
from sim.spatial.navigation.paths import PathFollower
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.stalls import StallMeter
from sim.states import WORKING
from sim.tasks import Batch
from sim.world import Abandon, Completion, WorldState

ROBOT, WALL = 1, 2  # pymunk collision types
WALL_THICKNESS_M = 1.0
# A space dropped at a set boundary is freed by a full garbage collection (its collision
# handlers and the space hold each other), which costs tens of ms whatever the space's size:
# one runs once the dropped spaces hold this many robots in all (every set from 250 robots on;
# every 25 sets of a 10-robot run, whose RSS then levels off 1.3 MiB higher in paper_spatial and
# 3.6 MiB in the warehouse: RSS after 500 rebuilds, measured once).
GC_ROBOTS = 250


class PymunkWorld:
    """The pymunk world behind the :class:`sim.world.World` interface.

    Args:
        scenario: a scenario with a ``spatial`` table.
        recorder: optional ``sim.recording.TrajectoryRecorder`` fed robot poses while running.
        control: the control period: ``"compiled"``, ``"array"``, ``"scalar"`` or ``"auto"``
            (compiled, for every team size; ``sim.spatial.control.control_kind``).
        check_layout: refuse a layout a scenario file could not hold (robots on each other or
            in a wall, a site no robot can reach: ``sim.spatial.layout``). Tests of states a
            run can reach but not start from (robots touching, a task out of reach) pass False.
        gc_robots: a full garbage collection frees the spaces dropped at set boundaries once
            they held this many robots in all (see ``GC_ROBOTS``).

    Attributes:
        planner: the :class:`GridPlanner` the distance and time cost models bid with.
        control_kind: the control period in use, ``"compiled"``, ``"array"`` or ``"scalar"``.
        fleet: the per-robot state (:class:`sim.spatial.fleet.FleetState`), rebuilt by
        :meth:`reset`. schedule, clock: the schedule of checks and the physics-step clock, rebuilt
        likewise. jobs, control, motors, contacts, follower: the collaborators :meth:`reset` builds.
        contacts_max_overlap_m: deepest robot-robot or robot-wall penetration at the end of any
            physics step (measured after every step in which a contact touches).
        collisions_robot_, collisions_wall_: contacts begun between robots, robot and wall.
    """

    def __init__(
        self,
        scenario: Scenario,
        recorder=None,
        *,
        control: str = "auto",
        check_layout: bool = True,
        gc_robots: int = GC_ROBOTS,
    ) -> None:
        if scenario.spatial is None:
            raise ValueError(f"scenario {scenario.name!r} has no [spatial] table")
        self.scenario = scenario
        self.spatial = sp = scenario.spatial
        self.planner = GridPlanner(sp)
        if check_layout:  # a scenario built in Python is checked here, as a file is on loading
            layout.check_layout(scenario, self.planner)
        self.recorder = recorder
        self.control_kind = control_kind(control, scenario.n_robots)
        self.dt_s = sp.dt_s
        self.substeps = max(1, round(1.0 / (sp.control_hz * sp.dt_s)))
        self.controller = DiffDriveController(sp.drive, self.substeps * sp.dt_s, law=sp.law)
        self.exec_time_s_ = np.asarray(scenario.exec_time_s, dtype=float)
        self.starts_ = np.array([r.start_xy for r in scenario.robots], dtype=float)
        self.headings_ = np.radians([r.heading_deg for r in scenario.robots])
        self.reach_m_ = 2.0 * sp.drive.radius_m + 0.1  # centres closer than this are touching
        self.buffers_ = (pb.Buffer(), pb.Buffer())  # batch I/O of motors and contacts, reused
        self.faults = build_faults(scenario)
        self.dropped_robots_ = 0  # robots in the spaces dropped since the last collection
        self.gc_robots = gc_robots
        self.reset(np.random.default_rng(0))

    def reset(self, rng: np.random.Generator) -> None:
        """Rebuild the space with every robot at its start, facing its start heading, free;
        a fresh fault model (if the scenario has faults)."""
        self._build(rng)
        self.abandoned_: list[Abandon] = []
        if self.faults is not None:
            self._reset_faults(rng)

    def _build(self, rng: np.random.Generator) -> None:
        """The space, the fleet state and the collaborators, every robot at its start and free
        (what :meth:`restore_arrays` rebuilds; the fault model is kept)."""
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
        self.motors = Motors(space, drive, self.starts_, ROBOT, self.headings_, self.buffers_[0])
        self.contacts = ContactMonitor(space, ROBOT, WALL, self.buffers_[1], sp.contacts)
        self.stalls = StallMeter(self.substeps * self.dt_s, sp.width_m, sp.height_m, m, sp.stalls)
        self.space = space
        self.clock = Clock(self.dt_s)
        self.goal_s_, self.last_ctrl_step_ = 0.0, -1
        self.fleet = FleetState.at_start(self.starts_, self.headings_)
        self.schedule = Schedule(state_list=self.fleet.state.tolist())
        walls = [((0, 0), (sp.width_m, 0)), ((sp.width_m, 0), (sp.width_m, sp.height_m))]
        walls += [((sp.width_m, sp.height_m), (0, sp.height_m)), ((0, sp.height_m), (0, 0))]
        v_max = drive.max_wheel_speed_radps * drive.wheel_radius_m
        kind = CONTROLS[self.control_kind]
        obstacles = [*sp.obstacles, *walls]
        self.follower = PathFollower(
            m, v_max, obstacles, drive.radius_m, kind.free_cap_m, follow=sp.follow
        )
        self.jobs = Jobs(
            fleet=self.fleet,
            schedule=self.schedule,
            clock=self.clock,
            follower=self.follower,
            planner=self.planner,
            controller=self.controller,
            spatial=sp,
            exec_time_s=self.exec_time_s_,
            reach_m=self.reach_m_,
            bodies=self.motors.bodies,
            rng=rng,
            keep_lists=kind.keeps_lists,
            avoid=sp.avoid,
        )
        parts = ControlParts(
            self.fleet,
            self.schedule,
            self.jobs,
            self.motors,
            self.follower,
            self.controller,
            sp.arrive_tol_m,
            self.reach_m_,
            sp.avoid,
            OrcaLaw.of(sp.orca, sp.law),
        )
        self.control = kind(parts)

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
        return self.clock.time_s

    @property
    def steps_(self) -> int:
        """Physics steps taken since reset."""
        return self.clock.steps

    @property
    def task_(self) -> np.ndarray:
        """(m,) id of each robot's task, -1 while free."""
        return self.fleet.task

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
        if self.faults is not None:
            return self._fault_snapshot(t, xy)
        return WorldState(t, self.fleet.task < 0, self.jobs.busy_until_s(t), xy)

    def apply(self, batch: Batch, assignment: np.ndarray, bids: np.ndarray) -> None:
        won = np.flatnonzero(np.asarray(assignment) >= 0)
        if not won.size:
            return
        xy, _ = self.poses()
        self.jobs.assign(batch, assignment, bids, won, xy)

    def advance(self, duration_s: float) -> list[Completion]:
        if self.faults is not None:
            return self._advance_faults(self.goal_s_ + duration_s)
        return self._advance(duration_s)

    def _advance(self, duration_s: float) -> list[Completion]:
        self.goal_s_ += duration_s
        target = round(self.goal_s_ / self.dt_s)
        clock, k, dt, run = self.clock, self.substeps, self.dt_s, self.contacts.run
        while clock.steps < target:
            if clock.steps % k == 0 and clock.steps != self.last_ctrl_step_:
                self._control()
            n = min(k - clock.steps % k, target - clock.steps)
            run(n, dt)
            clock.steps += n
        if clock.steps % k == 0 and clock.steps != self.last_ctrl_step_:
            self._control()
        elif self.time_s >= self.schedule.next_end_s - 1e-9:  # work ended since the last period
            self.jobs.finish_work(self.time_s)
        out, self.jobs.done = self.jobs.done, []
        return out

    def drain(self) -> list[Completion]:
        """Run until every task in progress is done or has failed; bounded by the task deadlines
        (and the end of work begun, which a deadline does not cut short)."""
        out, f = [], self.fleet
        busy = f.task >= 0
        work = f.state == WORKING
        ends = np.where(work, np.maximum(f.deadline_s, f.work_end_s), f.deadline_s)
        limit_s = float(ends[busy].max(initial=self.time_s)) + 60.0
        while (f.task >= 0).any() and self.time_s < limit_s:
            out += self.advance(0.5)  # a robot that breaks meanwhile abandons its task
        for j in np.flatnonzero(f.task >= 0).tolist():
            self.jobs.finish(j, self.time_s, False, "drain: still unfinished at the time limit")
        out += self.jobs.done
        self.jobs.done = []
        self.rebuild()
        return out

    # -- set boundaries: the state as named arrays, and a space rebuilt from them -------------
    def state_arrays(self) -> dict[str, np.ndarray]:
        """The world's whole state between task sets as named arrays (checkpoints): the clock,
        the fleet's per-robot arrays, the bodies, the schedule, the task bookkeeping and the
        contact counts, each component's under its prefix (``fleet/``, ``motors/``,
        ``schedule/``, ``jobs/``, ``contacts/``). A component with state implements
        ``state_arrays()`` and ``restore_arrays(arrays)``; registering one more is one entry
        in :meth:`_components`. The world's generator is the caller's to save.

        Raises:
            RuntimeError: while a task is in progress (state is kept between sets only).
        """
        if (self.fleet.task >= 0).any():
            raise RuntimeError("world state requested while tasks are in progress")
        out = {
            "clock/steps": np.array(self.clock.steps, dtype=np.int64),
            "clock/goal_s": np.array(self.goal_s_),
            "clock/last_control_step": np.array(self.last_ctrl_step_, dtype=np.int64),
        }
        for prefix, part in self._components():
            out.update({f"{prefix}/{k}": v for k, v in part.state_arrays().items()})
        return out

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Rebuild the space and put the state of :meth:`state_arrays` into it.

        Chipmunk's cached contacts and the joints' accumulated impulses (warm starting) are
        not part of the state: the new space starts without them, and a contact that still
        touches is found again (counted as a contact begun). Every run rebuilds its space this
        way at every set boundary (:meth:`drain`), so a run resumed from a checkpoint and one
        played straight through take the very same steps.
        """
        self._build(self.rng_)
        self.clock.steps = int(arrays["clock/steps"])
        self.goal_s_ = float(arrays["clock/goal_s"])
        self.last_ctrl_step_ = int(arrays["clock/last_control_step"])
        for prefix, part in self._components():
            cut = len(prefix) + 1
            part.restore_arrays(
                {k[cut:]: v for k, v in arrays.items() if k.startswith(prefix + "/")}
            )
        self.controller.forget_neighbours()
        self.jobs.refresh_lists()
        if self.faults is not None:  # the broken robots stand where they broke: plan round them
            broken = self.faults.broken_now()
            self.jobs.use_planner(self.path_planner)
            self.jobs.broken[:] = broken
            self._mark_broken(broken)

    def rebuild(self) -> None:
        """End a set: robots that step aside stop, and the space is rebuilt from the state
        (:meth:`restore_arrays`), as a resumed run builds it from its checkpoint."""
        yielding = self.fleet.yielding.nonzero()[0].tolist()
        for j in yielding:
            self.jobs.stop_yield(j)
        if yielding:
            self.jobs.refresh()
        self.restore_arrays(self.state_arrays())
        self.dropped_robots_ += self.scenario.n_robots
        if self.dropped_robots_ >= self.gc_robots:  # free the dropped spaces (see GC_ROBOTS)
            gc.collect()
            self.dropped_robots_ = 0

    def _components(self):
        """The world's components with state, by checkpoint prefix."""
        return (
            ("fleet", self.fleet),
            ("schedule", self.schedule),
            ("motors", self.motors),
            ("jobs", self.jobs),
            ("contacts", self.contacts),
            ("stalls", self.stalls),
        ) + ((("faults", self.faults),) if self.faults is not None else ())

    # -- robot faults (sim.faults): the wiring; the model decides when robots break ----------
    def _reset_faults(self, rng: np.random.Generator) -> None:
        """A fresh fault model; the robots plan with their own planner, which also knows where
        the broken robots stand (the cost models keep ``planner``, without them)."""
        self.faults.reset(np.random.default_rng(fault_seed_sequence(rng)))
        self.path_planner = GridPlanner(self.spatial)
        self.jobs.use_planner(self.path_planner)
        self.marked_z_ = self.fleet.last_z_m.copy()

    def take_abandoned(self) -> list[Abandon]:
        """Tasks abandoned since the last call (their robots broke), in order."""
        out, self.abandoned_ = self.abandoned_, []
        return out

    def _fault_snapshot(self, t: float, xy: np.ndarray) -> WorldState:
        broken = self.faults.broken_now()
        busy = self.jobs.busy_until_s(t)
        repair = self.faults.broken_until_s
        fixing = broken & np.isfinite(repair)
        busy[fixing] = np.maximum(busy[fixing], repair[fixing])
        return WorldState(t, (self.fleet.task < 0) & ~broken, busy, xy, broken)

    def _advance_faults(self, end_s: float) -> list[Completion]:
        """Advance to ``end_s``, stopping at every failure and repair on the way."""
        out = []
        while True:
            t_next = self.faults.next_event_s()
            if t_next > end_s:
                break
            if t_next > self.goal_s_:
                out += self._advance(t_next - self.goal_s_)
            self._fault_events(t_next)
        out += self._advance(end_s - self.goal_s_)
        broken = self.faults.broken_now()
        if broken.any():  # a robot that broke while driving rolled on while braking
            z = self.fleet.last_z_m[broken]
            if np.abs(z - self.marked_z_[broken]).max() > 0.05:
                self._mark_broken(broken)
        return out

    def _fault_events(self, t_event: float) -> None:
        """Apply the failures and repairs due at ``t_event``: a robot that breaks abandons its
        task and stands where it is (no wheel command: it brakes to a stop at its wheel limits
        and resists pushes like any robot at rest); others plan round it until it is repaired."""
        broke, fixed = self.faults.step(t_event)
        t = self.time_s
        for j in broke:
            if self.fleet.task[j] >= 0:
                self.abandoned_.append(self.jobs.abandon(j, t))
        broken = self.faults.broken_now()
        if broke or fixed:
            self.jobs.broken[:] = broken
            self._mark_broken(broken)

    def _mark_broken(self, broken: np.ndarray) -> None:
        """The path planner's obstacles: the scenario's, and a square the size of a robot
        where each broken robot stands (it is grown by the radius and clearance like any); then
        the robots that wait for a repair plan again (``Jobs.retry_blocked``)."""
        r = self.spatial.drive.radius_m
        z = self.fleet.last_z_m
        self.marked_z_ = z.copy()
        squares = [
            ((x - r, y - r), (x + r, y - r), (x + r, y + r), (x - r, y + r))
            for x, y in zip(z.real[broken].tolist(), z.imag[broken].tolist(), strict=True)
        ]
        static = self.spatial.obstacles  # what self.planner sees: its pairs are looked up
        self.path_planner.set_obstacles([*static, *squares], known=(self.planner, len(static)))
        self.jobs.retry_blocked(self.time_s)  # a repair may have opened a way

    def summary(self, record=None) -> dict:
        """JSON-able physics statistics of the run so far: contacts begun robot-robot and
        robot-wall, each a touch (closing speed below ``[spatial.contacts] impact_mps``) or an
        impact, also per robot-hour (robots x simulated hours); where driving robots stood still and
        why (``sim.spatial.stalls``)."""
        c = self.contacts
        hours = max(self.scenario.n_robots * self.time_s / 3600.0, 1e-12)
        kinds = {
            "robot_touch": c.robot_hits - c.robot_impacts,
            "robot_impact": c.robot_impacts,
            "wall_touch": c.wall_hits - c.wall_impacts,
            "wall_impact": c.wall_impacts,
        }
        return {
            **{f"contacts_{k}": n for k, n in kinds.items()},
            **{f"contacts_{k}_per_robot_h": n / hours for k, n in kinds.items()},
            "sim_time_s": self.time_s,
            "physics_steps": self.steps_,
            "distance_driven_m": float(self.fleet.moved_m.sum()),
            "collisions_robot": self.collisions_robot_,
            "collisions_wall": self.collisions_wall_,
            "max_overlap_m": self.contacts_max_overlap_m,
            "failed_tasks": self.jobs.failures,
            **self.stalls.summary(),
            **self.jobs.traffic_summary(),  # traffic_*: only with [spatial.traffic] rules on
        }

    def _control(self) -> None:
        """One control period, then the trajectory recorder; while nothing moves, only the task
        clock and the recorder (poses, commands and caps are as they were)."""
        self.last_ctrl_step_ = self.clock.steps
        t, f, sch = self.time_s, self.fleet, self.schedule
        if sch.resting and not (sch.n_steer or sch.n_backoff):
            self.jobs.end_due(t)
            if self.recorder is not None:
                z = f.last_z_m
                xy = np.column_stack([z.real, z.imag])
                shown = shown_now(f.state, f.t_progress_s, t)
                self.recorder.poses(t, xy, f.last_th_rad, shown)
            return
        self.control.period(t)
        holding = self.jobs.sites.holding
        if self.jobs.avoid:
            if self.jobs.traffic is not None:  # single-lane passages, before the jam rules
                self.jobs.traffic.period(t)
                holding = holding | self.jobs.held
            if self.spatial.look_ahead == "on":
                self.jobs.jams.look_ahead(t)
            near = self.jobs.jams.standing_near(t)
            if near:  # (both do nothing without a robot standing near another)
                self.jobs.jams.pass_workers(t, near)
                self.jobs.jams.break_jams(t, near)
        self.stalls.sample(f, holding)
        if self.recorder is not None:
            shown = shown_now(f.state, f.t_progress_s, t)
            self.recorder.poses(t, self.motors.flat[:, :2], f.last_th_rad, shown)
