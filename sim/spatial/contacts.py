"""Stepping the pymunk space: contact counts, solver iterations that follow them, true overlap.

:class:`ContactMonitor` registers begin/separate callbacks for robot-robot and robot-wall contacts
and keeps ``touching``, the number of contacts touching now, and the contacts begun since reset.
Each contact begun is a *touch* when the shapes approach along the contact normal slower than
``impact_mps`` (``[spatial.contacts]``, 0.3 m/s by default: two robots creeping at the proximity
law's
0.15 m/s each), else an *impact*.

Solver iterations follow the contacts. While nothing touches, each robot is joined only to its own
kinematic control body, whose mass is infinite, so the solver's constraints are independent of
each other and one iteration solves each exactly: the result is the same, bit for bit, as with
ten (``tests/behaviour/test_physics.py`` checks this). The moment a contact begins, in the begin
callback, which pymunk calls during collision detection and so before that step's solver runs,
the space switches to ``iterations``; when the last contact separates (again before the
solver) it goes back to one.

Overlap: pymunk reports a contact once shapes overlap, and a contact's depth after ``step`` is
the penetration at the positions the step leaves (positions are integrated before collision
detection; the solver then changes only velocities). So after every physics step in which a
contact touches, :meth:`ContactMonitor.run` reads the depth of every contact with one batched
call (``pymunk.batch`` arbiter field ``DISTANCE_1``: every contact here involves a circle and has
one point; cached contacts that no longer touch report 0) and keeps the deepest:
``max_overlap_m`` is the worst robot-robot or robot-wall penetration over every physics step of
the run. Steps without a touching contact have no overlap and cost nothing extra.

The world adds and removes nothing while it steps, so :meth:`ContactMonitor.run` calls
chipmunk's step directly (``Space.step`` wraps it in bookkeeping for objects added or removed in
callbacks) and the batched reads through pymunk's cffi library with descriptors built once.
"""

from __future__ import annotations

import numpy as np
import pymunk
import pymunk.batch as pb
from pymunk._chipmunk_cffi import ffi, lib

from sim.scenario import ContactSpec


def closing_speed_mps(arbiter: pymunk.Arbiter) -> float:
    """How fast the two shapes of a contact approach along its normal as it begins, m/s (a
    wall's static body stands still)."""
    a, b = arbiter.shapes
    rel = a.body.velocity - b.body.velocity
    return abs(rel.dot(arbiter.normal))


class ContactMonitor:
    """Counts contacts, sets the solver iterations and measures the deepest overlap.

    Args:
        space: the space; nothing may be added or removed while :meth:`run` steps it.
        robot, wall: collision types of robot shapes and of walls and obstacles.
        buffer: the batch buffer to read contact depths into (reused: pymunk never frees one).
        spec: the solver iterations and what counts as an impact (``[spatial.contacts]``).
    """

    def __init__(
        self,
        space: pymunk.Space,
        robot: int,
        wall: int,
        buffer: pb.Buffer | None = None,
        spec: ContactSpec | None = None,
    ) -> None:
        spec = ContactSpec() if spec is None else spec
        self.impact_mps = spec.impact_mps
        self.iterations, self.free_iterations = spec.iterations, spec.free_iterations
        self.space = space
        self.ptr_ = space._space
        self.touching = 0  # contacts begun and not yet separated
        self.robot_hits = self.wall_hits = 0  # contacts begun since reset
        self.robot_impacts = self.wall_impacts = 0  # ... of them at impact_mps or faster
        self.max_overlap_m = 0.0
        self.steps_touching = 0  # physics steps that ended with a contact touching
        space.on_collision(robot, robot, begin=self._begin_robot, separate=self._separate)
        space.on_collision(robot, wall, begin=self._begin_wall, separate=self._separate)
        lib.cpSpaceSetIterations(self.ptr_, self.free_iterations)
        self.buf_ = pb.Buffer() if buffer is None else buffer  # reused: pymunk never frees one
        self.buf_.clear()
        self.query_ = ffi.new("pmBatchedData *")
        self.query_.fields = pb.ArbiterFields.DISTANCE_1.value
        self.query_.floatArray, self.query_.intArray = self.buf_._float_arr, self.buf_._int_arr
        self.query_fn_ = ffi.addressof(lib, "pmSpaceArbiterIteratorFuncBatched")
        self.ptr_view_, self.view_ = None, np.zeros(0)

    COUNTERS = ("robot_hits", "wall_hits", "robot_impacts", "wall_impacts", "steps_touching")

    def state_arrays(self) -> dict[str, np.ndarray]:
        """The counts and the deepest overlap since reset. ``touching`` is not kept: it counts
        the contacts of this space, and a restored space starts without any (pymunk finds the
        contacts that still touch again, as contacts begun)."""
        out = {name: np.array(getattr(self, name), dtype=np.int64) for name in self.COUNTERS}
        out["max_overlap_m"] = np.array(self.max_overlap_m)
        return out

    def restore_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of :meth:`state_arrays`, into a monitor of a freshly built space."""
        for name in self.COUNTERS:
            setattr(self, name, int(arrays[name]))
        self.max_overlap_m = float(arrays["max_overlap_m"])

    def _touch(self) -> None:
        if not self.touching:
            lib.cpSpaceSetIterations(self.ptr_, self.iterations)
        self.touching += 1

    def _begin_robot(self, arbiter, space, data) -> None:
        self.robot_hits += 1
        self.robot_impacts += closing_speed_mps(arbiter) >= self.impact_mps
        self._touch()

    def _begin_wall(self, arbiter, space, data) -> None:
        self.wall_hits += 1
        self.wall_impacts += closing_speed_mps(arbiter) >= self.impact_mps
        self._touch()

    def _separate(self, arbiter, space, data) -> None:
        self.touching -= 1
        if not self.touching:
            lib.cpSpaceSetIterations(self.ptr_, self.free_iterations)

    def run(self, n: int, dt_s: float) -> None:
        """Take ``n`` physics steps of ``dt_s``, measuring the overlap after each that needs it."""
        step, ptr = lib.cpSpaceStep, self.ptr_
        for _ in range(n):
            step(ptr, dt_s)
            if self.touching:
                self._measure()

    def _measure(self) -> None:
        arr = self.buf_._float_arr
        arr.num = 0
        lib.cpSpaceEachCachedArbiter(self.ptr_, self.query_fn_, self.query_)
        self.steps_touching += 1
        num = arr.num
        if num <= 16:  # a few contacts: a Python list is quicker than numpy
            deepest = -min(ffi.unpack(arr.arr, num)) if num else 0.0
        else:
            if arr.arr != self.ptr_view_ or arr.max != self.view_.size:  # the array moved
                self.ptr_view_ = arr.arr
                self.view_ = np.frombuffer(ffi.buffer(arr.arr, 8 * arr.max), dtype=np.float64)
            deepest = -float(self.view_[:num].min())
        if deepest > self.max_overlap_m:
            self.max_overlap_m = deepest
