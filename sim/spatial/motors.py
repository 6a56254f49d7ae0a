"""Robot bodies in a pymunk space, driven through motor joints, with batched pose I/O.

:class:`Motors` puts the robots into a pymunk space. Each robot is a dynamic circle; a kinematic
*control body* per robot is joined to it by a PivotJoint and a GearJoint with ``max_bias = 0`` and
a force limit (pymunk's "tank" pattern): the joints pull the robot's velocity toward the control
body's, as hard as the tyres allow, while contacts push back. For a command (v, omega) held over
one control period the control body sits at the instantaneous centre of rotation, turning at omega,
and the pivot's anchor on it is the robot centre: that anchor moves at v along the robot's heading
at every physics step, so a robot drives exact arcs and never slides sideways unless something
pushes harder than its tyres grip. Poses are read and commands written for all bodies at once
through one ``pymunk.batch`` buffer, viewed as a structured numpy array.
"""

from __future__ import annotations

import numba
import numpy as np
import pymunk
import pymunk.batch as pb
from pymunk._chipmunk_cffi import ffi, lib

from sim.scenario import DriveSpec
from sim.spatial.law.drive import ARC_MAX_RADIUS_M

_IO = pb.BodyFields.POSITION | pb.BodyFields.ANGLE | pb.BodyFields.VELOCITY
_IO |= pb.BodyFields.ANGULAR_VELOCITY  # 6 floats per body: x, y, angle, vx, vy, omega
# the same 6 floats as one record: position and velocity as complex numbers
BODY = np.dtype([("z", np.complex128), ("th", np.float64), ("vel", np.complex128), ("w", float)])


