"""The control period of a small team, robot by robot in plain Python.

For a handful of robots the cost of a numpy control period is the per-call overhead of about a
hundred small array operations, not the arithmetic: the same law written per robot with Python
floats and complex numbers is several times faster, and it skips what a robot does not need
(one standing still costs a comparison). :class:`ScalarControl` is that scalar twin of
:class:`sim.spatial.control.array.ArrayControl`: the same formulas (``sim.spatial.law.drive``,
called robot by robot), the same order, the same event handlers (``sim.spatial.jobs.Jobs``); rare
work (waypoint switches, arrivals, stuck checks, make-way) calls the array code.
``tests/parity/test_controls.py`` runs both from copies of the same state and checks that they
command the same wheels; ``tests/behaviour/test_physics.py`` runs the behaviour tests through both.

It also skips what cannot change: it looks only at pairs with a steering robot (a standing robot
has no speed to cap) and sleeps the proximity check until a steering robot could come within
``look_m`` of another (every event wakes it), and it writes only the motors whose command changed
(a robot stopped and staying stopped keeps its control body as it is: with ``max_bias = 0`` the
joints match velocities only, so where that body stands does not matter).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import atan2, cos, sqrt

import numpy as np

from sim.spatial.control.avoidance import steer_clear, wall_clear
from sim.spatial.control.protocol import ControlParts
from sim.spatial.law.drive import (
    approach_cap_mps,
    control_body,
    goes_our_way,
    next_check_s,
    on_arc,
    pair_share_m,
    preferred_velocity,
    rim_speed_mps,
    steer_speeds,
    stopping_time_s,
    twist_from_rims,
)
from sim.states import DRIVING, IDLE


@dataclass(frozen=True, slots=True, eq=False)
class ScalarControl:
    """One control period of a small team, robot by robot in Python floats and complex numbers.

    Args:
        parts: the world's state and collaborators; its jobs must keep the schedule's lists,
            its follower exact free widths (read as lists); the motors are read in one batch
            and the changed commands written one by one.
    """

    name = "scalar"
    free_cap_m = np.inf  # reads the free widths as lists and never refines them: exact ones
    keeps_lists = True

    parts: ControlParts

    def period(self, t: float) -> None:
        """Read poses, advance tasks, steer, cap speeds, limit the wheels, write the motors."""
        p = self.parts
        f, sch, jobs, c = p.fleet, p.schedule, p.jobs, p.controller
        motors, fol = p.motors, p.follower
        rob = motors.read()
        zn, thn = rob["z"], rob["th"]
        hn = np.exp(1j * thn)
        zs, ths, hs = zn.tolist(), thn.tolist(), hn.tolist()
        m = len(zs)
        f.moved_m += np.abs(zn - f.last_z_m)
        f.last_z_m[:] = zn
        f.last_th_rad[:] = thn
        # ---- tasks: steering targets, progress, yield, arrival (ArrayControl._steer) ----
        state = sch.state_list  # the state and the steered robots as lists, kept by Jobs.refresh
        v0s = f.v_cmd_mps.tolist()  # speeds commanded last period
        backing = []
        if sch.n_backoff:
            until, replan = f.backoff_until_s.tolist(), f.replan.tolist()
            backing = [j for j in range(m) if state[j] == DRIVING and until[j] > t]
            for j in range(m):
                if replan[j] and state[j] == DRIVING and until[j] <= t:
                    jobs.replan(j, (zs[j].real, zs[j].imag), t)
            state = sch.state_list
        yielding = f.yielding.tolist() if sch.n_yield else None
        go = [s == DRIVING for s in state]
        steered = sch.steer_list
        if backing:
            for j in backing:
                go[j] = False
            steered = [j for j in steered if j not in backing]
        v, w = [0.0] * m, [0.0] * m
        pref = [0j] * m
        off = []  # robots beyond the free width of their path
        if steered:
            tgt, unit_c, switch, beyond, free0, free1, after, corner2, seg_m = fol.segment_lists()
            gain, bias = c.align_gain_, c.align_bias_
            heading_gain, lookahead = c.heading_gain, fol.lookahead_m
            step_m, recovered_m = jobs.recovery.progress_m, jobs.recovery.recovered_m
            brake2 = 2.0 * c.brake_mps2
            brake, top_v, avoiding = c.brake_mps2, c.v_max_mps, p.avoid
            left_m, progress = f.left_m, f.progress_m.tolist()
            until = f.yield_until_s.tolist() if yielding is not None else None
            stops = []
            for j in steered:
                z = zs[j]
                d = tgt[j] - z
                gap = abs(d)
                p = d * unit_c[j]
                if gap < switch[j] or p.real < beyond[j]:  # next waypoint
                    fol.index[j] += 1
                    fol.load_one(j)
                    fol.refresh_list_entry(j)
                    d = tgt[j] - z
                    gap = abs(d)
                    p = d * unit_c[j]
                side, aim = p.imag, d
                if side < free0[j] or side > free1[j]:  # straight could touch an obstacle
                    back = min(max(p.real - lookahead, 0.0), seg_m[j])
                    aim = d - back * unit_c[j].conjugate()
                    off.append(j)
                local = aim * hs[j].conjugate()
                err = atan2(local.imag, local.real)
                vj, stop = steer_speeds(cos(err), gap, corner2[j], gain, bias, brake2, sqrt)
                if avoiding:
                    pref[j] = preferred_velocity(aim, gap, corner2[j], brake, top_v, sqrt, min)
                vj = 0.0 if vj < 0.0 else (stop if stop < vj else vj)
                wj = err * heading_gain
                left = gap + after[j]
                left_m[j] = left
                if yielding is not None and yielding[j] and (left < 0.15 or until[j] < t):
                    stops.append(j)
                    vj = wj = 0.0
                elif go[j] and left < progress[j]:
                    f.progress_m[j] = left - step_m
                    f.t_progress_s[j] = t
                    if sch.recovering and left < f.stuck_left_m[j] - recovered_m:
                        jobs.recovered([j])  # got past where it last got stuck
                v[j], w[j] = vj, wj
            for j in stops:
                jobs.stop_yield(j)
            if stops:
                jobs.refresh()
            if t > sch.stuck_check_s:
                jobs.check_stuck(np.array(go), t)
            if t >= sch.site_check_s:
                self._arrive(zs, go, v, w, t)
        for j in backing:
            v[j], w[j] = f.backoff_cmd[j].tolist()
        jobs.end_due(t)
        # ---- other robots: ORCA (sim.spatial.law.orca), proximity caps (controller.proximity) ----
        orca = ()  # robots whose command ORCA set: the wheels follow it as it is
        if self.parts.avoid and steered:  # (p was reused for a point above)
            out = steer_clear(self.parts, zn, rob["vel"], hn, np.array(pref), np.array(v), t, True)
            if out is not None:
                orca = set(out[0].tolist())
                for j, vj, wj in zip(*(a.tolist() for a in out), strict=True):
                    v[j], w[j] = vj, wj
        state = sch.state_list  # arrivals and ends of work may have changed it
        if t >= sch.prox_check_s:
            self._near(zn, zs, ths, hs, hn, state, v, v0s, w, t)
        else:
            f.clear_way()
        if steered:  # heading out of the free width before it could stop (PathFollower.drifting)
            react, inv2a = c.react_s, c.inv2a_
            for j in steered:
                sj = v[j] if abs(v[j]) >= abs(v0s[j]) else v0s[j]
                side = ((tgt[j] - zs[j]) * unit_c[j]).imag
                side -= (hs[j] * unit_c[j]).imag * (sj * stopping_time_s(sj, react, inv2a))
                if (side < free0[j] or side > free1[j]) and j not in off:
                    off.append(j)
        if (
            steered and self.parts.avoid
        ):  # walls as ORCA lines (sim.spatial.law.orca.steer_walls); caps
            out = wall_clear(self.parts, zn, hn, np.array(v), np.array(pref), orca, t)
            if out is not None:
                walled = set(out[0].tolist())
                for j, vj, wj in zip(*(a.tolist() for a in out), strict=True):
                    v[j], w[j] = vj, wj
                orca = set(orca) | walled
                off = [j for j in off if j not in walled]
        if off or backing:  # beyond the free width, or backing off blind: mind the obstacles
            self.obstacle_caps(zs, hs, v, off + backing)
        # ---- wheel limits (DiffDriveController.limit) and the motor command (Motors.write) ----
        s, hb, top = c.rim_step_mps, c.half_base_m, c.rim_max_mps
        turn_q = c.turn_first_radps * hb if self.parts.avoid else np.inf  # slow a fast turn first
        q0s = f.q_cmd_mps.tolist()
        write = motors.write_one
        moving = changed = False
        for j in range(m):
            vj, q1, v0, q0 = v[j], w[j] * hb, v0s[j], q0s[j]
            if vj == 0.0 and q1 == 0.0 and v0 == 0.0 and q0 == 0.0:
                continue  # stopped and staying so: its control body stands, anywhere will do
            changed = True
            over = rim_speed_mps(vj, q1) / top
            if over > 1.0:
                vj, q1 = vj / over, q1 / over
            dv, dq = vj - v0, q1 - q0
            if abs(vj) < abs(v0):  # slowing down comes first: the turn gets what is left
                dv = s if dv > s else (-s if dv < -s else dv)
                room = s - abs(dv)
                dq = room if dq > room else (-room if dq < -room else dq)
                right, left = dv + dq, dv - dq
            elif abs(q0) > turn_q and (abs(q1) < abs(q0) or q1 * q0 < 0.0) and j not in orca:
                # a fast turn that must slow comes next: speed gets what is left
                dq = s if dq > s else (-s if dq < -s else dq)
                room = s - abs(dq)
                dv = room if dv > room else (-room if dv < -room else dv)
                right, left = dv + dq, dv - dq
            else:
                right, left = dv + dq, dv - dq
                right = s if right > s else (-s if right < -s else right)
                left = s if left > s else (-s if left < -s else left)
            vj, qj = twist_from_rims(right, left, v0, q0)
            wj = qj * (1.0 / hb)
            v[j], w[j], q0s[j] = vj, wj, qj
            moving = moving or vj != 0.0 or wj != 0.0
            z, h = zs[j], hs[j]
            if on_arc(vj, wj):
                r = vj / wj
                centre, vel = control_body(z, h, vj, wj, r)
            else:  # straight (or standing): the control body on the robot, moving at v h
                r, centre, vel = 0.0, z, vj * h
            write(j, centre.real, centre.imag, ths[j], vel.real, vel.imag, wj, r)
        if changed:
            f.v_cmd_mps, f.q_cmd_mps = np.array(v), np.array(q0s)
        calm = not (sch.n_steer or sch.n_backoff or moving)
        sch.resting, sch.calm = calm and sch.calm, calm

    def _arrive(self, zs, go, v, w, t: float) -> None:
        """``ArrayControl._arrive``, robot by robot."""
        p = self.parts
        f, tol, reach = p.fleet, p.arrive_tol_m, p.reach_m
        zone = tol + 2 * reach
        site, task = f.site.tolist(), f.task.tolist()
        nearest, arrived, queue = np.inf, [], []
        for j in range(len(zs)):
            if go[j]:
                gap = abs(site[j] - zs[j])
                nearest = gap if gap < nearest else nearest
                if task[j] < 0:  # the stuck check failed its task in this period
                    continue
                if gap <= tol:
                    arrived.append(j)
                elif gap <= zone:
                    queue.append((j, gap))
        if queue and p.avoid:  # no pushing in: a slot, or wait for the service point
            p.jobs.sites.take_slots([j for j, _ in queue], np.array(zs), t)
            queue = []
        if queue:  # touching a robot that stands nearer the site: the site is taken,
            # and working beside the robots already there counts as arrived
            near, state, yielding = (
                f.near_m.tolist(),
                f.state.tolist(),
                f.yielding.tolist(),
            )
            still = [k for k in range(len(zs)) if state[k] != DRIVING and not yielding[k]]
            for j, gap in queue:
                if near[j] <= reach and any(
                    abs(zs[k] - site[j]) < gap and abs(zs[k] - zs[j]) <= reach for k in still
                ):
                    arrived.append(j)
            arrived.sort()
        p.jobs.start_work(arrived, v, w, t)
        speed = p.controller.speed_bound * p.controller.v_max_mps
        p.schedule.site_check_s = next_check_s(t, nearest - zone, speed)

    def obstacle_caps(self, zs, hs, v, rows) -> None:
        """``ArrayControl.obstacle_caps`` (``DiffDriveController.wall_cap``), robot by robot.

        Args:
            zs: positions; hs: unit headings (lists of complex); v: speed commands (a list, m/s,
                written in place); rows: the robots to cap.
        """
        c, to_obstacle = self.parts.controller, self.parts.follower.to_obstacle_one
        two_a, at, at2, creep = c.two_a_, c.at_, c.at2_, c.creep_mps
        for j in rows:
            vj = v[j]
            if vj == 0.0:  # nothing to cap
                continue
            near = to_obstacle(zs[j])
            dist = abs(near)
            tau = (near * hs[j].conjugate()).real / (dist if dist > 1e-12 else 1e-12)
            tau = -tau if vj < 0.0 else tau
            tau = tau if tau > 1e-9 else 1e-9
            share = dist - c.radius_m if dist > c.radius_m else 0.0
            cap, floor = approach_cap_mps(share, tau, two_a, at, at2, sqrt, creep)
            cap = floor if cap < floor else cap
            if cap < abs(vj):
                v[j] = cap if vj > 0.0 else -cap

    def _near(self, zn, zs, ths, hs, hn, state, v, vprev, w, t: float) -> None:
        """Proximity caps, keep-right and make-way, over the pairs (i, k) with i steering.

        Only a robot that steers (drives, yields or backs off) can be capped, turn right or ask
        another to make way: a standing robot has no speed to cap, so its pairs are not looked
        at (the result is the same as over all pairs). When every steering robot is farther
        than ``look_m`` from every other robot the check sleeps until one could be that close;
        a robot that starts to steer is an event (``Jobs.refresh``), which wakes it.
        """
        p = self.parts
        f, sch, c = p.fleet, p.schedule, p.controller
        m = len(zs)
        look = c.look_m
        movers = sch.steer_list  # driving (backing off too) or yielding
        rows, apart, inf = [], np.inf, np.inf  # (i, z_i, distances from i) within look_m
        for i in movers:
            zi = zs[i]
            dist = [abs(z - zi) for z in zs]
            dist[i] = inf
            nearest = min(dist)
            if nearest < look:
                rows.append((i, zi, dist))
            elif nearest < apart:
                apart = nearest
        if not rows:  # no cap binds before a steering robot could be look_m from another
            sch.prox_check_s = next_check_s(t, apart - look, 2.0 * c.speed_bound * c.v_max_mps)
            f.clear_way()
            return
        contact, react, inv2a, at, at2 = c.contact_m, c.react_s, c.inv2a_, c.at_, c.at2_
        two_a, credit = c.two_a_, 0.5 / c.wheel_decel_
        creep, cos_ahead = c.creep_mps, c.cos_ahead
        limit, near, blocker = [np.inf] * m, [np.inf] * m, [-1] * m
        for i, zi, dist in rows:  # the pairs (i, k) closer than look_m, in order
            vi = v[i]
            if vi == 0.0:
                continue
            hci, vi0 = hs[i].conjugate(), vprev[i]
            stop_i = stopping_time_s(vi0, react, inv2a)
            for k, d in enumerate(dist):
                if d >= look:
                    continue
                r = zs[k] - zi
                d = d if d > 1e-9 else 1e-9
                cos_i = (r * hci).real / d
                toward = -cos_i if vi < 0.0 else cos_i
                if toward <= 0.0:
                    continue
                vk = vprev[k]
                back = -(r * hs[k].conjugate()).real / d * vk if vk else 0.0  # k coming closer
                gap = d - contact if d > contact else 0.0
                if back > 0.0:  # k's stopping distance toward i at its committed speed
                    their = back * stopping_time_s(vk, react, inv2a)
                else:  # k moves away: the distance it still travels while braking
                    their = -back * back * credit
                mine = cos_i * vi0  # how fast i comes closer to k, and its stopping distance
                mine = mine * stop_i if mine > 0.0 else 0.0
                share, half = pair_share_m(gap, their, mine)  # g - theirs less k's half of the rest
                share = half if half < share else share
                share = share if share > 0.0 else 0.0
                cap, floor = approach_cap_mps(share, toward, two_a, at, at2, sqrt, creep)
                cap = floor if cap < floor else cap
                if cap < limit[i]:
                    limit[i] = cap
                if toward > cos_ahead and d < near[i]:
                    near[i], blocker[i] = d, k
        for j in movers:
            if limit[j] < abs(v[j]):
                v[j] = limit[j] if v[j] > 0.0 else -limit[j]
        f.blocker, f.near_m = np.array(blocker), np.array(near)
        closest = min(near)
        if closest < c.keep_right_m and not p.avoid:
            turn, same = c.keep_right_gain * c.omega_max_radps, c.same_way_cos
            for j in movers:
                o = blocker[j]
                if near[j] < c.keep_right_m:
                    if not (state[o] == DRIVING and goes_our_way(ths[j], ths[o], cos, same)):
                        w[j] -= turn
        reach = p.reach_m + p.jobs.stepping.trigger_m
        if closest < reach:
            yielding = f.yielding.tolist()
            pushers = [
                j
                for j in movers
                if state[j] == DRIVING
                and near[j] < reach
                and state[blocker[j]] == IDLE
                and not yielding[blocker[j]]
            ]
            if pushers:
                p.jobs.make_way(np.array(pushers), f.blocker, zn, hn, np.array(v), t)
