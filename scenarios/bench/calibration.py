"""A fixed physics step to measure the loop against: the same small space in every run.

The world's own bare ``space.step`` is a poor yardstick: its cost moves with the contacts of
the world it steps (the solver takes ten iterations while one touches, one otherwise), so a
loop's ratio to it swung between runs of the same code. :func:`calibration_step_s` times a
space that does not depend on any run: ``n`` robots built as the world builds them
(``sim.spatial.motors.Motors``: a circle per robot, driven by a kinematic control body through a
pivot and a gear joint) on a grid in a walled box, far enough apart never to touch, each
turning in place at a fixed rate, with the world's solver iterations for a space without
contacts. Its cost is the joints' and the step's call overhead, as a contact-free step of the
world's has; ``mrta bench`` reports each loop in these steps.
"""

from __future__ import annotations

import time

import numpy as np
import pymunk

from sim.scenario import ContactSpec, DriveSpec
from sim.spatial.motors import Motors

PITCH_M = 2.0  # grid spacing of the calibration robots (radius 0.25 m: they never touch)
TURN_RADPS = 0.5  # every robot turns in place at this rate
DT_S = 1.0 / 60.0  # the bundled scenarios' physics step


def calibration_space(n: int) -> pymunk.Space:
    """The calibration space of ``n`` robots (a new one each call, always built the same)."""
    drive = DriveSpec()
    cols = int(np.ceil(np.sqrt(n)))
    starts = np.array([((k % cols + 1) * PITCH_M, (k // cols + 1) * PITCH_M) for k in range(n)])
    side = (cols + 1) * PITCH_M
    space = pymunk.Space()
    space.iterations = ContactSpec().free_iterations
    corners = [(0.0, 0.0), (side, 0.0), (side, side), (0.0, side)]
    for a, b in zip(corners, corners[1:] + corners[:1], strict=True):
        space.add(pymunk.Segment(space.static_body, a, b, 0.1))
    motors = Motors(space, drive, starts, 1)
    rob = motors.read()
    z, th = rob["z"].copy(), rob["th"].copy()
    motors.write(z, th, np.exp(1j * th), np.zeros(n), np.full(n, TURN_RADPS))
    return space


def calibration_step_s(n: int, steps: int, repeat: int = 3) -> float:
    """Seconds per step of the calibration space of ``n`` robots: the best of ``repeat``
    runs of ``steps`` steps, each on a freshly built space."""
    best = np.inf
    for _ in range(repeat):
        space = calibration_space(n)
        step = space.step
        t0 = time.perf_counter()
        for _ in range(steps):
            step(DT_S)
        best = min(best, (time.perf_counter() - t0) / steps)
    return best


def calibration_while(n: int, more, tick, clock, chunk: int = 16) -> float:
    """Seconds per step of the calibration space of ``n`` robots, stepped ``chunk`` steps at
    a time, with ``tick()`` after each chunk, until ``more()`` is False (at least one chunk):
    the whole time by ``clock``, over the steps. Run as a job of a ``Relay`` that lasts as
    long as the loops beside it (``more``: another job has not ended), it is timed in the same
    mixture of the machine's quick and slow spells as they are, where
    :func:`calibration_step_s`, the best of three short runs, catches a quick spell."""
    space = calibration_space(n)
    step = space.step
    steps = 0
    t0 = clock()
    while True:
        for _ in range(chunk):
            step(DT_S)
        steps += chunk
        tick()
        if not more():
            break
    return (clock() - t0) / steps
