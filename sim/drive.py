"""Differential drive: pymunk motors and wheel-limited path following for arrays of robots.

A differential-drive robot turns its wheels at rim speeds u_r, u_l (m/s); its body moves at
v = (u_r + u_l) / 2 along its heading and turns at omega = (u_r - u_l) / b, never sideways. The
controller aims each robot at the current waypoint of its path, slows down for corners, for the
final goal and for the robot in front, and returns the (v, omega) command after the wheel-speed
limit (both wheels scaled, so the curvature is kept) and the wheel-acceleration limit.

Everything is numpy over the robot axis. Points and headings are complex numbers (x + iy and
e^{i theta}): one complex multiply rotates a vector into a robot's frame, which keeps the hot loop
short.

:class:`Motors` puts the robots into a pymunk space. Each robot is a dynamic circle; a kinematic
*control body* per robot is joined to it by a PivotJoint and a GearJoint with ``max_bias = 0`` and
a force limit (pymunk's "tank" pattern): the joints pull the robot's velocity toward the control
body's, as hard as the tyres allow, while contacts push back. For a command (v, omega) held over
one control period the control body sits at the instantaneous centre of rotation, turning at omega,
and the pivot's anchor on it is the robot centre: that anchor moves at v along the robot's heading
at every physics step, so a robot drives exact arcs and never slides sideways unless something
pushes harder than its tyres grip.
"""

from __future__ import annotations

import numpy as np
import pymunk
import pymunk.batch as pb
from scipy.spatial import cKDTree

from sim.scenario import DriveSpec

HEADING_GAIN = 2.5  # 1/s: omega command per radian of heading error
TURN_IN_PLACE_RAD = np.pi / 3  # beyond this heading error the robot stops and turns
WAYPOINT_SWITCH_M = 0.2  # aim at the next waypoint once this close to the current one
CREEP_MPS = 0.15  # closing speed still allowed on contact: robots may nudge, never ram
KEEP_RIGHT_M = 0.6  # gap below which a robot turns right around a robot not going its way
KEEP_RIGHT_GAIN = 0.25  # that turn, as a share of the top turn rate
PROXIMITY_DECEL = 0.35  # share of the braking power planned for: the robot ahead may close in too
DENSE_MAX = 64  # up to this many robots the neighbour search is one (m, m) array
NEIGHBOURS = 8  # beyond DENSE_MAX: the nearest robots a KD-tree returns per robot
AHEAD_DEG = 70.0  # a robot within this angle of the direction of travel is in the way
_COS_TURN = float(np.cos(TURN_IN_PLACE_RAD))
_COS_AHEAD = float(np.cos(np.radians(AHEAD_DEG)))
_WHEEL_SIGN = np.array([[1.0], [-1.0]])  # right, left wheel: u = v +- omega b / 2
ARC_MAX_RADIUS_M = 1e4  # flatter arcs are driven as straight lines
_IO = pb.BodyFields.POSITION | pb.BodyFields.ANGLE | pb.BodyFields.VELOCITY
_IO |= pb.BodyFields.ANGULAR_VELOCITY  # 6 floats per body: x, y, angle, vx, vy, omega