class Motors:
    """Robot bodies and their motor joints in a pymunk space, with batched pose I/O.

    The ``pymunk.batch`` calls go straight through pymunk's cffi library with descriptors built
    once, and the numpy views of the buffer are kept while the buffer stays where it is: a read
    or a write is one pass over the bodies in C and no Python allocation. This uses pymunk's
    cffi handles (``Space._space``, ``Constraint._constraint``, the ``Buffer`` arrays) the way
    ``pymunk.batch`` itself does; written against pymunk 7.3.

    Args:
        space: the space to add the robots to (add nothing else dynamic or kinematic after).
        drive: body and tyre parameters.
        starts: (m, 2) start positions.
        collision_type: pymunk collision type of the robot shapes.
        headings_rad: (m,) start headings from +x (None: every robot faces +x).
        buffer: a ``pymunk.batch.Buffer`` to reuse (pymunk never frees a buffer's C arrays, so
            a world that rebuilds its space hands the same one to each new ``Motors``).
    """

    def __init__(
        self,
        space: pymunk.Space,
        drive: DriveSpec,
        starts: np.ndarray,
        collision_type: int,
        headings_rad: np.ndarray | None = None,
        buffer: pb.Buffer | None = None,
    ) -> None:
        self.space = space
        force_n = drive.mass_kg * drive.traction_mps2
        moment = pymunk.moment_for_circle(drive.mass_kg, 0.0, drive.radius_m)
        self.bodies, self.pivots, controls = [], [], []
        starts = np.asarray(starts, dtype=float)
        angles = np.zeros(len(starts)) if headings_rad is None else np.asarray(headings_rad)
        for xy, angle in zip(starts, angles.tolist(), strict=True):  # robots, then controls
            body = pymunk.Body(drive.mass_kg, moment)
            body.position = tuple(xy)
            if angle:
                body.angle = angle
            shape = pymunk.Circle(body, drive.radius_m)
            shape.friction, shape.elasticity, shape.collision_type = 0.3, 0.0, collision_type
            space.add(body, shape)
            self.bodies.append(body)
        for xy, body in zip(starts, self.bodies, strict=True):
            ctrl = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            ctrl.position = tuple(xy)
            if body.angle:
                ctrl.angle = body.angle
            pivot = pymunk.PivotJoint(ctrl, body, (0.0, 0.0), (0.0, 0.0))
            gear = pymunk.GearJoint(ctrl, body, 0.0, 1.0)
            pivot.max_bias = gear.max_bias = 0.0  # match velocities only: no spring back
            pivot.max_force = force_n
            gear.max_force = force_n * drive.wheel_base_m / 2.0  # torque of the wheel pair
            space.add(ctrl, pivot, gear)
            self.pivots.append(pivot)
            controls.append(ctrl)
        self.buf_ = pb.Buffer() if buffer is None else buffer
        self.buf_.clear()
        pb.get_space_bodies(space, pb.BodyFields.BODY_ID, self.buf_)
        ids = np.frombuffer(self.buf_.int_buf(), dtype=np.uintp).tolist()
        row = {int(i): k for k, i in enumerate(ids)}
        self.rob_ = _rows([row[b.id] for b in self.bodies])
        self.ctl_ = _rows([row[b.id] for b in controls])
        if not (isinstance(self.rob_, slice) and isinstance(self.ctl_, slice)):
            raise RuntimeError("robots and control bodies must be runs of batch buffer rows")
        self.anchor_ = np.zeros(len(self.bodies))
        self.radius_ = np.zeros(len(self.bodies))
        self.changed_ = np.zeros(len(self.bodies), dtype=np.int64)  # pivots to anchor anew
        self.anchor_list_ = [0.0] * len(self.bodies)  # arc radii of the pivots (write_one)
        self.cp_pivots_ = [p._constraint for p in self.pivots]
        self.cp_ctl_ = [c._body for c in controls]
        self.set_pos_, self.set_angle_ = lib.cpBodySetPosition, lib.cpBodySetAngle
        self.set_vel_, self.set_w_ = lib.cpBodySetVelocity, lib.cpBodySetAngularVelocity
        self.set_anchor_ = lib.cpPivotJointSetAnchorA
        self.get_, self.set_ = ffi.new("pmBatchedData *"), ffi.new("pmBatchedData *")
        for d in (self.get_, self.set_):
            d.fields = _IO.value
            d.floatArray, d.intArray = self.buf_._float_arr, self.buf_._int_arr
        self.get_fn_ = ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched")
        self.set_fn_ = ffi.addressof(lib, "pmSpaceBodySetIteratorFuncBatched")
        self.ptr_, self.num_ = None, -1

    def read(self) -> np.ndarray:
        """(m,) :data:`BODY` records (z, th, vel, w) of the robots: a view of the batch buffer,
        valid until the next read. ``flat`` views the same robots as (m, 6) floats."""
        arr = self.buf_._float_arr
        arr.num = 0
        lib.cpSpaceEachBody(self.space._space, self.get_fn_, self.get_)
        if arr.arr != self.ptr_ or arr.num != self.num_:  # the buffer moved: new views
            self.ptr_, self.num_ = arr.arr, arr.num
            raw = np.frombuffer(self.buf_.float_buf(), dtype=BODY)
            flat = raw.view(np.float64).reshape(-1, 6)
            self.rob, self.ctl, self.flat = raw[self.rob_], raw[self.ctl_], flat[self.rob_]
            self.ctl_flat = flat[self.ctl_].reshape(-1)  # x, y, th, vx, vy, w of each in turn
        return self.rob

    def write(self, z, th, h, v_mps, omega_radps) -> None:
        """Command every robot to drive at (v, omega) until the next write.

        On an arc the control body sits at the centre of rotation z + i R h, R = v / omega,
        turns at omega and carries the pivot anchor (0, -R): that anchor is the robot centre.
        Straight (or turning in place) it sits on the robot and moves at v h. Robot rows of the
        buffer (the last :meth:`read`) are written back unchanged.
        """
        radius, changed = self.radius_, self.changed_
        n = control_records(
            z, h, th, v_mps, omega_radps, self.ctl_flat, radius, self.anchor_, changed
        )
        if n:
            pivots, set_anchor = self.cp_pivots_, lib.cpPivotJointSetAnchorA
            for j in changed[:n].tolist():
                set_anchor(pivots[j], (0.0, -radius[j]))
        self.radius_, self.anchor_ = self.anchor_, radius
        arr = self.buf_._float_arr
        num, arr.num = arr.num, 0  # the setter walks the buffer from its start
        lib.cpSpaceEachBody(self.space._space, self.set_fn_, self.set_)
        arr.num = num

    def write_one(
        self, j: int, x: float, y: float, th: float, vx: float, vy: float, w: float, radius: float
    ) -> None:
        """:meth:`write` for robot j alone, its control body's state already computed (the
        scalar path of a small team): position, angle, velocity, turn rate and arc radius.
        A few cffi calls, no buffer: a robot whose command has not changed is not written."""
        body = self.cp_ctl_[j]
        self.set_pos_(body, (x, y))
        self.set_angle_(body, th)
        self.set_vel_(body, (vx, vy))
        self.set_w_(body, w)
        if radius != self.anchor_list_[j]:
            self.set_anchor_(self.cp_pivots_[j], (0.0, -radius))
            self.anchor_list_[j] = radius

    def state_arrays(self) -> dict[str, np.ndarray]:
        """Pose, velocity and turn rate of every robot and control body ((m, 6) floats: x, y,
        angle, vx, vy, omega) and the arc radius each pivot is anchored at, as the array path
        (:meth:`write`) and the scalar path (:meth:`write_one`) keep it (one of the two is
        used in a world and the other stays zero)."""
        self.read()
        return {
            "robots": self.flat.copy(),
            "controls": self.ctl_flat.reshape(-1, 6).copy(),
            "arc_radius_array": self.anchor_.copy(),
            "arc_radius_scalar": np.array(self.anchor_list_, dtype=float),
        }

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Put robots and control bodies where :meth:`state_arrays` found them, at the same
        velocities, with the pivots anchored as they were (into freshly built bodies)."""
        robots, controls = arrays["robots"].tolist(), arrays["controls"].tolist()
        by_array = np.asarray(arrays["arc_radius_array"], dtype=float)
        by_scalar = np.asarray(arrays["arc_radius_scalar"], dtype=float)
        anchor = np.where(by_array != 0.0, by_array, by_scalar).tolist()
        for body, row in zip(self.bodies, robots, strict=True):
            _set_body(body, row)
        for k, (body, row) in enumerate(zip(self.cp_ctl_, controls, strict=True)):
            self.set_pos_(body, (row[0], row[1]))
            self.set_angle_(body, row[2])
            self.set_vel_(body, (row[3], row[4]))
            self.set_w_(body, row[5])
            if anchor[k] != 0.0:
                self.set_anchor_(self.cp_pivots_[k], (0.0, -anchor[k]))
        self.anchor_ = by_array.copy()
        self.radius_ = np.zeros(len(self.bodies))
        self.anchor_list_ = by_scalar.tolist()
        self.ptr_, self.num_ = None, -1


@numba.njit(cache=True)
def control_records(z, h, th, v, w, rec, radius, anchor, changed) -> int:
    """The control bodies' records (x, y, angle, vx, vy, omega of each in turn, into ``rec``)
    for the commands (v, w) of robots at z heading h = exp(i th), as :meth:`Motors.write`
    describes (``sim.spatial.law.drive.control_body``): the arc radius R = v / w where
    ``on_arc``, else 0 (into ``radius``), the body at z + R (i h) moving at (v - w R) h. The
    robots whose R differs from ``anchor`` (their pivots' radii) go to the front of
    ``changed``; returns how many. The arithmetic is numpy's, term by term, with its
    baseline kernels (a complex times a real as (c.re r - c.im 0, c.im r + c.re 0))."""
    n = 0
    for j in range(len(z)):
        vj, wj = v[j], w[j]
        r = vj / wj if abs(vj) < abs(wj) * ARC_MAX_RADIUS_M else 0.0
        radius[j] = r
        hr, hi = h[j].real, h[j].imag
        ir, ii = 0.0 * hr - 1.0 * hi, 0.0 * hi + 1.0 * hr  # 1j * h
        s = vj - wj * r
        k = 6 * j
        rec[k] = (r * ir - 0.0 * ii) + z[j].real
        rec[k + 1] = (r * ii + 0.0 * ir) + z[j].imag
        rec[k + 2] = th[j]
        rec[k + 3] = s * hr - 0.0 * hi
        rec[k + 4] = s * hi + 0.0 * hr
        rec[k + 5] = wj
        if anchor[j] != r:
            changed[n] = j
            n += 1
    return n


def _set_body(body: pymunk.Body, row: list[float]) -> None:
    """A body's position, angle, velocity and turn rate from x, y, angle, vx, vy, omega."""
    body.position = (row[0], row[1])
    body.angle = row[2]
    body.velocity = (row[3], row[4])
    body.angular_velocity = row[5]


def _rows(rows: list[int]) -> slice | np.ndarray:
    """Rows of a batch buffer as a slice when contiguous (a view), else an index array."""
    if rows and rows == list(range(rows[0], rows[0] + len(rows))):
        return slice(rows[0], rows[0] + len(rows))
    return np.array(rows, dtype=np.intp)
