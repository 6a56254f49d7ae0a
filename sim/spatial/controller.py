"""Differential drive: the wheel-limited controller, for arrays of robots.

A differential-drive robot turns its wheels at rim speeds u_r, u_l (m/s); its body moves at
v = (u_r + u_l) / 2 along its heading and turns at omega = (u_r - u_l) / b, never sideways. The
controller aims each robot at a point on its path (``sim.spatial.navigation.paths.PathFollower``),
slows down for corners, for the final goal, for the robots around it and for obstacles it has been
pushed close to, and returns the (v, omega) command after the wheel-speed limit (both wheels scaled,
so the curvature is kept) and the wheel-acceleration limit (braking first: a robot that must slow
down gets its full deceleration and turns with what the wheels have left).

Everything is numpy over the robot axis, with as few array operations per control period as the
law allows: for small teams the per-call overhead of numpy, not the arithmetic, is the cost.
Points and headings are complex numbers (x + iy and e^{i theta}): one complex multiply rotates a
vector into a robot's frame. Wheel state is kept as (v, q = omega b / 2): rim speeds v +- q.
The robots' bodies and motors are :class:`sim.spatial.motors.Motors`.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from sim.scenario import DriveSpec, LawSpec
from sim.spatial.law.drive import (
    approach_cap_mps,
    goes_our_way,
    pair_share_m,
    rim_speed_mps,
    steer_speeds,
    stopping_time_s,
    twist_from_rims,
)

DENSE_MAX = 64  # up to this many robots the neighbour search is one (m, m) array
VERLET_SKIN_M = 1.0  # beyond DENSE_MAX: the neighbour list holds pairs this much beyond look_m


class DiffDriveController:
    """Turns targets into wheel-limited (v, omega) commands, one entry per robot.

    Args:
        drive: the robot body and wheel limits.
        control_dt_s: the control period; the wheel-acceleration limit is applied per period.
        dense_max: up to this many robots, pairs of neighbours come from one (m, m) distance
            array; beyond, from a Verlet list (:meth:`neighbour_pairs`).
        law: the steering and proximity law's settings (``[spatial.law]``).

    Attributes (the law's settings, as the control periods read them):
        heading_gain: turn rate commanded per radian of heading error, 1/s.
        cos_turn, cos_ahead: cosines of the turn-in-place angle and of the angle within which a
            robot is in the way.
        creep_mps, speed_bound, same_way_cos, keep_right_gain, turn_first_radps: as
            :class:`sim.scenario.LawSpec` says.
    """

    def __init__(
        self,
        drive: DriveSpec,
        control_dt_s: float,
        dense_max: int = DENSE_MAX,
        law: LawSpec | None = None,
    ) -> None:
        law = LawSpec() if law is None else law
        self.drive, self.law = drive, law
        self.dense_max = dense_max
        self.heading_gain = law.heading_gain
        self.cos_turn = math.cos(law.turn_in_place_rad)
        self.cos_ahead = math.cos(math.radians(law.ahead_deg))
        self.creep_mps, self.speed_bound = law.creep_mps, law.speed_bound
        self.same_way_cos, self.keep_right_gain = law.same_way_cos, law.keep_right_gain
        self.turn_first_radps = law.turn_first_radps
        self.half_base_m = drive.wheel_base_m / 2.0
        self.rim_max_mps = drive.max_wheel_speed_radps * drive.wheel_radius_m
        self.rim_step_mps = drive.max_wheel_accel_radps2 * drive.wheel_radius_m * control_dt_s
        self.v_max_mps = self.rim_max_mps
        self.omega_max_radps = self.rim_max_mps / self.half_base_m
        self.brake_mps2 = 0.5 * drive.max_wheel_accel_radps2 * drive.wheel_radius_m
        self.radius_m = drive.radius_m
        self.contact_m = 2.0 * drive.radius_m
        a = self.yield_mps2 = (
            law.proximity_decel * drive.max_wheel_accel_radps2 * drive.wheel_radius_m
        )
        t = self.react_s = law.react_periods * control_dt_s
        stop_m = self.v_max_mps * t + self.v_max_mps**2 / (2.0 * a)
        self.look_m = self.contact_m + 2.0 * stop_m  # farther apart, no speed cap can bind
        self.keep_right_m = self.contact_m + law.keep_right_m
        # v = v_max * clip((cos(err) - cos_turn) / (1 - cos_turn), 0, 1) as one affine map
        self.align_gain_ = self.v_max_mps / (1.0 - self.cos_turn)
        self.align_bias_ = -self.cos_turn * self.align_gain_
        self.at_, self.at2_, self.inv2a_ = a * t, (a * t) ** 2, 0.5 / a
        self.two_a_ = 1.0 / self.inv2a_
        self.wheel_decel_ = drive.max_wheel_accel_radps2 * drive.wheel_radius_m
        self.diag_ = np.zeros((0, 0))
        self.verlet_z_ = np.zeros(0, dtype=complex)  # positions when the Verlet list was built
        self.verlet_ = (np.zeros(0, dtype=int), np.zeros(0, dtype=int))

    def steer(
        self, hc: np.ndarray, delta: np.ndarray, gap_m: np.ndarray, corner2: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Desired (v, omega) that take each robot toward its target, before the limits.

        Args:
            hc: (m,) conjugate unit headings e^{-i theta}.
            delta: (m,) aim point minus position (x + iy), m.
            gap_m: (m,) distance to the waypoint, m (the robot brakes to reach it at the corner
                speed).
            corner2: (m,) squared speed allowed when passing the waypoint (0 at the goal).
        """
        local = delta * hc
        err = np.arctan2(local.imag, local.real)
        gain, bias, brake2 = self.align_gain_, self.align_bias_, 2.0 * self.brake_mps2
        v, stop = steer_speeds(np.cos(err), gap_m, corner2, gain, bias, brake2, np.sqrt)
        np.maximum(v, 0.0, out=v)
        np.minimum(v, stop, out=v)
        err *= self.heading_gain
        return v, err

    def _cap(self, share: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Top speed that covers at most ``share`` toward an obstacle at bearing cosine ``tau``
        (> 0) when held for the reaction time and then braked at ``yield_mps2``; at least the
        creep speed toward it (:func:`sim.spatial.law.drive.approach_cap_mps`)."""
        cap, creep = approach_cap_mps(
            share, tau, self.two_a_, self.at_, self.at2_, np.sqrt, self.creep_mps
        )
        return np.maximum(cap, creep, out=cap)

    def proximity(
        self, z: np.ndarray, hc: np.ndarray, v_mps: np.ndarray, v_prev_mps: np.ndarray
    ) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None, float]:
        """Cap each robot's speed so that it and the robots around it can stop before touching.

        Driving at v for one control period T and then braking at ``yield_mps2`` = a covers
        tau (v T + v^2 / 2a) toward a neighbour at bearing cosine tau > 0, so keeping that within
        a share s of the gap g means v <= a (sqrt(T^2 + 2 s / (a tau)) - T). The shares of a
        pair never add up to more than g, so both can always stop in time: with each robot's
        need (that distance at the speed it committed to last period, toward the other; a
        neighbour moving away brakes at the wheels' limit and so adds the distance it still
        travels), a robot gets g less the neighbour's need less the neighbour's half of the room
        that is left, min(g - theirs, (g - theirs + mine) / 2), at least 0. A robot that is
        already committed to most of the gap keeps it, and one standing beside it (or turning
        onto it) may not drive into it. On contact ``creep_mps`` of closing speed is left: robots
        may nudge, never ram (pymunk finds contacts once shapes overlap, so the closing speed at
        contact sets the overlap). Moving sideways or away is free. The nearest robot within
        ``ahead_deg`` of the direction of travel is reported as the one in the way.

        The rule is applied to every pair closer than ``look_m`` = contact + 2 x the stopping
        distance from top speed: farther apart, both can stop from top speed within their half of
        the gap, so no cap is needed. Up to ``dense_max`` robots the pairs come from one (m, m)
        distance array, beyond from a Verlet list (:meth:`neighbour_pairs`); then the formulas run
        over the pairs (i, k) in which i moves toward k, so a crowd costs what its close pairs
        cost, not m x m.

        Args:
            z: (m,) positions x + iy; hc: (m,) conjugate unit headings; v_mps: (m,) speed
                commands; v_prev_mps: (m,) speeds commanded in the last period.

        Returns:
            (m,) capped speeds, (m,) index of the nearest robot ahead (-1: none), (m,) its
            centre distance (inf: none) and the least distance between two robots (0 when not
            known: beyond ``dense_max`` robots). When no two robots are closer than ``look_m``
            the three arrays are None and that distance is at least ``look_m``.
        """
        m = len(v_mps)
        if m < 2:
            return None, None, None, np.inf
        look = self.look_m
        if m <= self.dense_max:
            dist = np.abs(z - z[:, None])
            dist += self.diag_inf(m)  # a robot is infinitely far from itself
            apart = float(dist.min())
            if apart >= look:
                return None, None, None, apart
            i, k = (dist < look).nonzero()
        else:  # a superset of the pairs closer than look_m (Verlet list), moving robot first
            i, k = self.neighbour_pairs(z)
            if not len(i):
                return None, None, None, look  # all at least look_m apart
            moving = (v_mps[i] != 0.0).nonzero()[0]
            i, k = i[moving], k[moving]
            apart = 0.0
        # (i, k): i could be capped because of k. Only i moving toward k (bearing cosine
        # tau > 0 in its direction of travel) closer than look_m can be: the others never bind
        rel = z[k] - z[i]
        dist = np.abs(rel)
        np.maximum(dist, 1e-9, out=dist)
        cos = (rel * hc[i]).real
        cos /= dist  # bearing cosine of k from i's heading
        toward = cos * np.sign(v_mps)[i]
        sel = (toward > 0.0) & (dist < look)
        sel = sel.nonzero()[0]
        i, k, rel, dist, cos, toward = i[sel], k[sel], rel[sel], dist[sel], cos[sel], toward[sel]
        mine = cos * v_prev_mps[i]  # how fast i comes closer to k
        back = (rel * hc[k]).real
        back /= dist
        back *= -v_prev_mps[k]  # ... and k to i
        gap = dist - self.contact_m
        np.maximum(gap, 0.0, out=gap)
        away = np.minimum(back, 0.0)  # k moves away: it would brake over away^2 / 2 a_wheel
        np.maximum(back, 0.0, out=back)
        # stopping distances toward each other at the committed speeds (one period, then a)
        stop = stopping_time_s(v_prev_mps, self.react_s, self.inv2a_)  # per m/s, per robot
        their = back * stop[k]
        their -= away * away * (0.5 / self.wheel_decel_)
        np.maximum(mine, 0.0, out=mine)
        mine *= stop[i]
        # i keeps the gap less k's stopping distance less k's half of the room left over:
        # min(g - their, (g - their + mine) / 2), never below 0
        share, half = pair_share_m(gap, their, mine)
        np.minimum(share, half, out=share)
        np.maximum(share, 0.0, out=share)
        limit = np.full(m, np.inf)
        np.minimum.at(limit, i, self._cap(share, np.maximum(toward, 1e-9)))
        # the robot in the way: the nearest ahead, the lowest index among equally near ones
        ahead = (toward > self.cos_ahead).nonzero()[0]
        near = np.full(m, np.inf)
        np.minimum.at(near, i[ahead], dist[ahead])
        first = ahead[dist[ahead] == near[i[ahead]]]
        blocker = np.full(m, m)
        np.minimum.at(blocker, i[first], k[first])
        blocker[blocker == m] = -1
        return np.maximum(np.minimum(v_mps, limit), -limit), blocker, near, apart

    def wall_cap(self, hc: np.ndarray, v_mps: np.ndarray, to_wall: np.ndarray) -> np.ndarray:
        """Speed caps (like :meth:`proximity`, obstacles standing still) for robots whose
        nearest obstacle point is ``to_wall`` away (x + iy, from the robot centre)."""
        dist = np.abs(to_wall)
        tau = (to_wall * hc).real / np.maximum(dist, 1e-12) * np.sign(v_mps)
        tau = np.maximum(tau, 1e-9)
        cap = self._cap(np.maximum(dist - self.radius_m, 0.0), tau)
        return np.maximum(np.minimum(v_mps, cap), -cap)

    def keep_right(
        self, th: np.ndarray, w_radps: np.ndarray, blocker: np.ndarray, near: np.ndarray, moving
    ) -> np.ndarray:
        """Turn right when the robot in the way is not going our way (oncoming or standing).

        Both robots of a head-on pair turn right and pass each other; a robot stopped in front of
        a working one drives around it.

        Args:
            th: (m,) headings; w_radps: (m,) turn commands; blocker, near: from
                :meth:`proximity`; moving: (m,) bool, robots that drive on their own.
        """
        other = np.maximum(blocker, 0)
        same_way = goes_our_way(th, th[other], np.cos, self.same_way_cos)
        same_way &= moving[other]
        veer = near < self.keep_right_m  # near is finite only where there is a blocker
        veer &= ~same_way
        return w_radps - veer * (self.keep_right_gain * self.omega_max_radps)

    def neighbour_pairs(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every pair of robots (i, k), both ways round, that could be closer than ``look_m``:
        a Verlet list of the pairs within ``look_m + VERLET_SKIN_M`` (``cKDTree.query_pairs``),
        rebuilt once a robot has moved more than half the skin since it was built (until then
        two robots closer than ``look_m`` now were closer than ``look_m + VERLET_SKIN_M``)."""
        z0 = self.verlet_z_
        if len(z0) != len(z) or float(np.abs(z - z0).max()) >= 0.5 * VERLET_SKIN_M:
            xy = np.column_stack([z.real, z.imag])
            tree = cKDTree(xy, balanced_tree=False, compact_nodes=False)
            pairs = tree.query_pairs(self.look_m + VERLET_SKIN_M, output_type="ndarray")
            self.verlet_z_ = z.copy()
            self.verlet_ = (
                np.concatenate([pairs[:, 0], pairs[:, 1]]),
                np.concatenate([pairs[:, 1], pairs[:, 0]]),
            )
        return self.verlet_

    def forget_neighbours(self) -> None:
        """Drop the Verlet list (a rebuilt space: the next call builds it afresh)."""
        self.verlet_z_ = np.zeros(0, dtype=complex)
        self.verlet_ = (np.zeros(0, dtype=int), np.zeros(0, dtype=int))

    def diag_inf(self, m: int) -> np.ndarray:
        """(m, m) zeros with inf on the diagonal (cached)."""
        if len(self.diag_) != m:
            self.diag_ = np.diag(np.full(m, np.inf))
        return self.diag_

    def limit(
        self,
        v_mps: np.ndarray,
        omega_radps: np.ndarray,
        v0: np.ndarray,
        q0: np.ndarray,
        turn_first: bool = False,
        orca: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Apply the wheel-speed and wheel-acceleration limits to desired twists.

        Each wheel's rim speed v +- q (q = omega b / 2) may change by ``rim_step_mps`` per
        period. A robot that must slow down (|v| falls) takes its full deceleration first and
        turns with what is left. With ``turn_first`` (the law under collision avoidance), one
        turning faster than ``turn_first_radps`` whose turn must slow (|q| falls or changes
        sign) slows the turn first and changes speed with what is left, unless ORCA set its
        command (its guarantee needs that velocity); else speeding up would keep the turn going
        and carry the robot past its heading, off its path and into walls. Otherwise each wheel
        goes as far toward its target as it may.

        Args:
            v_mps: (m,) desired forward speed.
            omega_radps: (m,) desired turn rate.
            v0, q0: (m,) v and q commanded in the last period, m/s.
            turn_first: slow a fast turn first (above).
            orca: indices of the robots whose command collision avoidance set
                (``sim.spatial.law.orca``): no turn first for them, their wheels follow the velocity
                ORCA chose.

        Returns:
            (v, omega, q) actually commanded.
        """
        s = self.rim_step_mps
        q1 = omega_radps * self.half_base_m
        over = rim_speed_mps(v_mps, q1)
        over *= 1.0 / self.rim_max_mps
        np.maximum(over, 1.0, out=over)  # the faster wheel at most at top speed
        dv = v_mps / over
        brake = np.abs(dv) < np.abs(v0)
        dv -= v0
        dq = q1 / over
        dq -= q0
        right = np.minimum(np.maximum(dv + dq, -s), s)  # each wheel on its own
        left = np.minimum(np.maximum(dv - dq, -s), s)
        if turn_first:
            q_target = q1 / over
            turn = np.abs(q0) > self.turn_first_radps * self.half_base_m
            turn &= (np.abs(q_target) < np.abs(q0)) | (q_target * q0 < 0.0)
            turn &= ~brake
            if orca is not None:
                turn[orca] = False
            if np.count_nonzero(turn):  # a fast turn that must slow comes next
                dq_t = np.minimum(np.maximum(dq, -s), s)
                room = s - np.abs(dq_t)
                dv_t = np.minimum(np.maximum(dv, -room), room)
                np.copyto(right, dv_t + dq_t, where=turn)
                np.copyto(left, dv_t - dq_t, where=turn)
        if np.count_nonzero(brake):  # slowing down comes first: the turn gets what is left
            np.minimum(np.maximum(dv, -s, out=dv), s, out=dv)
            room = s - np.abs(dv)
            np.minimum(np.maximum(dq, -room, out=dq), room, out=dq)
            np.copyto(right, dv + dq, where=brake)
            np.copyto(left, dv - dq, where=brake)
        v, q = twist_from_rims(right, left, v0, q0)
        return v, q * (1.0 / self.half_base_m), q
