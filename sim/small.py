"""The control period of a small team, robot by robot in plain Python.

For a handful of robots the cost of a numpy control period is the per-call overhead of about a
hundred small array operations, not the arithmetic: the same law written per robot with Python
floats and complex numbers is several times faster, and it skips what a robot does not need
(one standing still costs a comparison). :class:`SmallTeamMixin` is that scalar twin of
``PymunkWorld._control`` (``sim.physics``) and of the array parts of ``sim.jobs``: the same
formulas (``sim.drive.DiffDriveController``, ``sim.paths.PathFollower``), the same order, the
same event handlers; rare work (waypoint switches, arrivals, stuck checks, make-way) calls the
array code. ``PymunkWorld`` uses it up to ``SMALL_TEAM`` robots; ``tests/sim/test_physics.py``
runs the behaviour tests through both and checks that they command the same wheels period by
period.
"""

from __future__ import annotations

from math import atan2, cos, sqrt

import numpy as np

from sim.drive import AHEAD_DEG, CREEP_MPS, HEADING_GAIN, KEEP_RIGHT_GAIN
from sim.jobs import PROGRESS_M, RECOVERED_M, SPEED_BOUND, YIELD_TRIGGER_M
from sim.motors import ARC_MAX_RADIUS_M
from sim.paths import LOOKAHEAD_M
from sim.recording import DRIVING, IDLE

SMALL_TEAM = 24  # up to this many robots a control period runs per robot in Python
_COS_AHEAD = float(np.cos(np.radians(AHEAD_DEG)))