class Motors:
    """Robot bodies and their motor joints in a pymunk space, with batched pose I/O.

    Args:
        space: the space to add the robots to (add nothing else dynamic or kinematic after).
        drive: body and tyre parameters.
        starts: (m, 2) start positions; every robot starts facing +x.
        collision_type: pymunk collision type of the robot shapes.
    """

    def __init__(
        self, space: pymunk.Space, drive: DriveSpec, starts: np.ndarray, collision_type: int
    ) -> None:
        self.space = space
        force_n = drive.mass_kg * drive.traction_mps2
        moment = pymunk.moment_for_circle(drive.mass_kg, 0.0, drive.radius_m)
        self.bodies, self.pivots, controls = [], [], []
        for xy in np.asarray(starts, dtype=float):
            body = pymunk.Body(drive.mass_kg, moment)
            body.position = tuple(xy)
            shape = pymunk.Circle(body, drive.radius_m)
            shape.friction, shape.elasticity, shape.collision_type = 0.3, 0.0, collision_type
            ctrl = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            ctrl.position = tuple(xy)
            pivot = pymunk.PivotJoint(ctrl, body, (0.0, 0.0), (0.0, 0.0))
            gear = pymunk.GearJoint(ctrl, body, 0.0, 1.0)
            pivot.max_bias = gear.max_bias = 0.0  # match velocities only: no spring back
            pivot.max_force = force_n
            gear.max_force = force_n * drive.wheel_base_m / 2.0  # torque of the wheel pair
            space.add(body, shape, ctrl, pivot, gear)
            self.bodies.append(body)
            self.pivots.append(pivot)
            controls.append(ctrl)
        self.buf_ = pb.Buffer()
        pb.get_space_bodies(space, pb.BodyFields.BODY_ID, self.buf_)
        ids = np.frombuffer(self.buf_.int_buf(), dtype=np.uintp).tolist()
        row = {int(i): k for k, i in enumerate(ids)}
        self.rob_ = _rows([row[b.id] for b in self.bodies])
        self.ctl_ = _rows([row[b.id] for b in controls])
        self.anchor_ = np.zeros(len(self.bodies))

    def read(self) -> np.ndarray:
        """(bodies, 6) x, y, angle, vx, vy, omega of every body in the space: a writable view
        of the batch buffer, valid until the next read. Robot rows: ``self.rob_``."""
        self.buf_.clear()
        pb.get_space_bodies(self.space, _IO, self.buf_)
        return np.frombuffer(self.buf_.float_buf()).reshape(-1, 6)

    def write(self, raw, z, th, h, v_mps, omega_radps) -> None:
        """Command every robot to drive at (v, omega) until the next write.

        On an arc the control body sits at the centre of rotation z + i R h, R = v / omega,
        turns at omega and carries the pivot anchor (0, -R): that anchor is the robot centre.
        Straight (or turning in place) it sits on the robot and moves at v h. Robot rows of
        ``raw`` (the last :meth:`read`) are written back unchanged.
        """
        v, w = v_mps, omega_radps
        arc = np.abs(v) < ARC_MAX_RADIUS_M * np.abs(w)
        radius = np.divide(v, w, out=np.zeros_like(v), where=arc)
        centre = z + 1j * radius * h
        vel = (v * ~arc) * h
        ctl = raw[self.ctl_]  # a view when the control bodies are contiguous rows
        ctl[:, 0], ctl[:, 1], ctl[:, 2] = centre.real, centre.imag, th
        ctl[:, 3], ctl[:, 4], ctl[:, 5] = vel.real, vel.imag, w
        if not isinstance(self.ctl_, slice):
            raw[self.ctl_] = ctl
        for j in (self.anchor_ != radius).nonzero()[0].tolist():
            self.pivots[j].anchor_a = (0.0, -float(radius[j]))
        self.anchor_ = radius
        pb.set_space_bodies(self.space, _IO, self.buf_)


def _rows(rows: list[int]) -> slice | np.ndarray:
    """Rows of a batch buffer as a slice when contiguous (a view), else an index array."""
    if rows and rows == list(range(rows[0], rows[0] + len(rows))):
        return slice(rows[0], rows[0] + len(rows))
    return np.array(rows, dtype=np.intp)


