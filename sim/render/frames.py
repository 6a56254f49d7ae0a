"""Frames of a finished ``Trajectory``: their times, one frame, a stream of frames.

The simulation never draws; these functions read its record afterwards. One
:class:`~sim.render.scene.FrameScene` per call draws the static background once and blits only the
moving artists; frames are read straight from the Agg buffer. Nothing here selects or switches
matplotlib's backend, and no display or environment variable is needed.
"""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from sim.recording import Trajectory
from sim.render.scene import FrameScene

MIN_SIDE_PX = 64


def check_size(size) -> tuple[int, int]:
    """(width, height) in whole pixels, each at least ``MIN_SIDE_PX``; else ``ValueError``."""
    try:
        width, height = (int(v) for v in size)
        ok = (width, height) == tuple(size)
    except (TypeError, ValueError):
        ok = False
    if not ok or min(width, height) < MIN_SIDE_PX:
        raise ValueError(
            f"size must be (width, height) in whole pixels, each at least {MIN_SIDE_PX}; "
            f"got {size!r}"
        )
    return width, height


def _check_trail(trail_s: float) -> float:
    if not (math.isfinite(trail_s) and trail_s >= 0):
        raise ValueError(f"trail_s must be a finite number of seconds >= 0; got {trail_s!r}")
    return float(trail_s)


def _check_traj(traj: Trajectory) -> tuple[float, float]:
    if not isinstance(traj, Trajectory):
        raise TypeError(f"expected a sim.recording.Trajectory, got {type(traj).__name__}")
    if len(traj.times_s) == 0:
        raise ValueError("the trajectory has no recorded poses (times_s is empty)")
    return float(traj.times_s[0]), float(traj.times_s[-1])


def _check_time(name: str, t_s: float, start: float, end: float) -> float:
    tol = 1e-6 * max(1.0, abs(end))
    if not (math.isfinite(t_s) and start - tol <= t_s <= end + tol):
        raise ValueError(f"{name} = {t_s!r} s is outside the recorded times {start:g} .. {end:g} s")
    return min(max(float(t_s), start), end)


def frame_times(
    traj: Trajectory, frames: int = 200, t_from: float | None = None, t_to: float | None = None
) -> np.ndarray:
    """The simulated times of ``frames`` evenly spaced frames from ``t_from`` to ``t_to``.

    Both default to the first and last recorded times. Raises ``ValueError`` for a non-positive
    frame count, times outside the record, ``t_from > t_to``, or several frames of one instant.
    """
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames <= 0:
        raise ValueError(f"frames must be a positive integer; got {frames!r}")
    start, end = _check_traj(traj)
    t0 = start if t_from is None else _check_time("t_from", t_from, start, end)
    t1 = end if t_to is None else _check_time("t_to", t_to, start, end)
    if t0 > t1:
        raise ValueError(f"t_from ({t0:g} s) is after t_to ({t1:g} s)")
    if t0 == t1 and frames > 1:
        raise ValueError(
            f"t_from == t_to ({t0:g} s) would give {frames} identical frames; "
            "use render_frame for one instant"
        )
    return np.linspace(t0, t1, int(frames))


def time_decimals(times: np.ndarray) -> int:
    """Decimals that make consecutive frame times print differently (at least one)."""
    if len(times) < 2:
        return 1
    step = float(times[1] - times[0])
    return int(min(6, max(1, math.ceil(-math.log10(step) - 1e-9))))


def frame_scene(traj: Trajectory, size, trail_s: float, times: np.ndarray) -> FrameScene:
    """A checked :class:`FrameScene` whose clock prints ``times`` apart."""
    scene = FrameScene(traj, check_size(size), _check_trail(trail_s))
    scene.time_decimals = time_decimals(times)
    return scene


def render_frames(
    traj: Trajectory,
    *,
    frames: int = 200,
    size: tuple[int, int] = (600, 600),
    t_from: float | None = None,
    t_to: float | None = None,
    trail_s: float = 10.0,
) -> Iterator[np.ndarray]:
    """Yield ``frames`` (H, W, 3) uint8 RGB images at evenly spaced simulated times.

    Args:
        traj: a finished run.
        frames: number of frames (>= 1).
        size: (width, height) in pixels.
        t_from, t_to: simulated time window in s; defaults: the first and last recorded times.
        trail_s: seconds of history shown (trails; done and lost tasks stay this long).

    Raises:
        ValueError: on bad arguments, before any frame is drawn.
    """
    times = frame_times(traj, frames, t_from, t_to)
    scene = frame_scene(traj, size, trail_s, times)

    def generate() -> Iterator[np.ndarray]:
        for t_s in times:
            yield scene.draw(float(t_s))[..., :3].copy()

    return generate()


def render_frame(
    traj: Trajectory, t_s: float, *, size: tuple[int, int] = (600, 600), trail_s: float = 10.0
) -> np.ndarray:
    """One (H, W, 3) uint8 RGB frame of ``traj`` at simulated time ``t_s``."""
    start, end = _check_traj(traj)
    t_s = _check_time("t_s", t_s, start, end)
    return next(render_frames(traj, frames=1, size=size, t_from=t_s, t_to=t_s, trail_s=trail_s))