class SmallTeamMixin:
    """Scalar control period (see the module docstring); arrays from ``PymunkWorld.reset``."""

    def _control_small(self, t: float) -> None:
        motors, c, f = self.motors, self.controller, self.follower
        rob = motors.read()
        zn, thn = rob["z"], rob["th"]
        hn = np.exp(1j * thn)
        zs, ths, hs = zn.tolist(), thn.tolist(), hn.tolist()
        m = len(zs)
        self.moved_m_ += np.abs(zn - self.last_z_)
        self.last_z_[:] = zn
        self.last_th_[:] = thn
        # ---- tasks: steering targets, progress, yield, arrival (sim.jobs._jobs) ----
        state = self.state_list_  # state_ and the steered robots as lists, kept by _events
        v0s = self.v_cmd_.tolist()  # speeds commanded last period
        backing = []
        if self.n_backoff_:
            until, replan = self.backoff_until_s_.tolist(), self.replan_.tolist()
            backing = [j for j in range(m) if state[j] == DRIVING and until[j] > t]
            for j in range(m):
                if replan[j] and state[j] == DRIVING and until[j] <= t:
                    self._replan(j, (zs[j].real, zs[j].imag), t)
            state = self.state_list_
        yielding = self.yielding_.tolist() if self.n_yield_ else None
        go = [s == DRIVING for s in state]
        steered = self.steer_list_
        if backing:
            for j in backing:
                go[j] = False
            steered = [j for j in steered if j not in backing]
        v, w = [0.0] * m, [0.0] * m
        off = []  # robots beyond the free width of their path
        if steered:
            tgt, unit_c, switch, beyond, free0, free1, after, corner2, seg_m = f.segment_lists()
            gain, bias = c.align_gain_, c.align_bias_
            brake2 = 2.0 * c.brake_mps2
            left_m, progress = self.left_m_, self.progress_m_.tolist()
            until = self.yield_until_s_.tolist() if yielding is not None else None
            stops = []
            for j in steered:
                z = zs[j]
                d = tgt[j] - z
                gap = abs(d)
                p = d * unit_c[j]
                if gap < switch[j] or p.real < beyond[j]:  # next waypoint
                    f.index[j] += 1
                    f.load_one(j)
                    f.refresh_list_entry(j)
                    d = tgt[j] - z
                    gap = abs(d)
                    p = d * unit_c[j]
                side, aim = p.imag, d
                if side < free0[j] or side > free1[j]:  # straight could touch an obstacle
                    back = min(max(p.real - LOOKAHEAD_M, 0.0), seg_m[j])
                    aim = d - back * unit_c[j].conjugate()
                    off.append(j)
                local = aim * hs[j].conjugate()
                err = atan2(local.imag, local.real)
                vj = cos(err) * gain + bias
                stop = sqrt(gap * brake2 + corner2[j])
                vj = 0.0 if vj < 0.0 else (stop if stop < vj else vj)
                wj = err * HEADING_GAIN
                left = gap + after[j]
                left_m[j] = left
                if yielding is not None and yielding[j] and (left < 0.15 or until[j] < t):
                    stops.append(j)
                    vj = wj = 0.0
                elif go[j] and left < progress[j]:
                    self.progress_m_[j] = left - PROGRESS_M
                    self.t_progress_s_[j] = t
                    if self.recovering_ and left < self.stuck_left_m_[j] - RECOVERED_M:
                        self._recovered([j])  # got past where it last got stuck
                v[j], w[j] = vj, wj
            for j in stops:
                self._stop_yield(j, refresh=False)
            if stops:
                self._events()
            if t > self.stuck_check_s_:
                self._stuck(np.array(go), t)
            if t >= self.site_check_s_:
                self._arrive_small(zs, go, v, w, t)
        for j in backing:
            v[j], w[j] = self.backoff_cmd_[j].tolist()
        self._clock(t)
        # ---- other robots (sim.drive.DiffDriveController.proximity), obstacles ----
        state = self.state_list_  # arrivals and ends of work may have changed it
        if t >= self.prox_check_s_:
            self._near_small(zn, zs, ths, hs, hn, state, v, v0s, w, t)
        else:
            self.blocker_, self.near_ = self.nobody_
        if steered:  # heading out of the free width before it could stop (PathFollower.drifting)
            react, inv2a = c.react_s, c.inv2a_
            for j in steered:
                sj = v[j] if abs(v[j]) >= abs(v0s[j]) else v0s[j]
                side = ((tgt[j] - zs[j]) * unit_c[j]).imag
                side -= (hs[j] * unit_c[j]).imag * (sj * (react + abs(sj) * inv2a))
                if (side < free0[j] or side > free1[j]) and j not in off:
                    off.append(j)
        if off or backing:  # beyond the free width, or backing off blind: mind the obstacles
            self._obstacle_caps_small(zs, hs, v, off + backing)
        # ---- wheel limits (DiffDriveController.limit) and the motor command (Motors.write) ----
        s, hb, top = c.rim_step_mps, c.half_base_m, c.rim_max_mps
        q0s = self.q_cmd_.tolist()
        write = motors.write_one
        moving = changed = False
        for j in range(m):
            vj, q1, v0, q0 = v[j], w[j] * hb, v0s[j], q0s[j]
            if vj == 0.0 and q1 == 0.0 and v0 == 0.0 and q0 == 0.0:
                continue  # stopped and staying so: its control body stands, anywhere will do
            changed = True
            over = (abs(vj) + abs(q1)) / top
            if over > 1.0:
                vj, q1 = vj / over, q1 / over
            dv, dq = vj - v0, q1 - q0
            if abs(vj) < abs(v0):  # slowing down comes first: the turn gets what is left
                dv = s if dv > s else (-s if dv < -s else dv)
                room = s - abs(dv)
                dq = room if dq > room else (-room if dq < -room else dq)
                right, left = dv + dq, dv - dq
            else:
                right, left = dv + dq, dv - dq
                right = s if right > s else (-s if right < -s else right)
                left = s if left > s else (-s if left < -s else left)
            vj = (right + left) * 0.5 + v0
            qj = (right - left) * 0.5 + q0
            wj = qj * (1.0 / hb)
            v[j], w[j], q0s[j] = vj, wj, qj
            moving = moving or vj != 0.0 or wj != 0.0
            z, h = zs[j], hs[j]
            if abs(vj) < abs(wj) * ARC_MAX_RADIUS_M:
                r = vj / wj
                centre = r * (1j * h) + z
                vel = (vj - wj * r) * h
            else:
                r, centre, vel = 0.0, z, vj * h
            write(j, centre.real, centre.imag, ths[j], vel.real, vel.imag, wj, r)
        if changed:
            self.v_cmd_, self.q_cmd_ = np.array(v), np.array(q0s)
        calm = not (self.n_steer_ or self.n_backoff_ or moving)
        self.resting_, self.calm_ = calm and self.calm_, calm
        if self.recorder is not None:
            self.recorder.poses(t, motors.flat[:, :2], thn, self.state_)

    def _arrive_small(self, zs, go, v, w, t: float) -> None:
        """``sim.jobs._arrive``, robot by robot."""
        tol, reach = self.spatial.arrive_tol_m, self.reach_m_
        zone = tol + 2 * reach
        site = self.site_.tolist()
        nearest, arrived, queue = np.inf, [], []
        for j in range(len(zs)):
            if go[j]:
                gap = abs(site[j] - zs[j])
                nearest = gap if gap < nearest else nearest
                if gap <= tol:
                    arrived.append(j)
                elif gap <= zone:
                    queue.append((j, gap))
        if queue:  # touching a robot that stands nearer the site: the site is taken,
            # and working beside the robots already there counts as arrived
            near, state, yielding = (
                self.near_.tolist(),
                self.state_.tolist(),
                self.yielding_.tolist(),
            )
            still = [k for k in range(len(zs)) if state[k] != DRIVING and not yielding[k]]
            for j, gap in queue:
                if near[j] <= reach and any(
                    abs(zs[k] - site[j]) < gap and abs(zs[k] - zs[j]) <= reach for k in still
                ):
                    arrived.append(j)
            arrived.sort()
        self._start_work(arrived, v, w, t)
        speed = SPEED_BOUND * self.controller.v_max_mps
        self.site_check_s_ = t + max(nearest - zone, 0.0) / speed

    def _obstacle_caps_small(self, zs, hs, v, rows) -> None:
        """``PymunkWorld._obstacle_caps`` (``DiffDriveController.wall_cap``), robot by robot."""
        c, to_obstacle = self.controller, self.follower.to_obstacle_one
        two_a, at, at2 = 1.0 / c.inv2a_, c.at_, c.at2_
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
            cap = sqrt(share / tau * two_a + at2) - at
            floor = CREEP_MPS / tau
            cap = floor if cap < floor else cap
            if cap < abs(vj):
                v[j] = cap if vj > 0.0 else -cap

    def _near_small(self, zn, zs, ths, hs, hn, state, v, vprev, w, t: float) -> None:
        """Proximity caps, keep-right and make-way, over the pairs (i, k) with i steering.

        Only a robot that steers (drives, yields or backs off) can be capped, turn right or ask
        another to make way: a standing robot has no speed to cap, so its pairs are not looked
        at (the result is the same as over all pairs). When every steering robot is farther
        than ``look_m`` from every other robot the check sleeps until one could be that close;
        a robot that starts to steer is an event (``_events``), which wakes it.
        """
        c = self.controller
        m = len(zs)
        look = c.look_m
        movers = self.steer_list_  # driving (backing off too) or yielding
        pairs, apart, inf = [], np.inf, np.inf
        for i in movers:
            zi = zs[i]
            dist = [abs(z - zi) for z in zs]
            dist[i] = inf
            if min(dist) < look:
                pairs += [(i, k, d, zs[k] - zi) for k, d in enumerate(dist) if d < look]
            else:
                apart = min(apart, min(dist))
        if not pairs:  # no cap binds before a steering robot could be look_m from another
            self.prox_check_s_ = t + (apart - look) / (2.0 * SPEED_BOUND * c.v_max_mps)
            self.blocker_, self.near_ = self.nobody_
            return
        contact, react, inv2a, at, at2 = c.contact_m, c.react_s, c.inv2a_, c.at_, c.at2_
        two_a, credit = 1.0 / inv2a, 0.5 / c.wheel_decel_
        limit, near, blocker = [np.inf] * m, [np.inf] * m, [-1] * m
        for i, k, d, r in pairs:
            vi = v[i]
            if vi == 0.0:
                continue
            d = d if d > 1e-9 else 1e-9
            cos_i = (r * hs[i].conjugate()).real / d
            toward = -cos_i if vi < 0.0 else cos_i
            if toward <= 0.0:
                continue
            vk = vprev[k]
            back = -(r * hs[k].conjugate()).real / d * vk if vk else 0.0  # k coming closer
            gap = d - contact if d > contact else 0.0
            if back > 0.0:  # k's stopping distance toward i at its committed speed
                their = back * (react + abs(vk) * inv2a)
            else:  # k moves away: the distance it still travels while braking
                their = -back * back * credit
            vi0 = vprev[i]
            mine = cos_i * vi0  # how fast i comes closer to k, and its stopping distance
            mine = mine * (react + abs(vi0) * inv2a) if mine > 0.0 else 0.0
            share = gap - their  # i keeps g - theirs less k's half of the room left over
            half = 0.5 * (share + mine)
            share = half if half < share else share
            share = share if share > 0.0 else 0.0
            cap = sqrt(share / toward * two_a + at2) - at
            floor = CREEP_MPS / toward
            cap = floor if cap < floor else cap
            if cap < limit[i]:
                limit[i] = cap
            if toward > _COS_AHEAD and d < near[i]:
                near[i], blocker[i] = d, k
        for j in movers:
            if limit[j] < abs(v[j]):
                v[j] = limit[j] if v[j] > 0.0 else -limit[j]
        self.blocker_, self.near_ = np.array(blocker), np.array(near)
        closest = min(near)
        if closest < c.keep_right_m:
            turn = KEEP_RIGHT_GAIN * c.omega_max_radps
            for j in movers:
                o = blocker[j]
                if near[j] < c.keep_right_m:
                    if not (state[o] == DRIVING and cos(ths[j] - ths[o]) > 0.5):
                        w[j] -= turn
        reach = self.reach_m_ + YIELD_TRIGGER_M
        if closest < reach:
            yielding = self.yielding_.tolist()
            pushers = [
                j
                for j in movers
                if state[j] == DRIVING
                and near[j] < reach
                and state[blocker[j]] == IDLE
                and not yielding[blocker[j]]
            ]
            if pushers:
                self._make_way(np.array(pushers), self.blocker_, zn, hn, np.array(v), t)
