"""The control period compiled: one implementation for every team size.

A period is one call into compiled code (``sim.spatial.control.kernel``, numba), with Python
before, between and after its stages for the events only:

1. Robots done backing off plan again first (``Jobs.replan``: Python, it may fail a task).
2. The first half (``kernel.steering``): poses from the motors' batched read, the odometer,
   each robot's path aim (waypoints passed), its wanted (v, omega), ORCA's preferred velocity and
   its progress. If that leaves something to Python, the call returns and Python acts in the
   order ``ArrayControl`` does: yields to stop (``Jobs.stop_yield``), robots past where they got
   stuck (``Jobs.recovered``), the stuck check and arrival when they are due
   (``Jobs.check_stuck``, ``sim.spatial.control.arrival``), the end of work
   (``Jobs.end_due``); then it calls again for the rest.
3. The second half (``kernel.commands``): ORCA for the robots that steer themselves, the
   proximity caps, keep-right and the make-way requests, the wall lines, the speed caps toward
   obstacles and the wheel limits. A make-way request (``Jobs.make_way``) is handled between the
   proximity caps and the wall lines, as in ``ArrayControl``. The motors are written in one batch.

The rules are those of ``ArrayControl`` (the numpy law stays as their reference in the tests),
with one change on purpose: a velocity program with no solution keeps the wall and lane lines
hard and breaks the robots' lines least (RVO2's linearProgram3; ``kernel.linprog``).

numba is imported with the first control period built (``kernel.loading``), so a process that
never builds a pymunk world does not pay for it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.spatial.control.arrival import arrive, next_arrival_check_s
from sim.spatial.control.avoidance import wall_reach_m
from sim.spatial.control.kernel.settings import avoid_law, drive_law
from sim.spatial.control.kernel.views import (
    edges_of,
    fleet_of,
    follower_of,
    kept_for,
    outputs_for,
    poses_for,
    shapes_of,
    sites_of,
    wishes_for,
)
from sim.spatial.control.protocol import ControlParts
from sim.spatial.law.drive import next_check_s
from sim.states import DRIVING

FREE_CAP_M = 2.0  # side steps' free widths as far as this, then exactly where a robot needs it


@dataclass(frozen=True, slots=True, eq=False)
class CompiledControl:
    """One control period of the whole fleet in compiled code, events in Python.

    Args:
        parts: the world's state and collaborators; the motors are read and written in one
            batch each. Building one loads the compiled kernel (compiling it once per install:
            ``sim.spatial.control.kernel.loading``).

    Attributes:
        poses_, wishes_: this period's poses (z, h, th, vel) and each robot's wish (v, w,
            pref, go, stop, past), as ``kernel.steering`` names them.
        kernel_: the kernel's entry module (``kernel.period``), loaded and compiled.
    """

    name = "compiled"
    free_cap_m = FREE_CAP_M  # the kernel refines a capped width where a robot is beyond it
    keeps_lists = False

    parts: ControlParts
    kernel_: object = field(init=False)
    drive_: tuple = field(init=False)
    avoid_: tuple = field(init=False)
    edges_: tuple = field(init=False)
    shapes_: tuple = field(init=False)
    poses_: tuple = field(init=False)
    wishes_: tuple = field(init=False)
    kept_: tuple = field(init=False)

    def __post_init__(self) -> None:
        from sim.spatial.control.kernel import loading, period  # numba, on first use

        loading.ensure_compiled()
        p, m = self.parts, len(self.parts.fleet.state)
        law = drive_law(p.controller, p.follower, p.jobs.recovery)
        for name, value in (
            ("kernel_", period),
            ("drive_", tuple(law)),
            ("avoid_", tuple(avoid_law(p.orca))),
            ("edges_", edges_of(p.follower, wall_reach_m(p))),
            ("shapes_", shapes_of(p.follower)),
            ("poses_", poses_for(m)),
            ("wishes_", wishes_for(m)),
            ("kept_", kept_for(m)),
        ):
            object.__setattr__(self, name, value)

    def period(self, t: float) -> None:
        """Read poses, advance tasks, steer, cap speeds, limit the wheels, write the motors."""
        p, kernel = self.parts, self.kernel_
        f, sch, jobs = p.fleet, p.schedule, p.jobs
        p.motors.read()
        read = True
        if sch.n_backoff:  # robots done backing off plan again first (they may fail)
            back = (f.state == DRIVING) & (f.backoff_until_s > t)
            due = (f.replan & ~back).nonzero()[0].tolist()
            if due:
                kernel.read_only(p.motors.flat, fleet_of(f), self.poses_)
                read = False
                z = self.poses_[0]
                for j in due:
                    jobs.replan(j, (z[j].real, z[j].imag), t)
        out = outputs_for(len(f.state))
        prox_s = sch.prox_check_s
        res = self._call(kernel.START, t, read, out)
        status, passed, steering, stops, pasts, capped, distance = res[:7]
        if res[7] or res[8] or res[9]:  # not all kernel.ACTS
            self._quiet(t, *res[7:])
        if status == kernel.EVENTS:
            if steering:
                self._events(t, stops, pasts)
            jobs.end_due(t)
            prox_s = sch.prox_check_s
            res = self._call(kernel.COMMANDS, t, False, out)
            status, more, capped, distance = res[0], res[1], res[5], res[6]
            passed += more
        self._way(t, t >= prox_s, capped, distance, out)
        if status == kernel.MAKE_WAY:
            z, h = self.poses_[0], self.poses_[1]
            jobs.make_way(out[5].nonzero()[0], f.blocker, z, h, self.wishes_[0], t)
            passed += self._call(kernel.FINISH, t, False, out)[1]
        if passed:
            p.follower.version_ += 1  # the current-segment arrays changed
        v, w, q = out[0], out[1], out[2]
        f.v_cmd_mps, f.q_cmd_mps = v, q
        z, h, th = self.poses_[0], self.poses_[1], self.poses_[2]
        p.motors.write(z, th, h, v, w)
        calm = not (sch.n_steer or sch.n_backoff)
        calm = calm and not (np.count_nonzero(v) or np.count_nonzero(w))
        sch.resting, sch.calm = calm and sch.calm, calm

    def _quiet(self, t: float, stuck_kind: int, site_kind: int, queue_kind: int) -> None:
        """The stuck check, the arrival check and the site queues, found by the kernel with
        nothing to do but set their next times (of the kind ``kernel.NOW``, ``LATER`` or
        ``NEVER``; ``ACTS``: the check was not found so): set them, each with its check's own
        code."""
        p, kernel = self.parts, self.kernel_
        if stuck_kind == kernel.LATER:
            p.schedule.stuck_check_s = p.jobs.next_stuck_check_s()
        if site_kind == kernel.NOW:
            p.schedule.site_check_s = t
        elif site_kind == kernel.LATER:
            gap = np.abs(p.fleet.site - self.poses_[0])
            p.schedule.site_check_s = next_arrival_check_s(p, gap, self.wishes_[3], t)
        sites = p.jobs.sites
        if queue_kind == kernel.NOW:
            sites.queue_check_s = t
        elif queue_kind == kernel.NEVER:
            sites.queue_check_s = np.inf
        elif queue_kind == kernel.LATER:
            sites.queue_check_s = sites.later_check_s(t)

    def _call(self, stage: int, t: float, read: bool, out: tuple) -> tuple:
        """``kernel.run_period`` from ``stage`` with the state as it is now."""
        p = self.parts
        sch, f = p.schedule, p.fleet
        schedule = (
            bool(p.avoid),
            int(sch.n_backoff),
            int(sch.n_yield),
            int(sch.n_steer),
            bool(sch.recovering),
            float(sch.stuck_check_s),
            float(sch.site_check_s),
            float(sch.prox_check_s),
            float(p.jobs.sites.queue_check_s),
            float(sch.next_end_s),
            float(sch.next_deadline_s),
        )
        return self.kernel_.run_period(
            stage,
            float(t),
            read,
            schedule,
            float(p.reach_m + p.jobs.stepping.trigger_m),
            p.motors.flat,
            fleet_of(f),
            follower_of(p.follower),
            self.poses_,
            self.wishes_,
            self.drive_,
            self.avoid_,
            self.edges_,
            self.shapes_,
            self.kept_,
            sites_of(p),
            out,
        )

    def _events(self, t: float, stops: int, pasts: int) -> None:
        """What the first half reported, in ``ArrayControl._steer``'s order."""
        p = self.parts
        jobs, sch = p.jobs, p.schedule
        _, _, _, go, stop, past = self.wishes_
        if stops:
            for j in stop.nonzero()[0].tolist():
                jobs.stop_yield(j)
            jobs.refresh()
        if pasts:
            jobs.recovered(past.nonzero()[0].tolist())
        if t > sch.stuck_check_s:
            jobs.check_stuck(go, t)
        if t >= sch.site_check_s:
            arrive(p, self.poses_[0], go, self.wishes_[0], self.wishes_[1], t)

    def _way(self, t: float, due: bool, capped: bool, distance: float, out: tuple) -> None:
        """The robot in each one's way from the proximity caps, or none; the next check when
        no cap can bind before two robots could be ``look_m`` apart."""
        p = self.parts
        f, c = p.fleet, p.controller
        if capped:
            f.blocker, f.near_m = out[3], out[4]
            return
        if due:
            closing = 2.0 * c.speed_bound * c.v_max_mps
            p.schedule.prox_check_s = next_check_s(t, distance - c.look_m, closing)
        f.clear_way()