class DiffDriveController:
    """Turns targets into wheel-limited (v, omega) commands, one entry per robot.

    Args:
        drive: the robot body and wheel limits.
        control_dt_s: the control period; the wheel-acceleration limit is applied per period.
    """

    def __init__(self, drive: DriveSpec, control_dt_s: float) -> None:
        self.drive = drive
        self.half_base_m = drive.wheel_base_m / 2.0
        self.rim_max_mps = drive.max_wheel_speed_radps * drive.wheel_radius_m
        self.rim_step_mps = drive.max_wheel_accel_radps2 * drive.wheel_radius_m * control_dt_s
        self.v_max_mps = self.rim_max_mps
        self.omega_max_radps = self.rim_max_mps / self.half_base_m
        self.brake_mps2 = 0.5 * drive.max_wheel_accel_radps2 * drive.wheel_radius_m
        self.contact_m = 2.0 * drive.radius_m
        self.yield_mps2 = PROXIMITY_DECEL * drive.max_wheel_accel_radps2 * drive.wheel_radius_m
        self.look_m = self.contact_m + self.v_max_mps**2 / (2.0 * self.yield_mps2)
        self.keep_right_m = self.contact_m + KEEP_RIGHT_M
        self.rows_ = np.zeros(0, dtype=int)

    def steer(
        self, z: np.ndarray, h: np.ndarray, target: np.ndarray, corner_mps: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Desired (v, omega) that take each robot toward its target, before the limits.

        Args:
            z: (m,) positions x + iy, m.
            h: (m,) unit headings e^{i theta}.
            target: (m,) current waypoints x + iy.
            corner_mps: (m,) speed allowed when passing the waypoint (0 at the goal).
        """
        delta = target - z
        local = delta * h.conj()
        err = np.arctan2(local.imag, local.real)
        align = np.minimum(np.maximum((np.cos(err) - _COS_TURN) / (1.0 - _COS_TURN), 0.0), 1.0)
        stop = np.sqrt(corner_mps * corner_mps + 2.0 * self.brake_mps2 * np.abs(delta))
        return np.minimum(self.v_max_mps * align, stop), HEADING_GAIN * err

    def proximity(
        self, z: np.ndarray, h: np.ndarray, v_mps: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cap each robot's speed so that it can stop before touching any other robot.

        The part of the robot's velocity that points at a neighbour is capped by the gap to it
        (a braking profile that ends at ``CREEP_MPS`` on contact); moving sideways or away is
        free, so robots slide past each other but never ram: pymunk finds contacts only once
        shapes overlap, so the closing speed at contact sets the overlap. The nearest robot within
        ``AHEAD_DEG`` of the direction of travel is reported as the one in the way.

        Args:
            z: (m,) positions x + iy; h: (m,) unit headings; v_mps: (m,) speed commands.

        Returns:
            (m,) capped speeds, (m,) index of the nearest robot ahead (-1: none) and (m,) its
            centre distance (inf: none).
        """
        m = len(v_mps)
        if m < 2:
            return v_mps, np.full(m, -1), np.full(m, np.inf)
        travel = h * np.sign(v_mps)
        if m <= DENSE_MAX:
            rel = (z[None, :] - z[:, None]) * travel.conj()[:, None]
            ok, cols = True, None
        else:
            xy = np.column_stack([z.real, z.imag])
            k = min(m, NEIGHBOURS + 1)
            _, idx = cKDTree(xy).query(xy, k=k, distance_upper_bound=self.look_m)
            ok = idx[:, 1:] < m  # column 0 is the robot itself; misses are reported as m
            cols = np.minimum(idx[:, 1:], m - 1)
            rel = (z[cols] - z[:, None]) * travel.conj()[:, None]
        dist = np.abs(rel)
        toward = np.where(ok, rel.real, 0.0) / np.maximum(dist, 1e-9)  # cos of the bearing
        gap = np.maximum(dist - self.contact_m, 0.0)
        cap = np.sqrt(2.0 * self.yield_mps2 * gap) + CREEP_MPS
        limit = np.where(toward > 0.0, cap / np.maximum(toward, 1e-9), np.inf).min(axis=1)
        ahead = np.where(toward > _COS_AHEAD, dist, np.inf)
        rows = self._rows(m)
        k = ahead.argmin(axis=1)
        near = ahead[rows, k]
        if cols is not None:
            k = cols[rows, k]
        blocker = np.where(near < np.inf, k, -1)
        return np.maximum(np.minimum(v_mps, limit), -limit), blocker, near

    def keep_right(
        self, h: np.ndarray, w_radps: np.ndarray, blocker: np.ndarray, near: np.ndarray, moving
    ) -> np.ndarray:
        """Turn right when the robot in the way is not going our way (oncoming or standing).

        Both robots of a head-on pair turn right and pass each other; a robot stopped in front of
        a working one drives around it.

        Args:
            h: (m,) unit headings; w_radps: (m,) turn commands; blocker, near: from
                :meth:`proximity`; moving: (m,) bool, robots that drive on their own.
        """
        other = np.maximum(blocker, 0)
        same_way = moving[other] & ((h * h[other].conj()).real > 0.5)
        veer = (blocker >= 0) & (near < self.keep_right_m) & ~same_way
        return w_radps - veer * (KEEP_RIGHT_GAIN * self.omega_max_radps)

    def _rows(self, m: int) -> np.ndarray:
        if len(self.rows_) != m:
            self.rows_ = np.arange(m)
        return self.rows_

    def limit(
        self, v_mps: np.ndarray, omega_radps: np.ndarray, rims: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Apply the wheel-speed and wheel-acceleration limits to desired twists.

        Args:
            v_mps: (m,) desired forward speed.
            omega_radps: (m,) desired turn rate.
            rims: (2, m) rim speeds (right, left) commanded in the last period, m/s.

        Returns:
            (v, omega, rims) actually commanded.
        """
        want = v_mps + _WHEEL_SIGN * (omega_radps * self.half_base_m)
        want /= np.maximum(np.abs(want).max(axis=0) / self.rim_max_mps, 1.0)
        step = self.rim_step_mps
        new = rims + np.minimum(np.maximum(want - rims, -step), step)
        right, left = new
        return 0.5 * (right + left), (right - left) / (2.0 * self.half_base_m), new


class PathFollower:
    """Waypoint lists of m robots in padded arrays, with the vectorised bookkeeping around them.

    Args:
        m: number of robots.
        v_max_mps: top speed, used for the corner speeds.
    """

    def __init__(self, m: int, v_max_mps: float) -> None:
        self.v_max_mps = v_max_mps
        self.rows_ = np.arange(m)
        self.points = np.zeros((m, 2), dtype=complex)  # (m, P) waypoints, padded with the last
        self.last = np.full(m, -1)  # index of the final waypoint (-1: no path)
        self.index = np.zeros(m, dtype=int)  # waypoint currently aimed at
        self.after_m = np.zeros((m, 2))  # path length left after each waypoint
        self.corner_mps = np.zeros((m, 2))  # speed allowed at each waypoint

    def set_path(self, j: int, path: np.ndarray) -> None:
        """Give robot j a path (P, 2) whose first point is where it is now."""
        n = len(path)
        if n > self.points.shape[1]:
            grow = ((0, 0), (0, n - self.points.shape[1]))
            self.points = np.pad(self.points, grow, mode="edge")
            self.after_m = np.pad(self.after_m, grow)
            self.corner_mps = np.pad(self.corner_mps, grow)
        pts = path[:, 0] + 1j * path[:, 1]
        seg = np.diff(pts)
        after = np.concatenate([np.cumsum(np.abs(seg)[::-1])[::-1], [0.0]])
        turn = seg[1:] * seg[:-1].conj()
        cos_turn = turn.real / np.maximum(np.abs(turn), 1e-12)
        corner = np.zeros(n)
        corner[1:-1] = self.v_max_mps * np.clip(cos_turn, 0.0, 1.0) ** 2
        self.points[j, :n], self.points[j, n:] = pts, pts[-1]
        self.after_m[j, :n], self.after_m[j, n:] = after, 0.0
        self.corner_mps[j, :n], self.corner_mps[j, n:] = corner, 0.0
        self.last[j] = n - 1
        self.index[j] = min(1, n - 1)

    def clear(self, j: int) -> None:
        self.last[j] = -1
        self.index[j] = 0

    def targets(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance past reached waypoints; (target, corner speed, path left) for every robot.

        Args:
            z: (m,) positions x + iy. Rows of robots without a path hold stale values.
        """
        idx = self.index
        tgt = self.points[self.rows_, idx]
        inward = tgt - self.points[self.rows_, idx - 1]
        passed = ((z - tgt) * inward.conj()).real > 0.0  # beyond the waypoint's normal line
        close = ((np.abs(tgt - z) < WAYPOINT_SWITCH_M) | passed) & (idx < self.last)
        if np.count_nonzero(close):
            idx = self.index = idx + close
            tgt = self.points[self.rows_, idx]
        left = np.abs(tgt - z) + self.after_m[self.rows_, idx]
        return tgt, self.corner_mps[self.rows_, idx], left
