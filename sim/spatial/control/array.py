"""The control period over numpy arrays: every robot in each array operation.

For larger teams the cost of a control period is the arithmetic, and numpy does it over the
robot axis (``sim.spatial.controller.DiffDriveController`` holds the vectorised law,
``sim.spatial.navigation.paths`` the path following). Checks that cannot fire yet are skipped until
the earliest time they could (the schedule in ``sim.spatial.fleet``); per-robot Python runs on task
events only (``sim.spatial.jobs``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from sim.spatial.control.arrival import arrive
from sim.spatial.control.avoidance import steer_clear, wall_clear
from sim.spatial.control.protocol import ControlParts
from sim.spatial.law.drive import next_check_s, preferred_velocity
from sim.states import DRIVING, IDLE

FREE_CAP_M = 2.0  # free widths of side steps as far as this (the step is 1 m), then on demand


@dataclass(frozen=True, slots=True, eq=False)
class ArrayControl:
    """One control period of the whole fleet over numpy arrays.

    Args:
        parts: the world's state and collaborators; the motors are read and written in one
            batch each.
    """

    name = "array"
    free_cap_m = FREE_CAP_M  # a side step's free widths exactly only when a robot gets that far
    keeps_lists = False

    parts: ControlParts
    pref_: np.ndarray = field(init=False)  # (m,) preferred velocities for ORCA, m/s

    def __post_init__(self) -> None:
        object.__setattr__(self, "pref_", np.zeros(len(self.parts.fleet.state), dtype=complex))

    def period(self, t: float) -> None:
        """Read poses, advance tasks, steer, cap speeds, limit the wheels, write the motors."""
        p = self.parts
        f, sch, c, motors = p.fleet, p.schedule, p.controller, p.motors
        rob = motors.read()
        z, th = rob["z"], rob["th"]
        h = np.exp(1j * th)
        hc = h.conj()
        f.moved_m += np.abs(z - f.last_z_m)
        f.last_z_m[:] = z
        f.last_th_rad[:] = th
        v, w, rows = self._steer(z, hc, t)  # rows: robots beyond the free width of their path
        orca = None  # robots whose command ORCA set: the wheels follow it as it is
        if p.avoid and sch.n_steer:
            orca = self._avoid(z, rob["vel"], h, v, w, t)
        if t >= sch.prox_check_s:
            self._near(z, th, h, hc, v, w, t)
        else:
            f.clear_way()
        if sch.n_steer:  # ... and the robots whose heading could carry them out of it
            v_cmd = f.v_cmd_mps  # the speed next period lies between v_cmd and v
            reach = np.where(np.abs(v) >= np.abs(v_cmd), v, v_cmd)
            rows = p.follower.drifting(z, h, reach, c.react_s, c.inv2a_)
        if sch.n_backoff:  # backing off blind, without a path: mind the obstacles too
            back = (f.backoff_until_s > t).nonzero()[0]
            rows = back if rows is None else np.union1d(rows, back)
        if p.avoid and sch.n_steer:  # walls as ORCA lines; the caps for the others
            out = wall_clear(p, z, h, v, self.pref_, orca, t)
            if out is not None:
                sel = out[0]
                v[sel], w[sel] = out[1], out[2]
                orca = sel if orca is None else np.union1d(orca, sel)
                rows = None if rows is None else np.setdiff1d(rows, sel)
        if rows is not None and len(rows):
            self.obstacle_caps(z, hc, v, rows)
        v, w, f.q_cmd_mps = c.limit(v, w, f.v_cmd_mps, f.q_cmd_mps, p.avoid, orca)
        f.v_cmd_mps = v
        motors.write(z, th, h, v, w)
        calm = not (sch.n_steer or sch.n_backoff)
        calm = calm and not (np.count_nonzero(v) or np.count_nonzero(w))
        sch.resting, sch.calm = calm and sch.calm, calm  # stopped for a whole period

    def _steer(self, z: np.ndarray, hc: np.ndarray, t: float):
        """Advance every robot's task (progress, yield, stuck, arrival); desired twists and the
        robots beyond the free width of their path (None: not looked at)."""
        p = self.parts
        f, sch, jobs = p.fleet, p.schedule, p.jobs
        off_path = None
        go = f.state == DRIVING
        steered = go | f.yielding if sch.n_yield else go
        back = None
        if sch.n_backoff:
            back = go & (f.backoff_until_s > t)
            for j in (f.replan & ~back).nonzero()[0].tolist():
                jobs.replan(j, (z[j].real, z[j].imag), t)
            go = (f.state == DRIVING) & ~back
            steered = go | f.yielding
        if sch.n_steer if back is None else np.count_nonzero(steered):
            aim, gap, left, corner2, off_path = p.follower.targets(z)
            v, w = p.controller.steer(hc, aim, gap, corner2)
            if p.avoid:
                self.pref_[:] = preferred_velocity(
                    aim,
                    gap,
                    corner2,
                    p.controller.brake_mps2,
                    p.controller.v_max_mps,
                    np.sqrt,
                    np.minimum,
                )
                np.multiply(self.pref_, steered, out=self.pref_)
            if back is not None or sch.n_steer < len(v):
                v *= steered
                w *= steered
            np.copyto(f.left_m, left, where=steered)
            if sch.n_yield:
                stop = f.yielding & ((left < 0.15) | (f.yield_until_s < t))
                if np.count_nonzero(stop):
                    for j in stop.nonzero()[0].tolist():
                        jobs.stop_yield(j)
                        v[j] = w[j] = 0.0
                    jobs.refresh()
            better = left < f.progress_m
            better &= go
            if np.count_nonzero(better):
                np.putmask(f.progress_m, better, left - jobs.recovery.progress_m)
                np.putmask(f.t_progress_s, better, t)
                if sch.recovering:  # got past where it last got stuck: tries start again
                    past = better & (left < f.stuck_left_m - jobs.recovery.recovered_m)
                    if np.count_nonzero(past):
                        jobs.recovered(past.nonzero()[0].tolist())
            if t > sch.stuck_check_s:
                jobs.check_stuck(go, t)
            if t >= sch.site_check_s:
                self._arrive(z, go, v, w, t)
        else:
            v, w = np.zeros(len(z)), np.zeros(len(z))
        if back is not None:
            v[back], w[back] = f.backoff_cmd[back].T
        jobs.end_due(t)
        return v, w, off_path

    def _avoid(self, z, vel, h, v, w, t: float):
        """ORCA for the robots that steer (``steer_clear``; writes ``v``, ``w`` in place);
        returns the robots whose command it set, or None."""
        out = steer_clear(self.parts, z, vel, h, self.pref_, v, t)
        if out is None:
            return None
        sel, v_new, w_new = out
        v[sel], w[sel] = v_new, w_new
        return sel

    def _arrive(self, z: np.ndarray, go: np.ndarray, v: np.ndarray, w: np.ndarray, t: float):
        """Arrivals (``sim.spatial.control.arrival``), against neighbours in large fleets."""
        c = self.parts.controller
        arrive(self.parts, z, go, v, w, t, None if len(z) <= c.dense_max else c.neighbour_pairs)

    def _near(self, z, th, h, hc, v, w, t: float) -> None:
        """Proximity caps, keep-right and make-way (writes ``v``, ``w`` in place)."""
        p = self.parts
        f, c, reach = p.fleet, p.controller, p.reach_m + p.jobs.stepping.trigger_m
        cap, blocker, near, apart = c.proximity(z, hc, v, f.v_cmd_mps)
        if cap is None:  # no cap binds before two robots could be look_m apart
            closing = 2.0 * c.speed_bound * c.v_max_mps
            p.schedule.prox_check_s = next_check_s(t, apart - c.look_m, closing)
            f.clear_way()
            return
        v[:] = cap
        f.blocker, f.near_m = blocker, near
        closest = float(near.min())
        if closest < c.keep_right_m and not p.avoid:
            w[:] = c.keep_right(th, w, blocker, near, f.state == DRIVING)
        if closest < reach:
            pushing = (f.state == DRIVING) & (near < reach)
            standing = (f.state == IDLE) & ~f.yielding
            pushing &= standing[np.maximum(blocker, 0)]
            if np.count_nonzero(pushing):
                p.jobs.make_way(pushing.nonzero()[0], blocker, z, h, v, t)

    def obstacle_caps(self, z, hc, v, rows) -> None:
        """Cap the speed of robots ``rows`` toward their nearest obstacle (writes ``v``).

        Args:
            z: (m,) positions; hc: (m,) conjugate unit headings; v: (m,) speed commands, m/s.
        """
        rows = np.asarray(rows)
        gap = self.parts.follower.to_obstacle(z[rows])
        capped = self.parts.controller.wall_cap(hc[rows], np.asarray(v)[rows], gap)
        for j, vj in zip(rows.tolist(), capped.tolist(), strict=True):
            v[j] = vj
