"""Benchmark: our blitted, single-palette GIF path against FuncAnimation + PillowWriter.

Both render the same frames of the same trajectory in the same process, one after the other,
after a small warm-up that pays matplotlib's import and font-cache costs for both. Report the
ratio; absolute seconds depend on the machine. Run ``python -m scenarios.bench.gif``.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import numpy as np

from scenarios.bench.synthetic import synthetic_trajectory
from sim.recording import Trajectory
from sim.render import frame_times, render_frame, render_gif
from sim.render.frames import time_decimals
from sim.render.scene import FrameScene
from sim.render.style import DPI

BENCH_SEED = 0


def baseline_gif(
    traj: Trajectory,
    path: Path,
    *,
    frames: int = 200,
    fps: float = 20,
    size: tuple[int, int] = (600, 600),
    trail_s: float = 10.0,
) -> Path:
    """The usual way: FuncAnimation moves the artists and redraws the whole figure for every
    frame (no blitting; with a non-GUI canvas it even draws twice per frame), and PillowWriter
    gives each frame its own palette. Same content as ``render_gif``, with matplotlib text
    artists where ``render_gif`` stamps text with Pillow. The artists are built once, so this
    is the conservative baseline, not the slowest one."""
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    times = frame_times(traj, frames)
    fig = Figure(figsize=(size[0] / DPI, size[1] / DPI), dpi=DPI)
    FigureCanvasAgg(fig)
    scene = FrameScene(traj, size, trail_s, figure=fig, blit=False)
    scene.time_decimals = time_decimals(times)

    def draw(i: int) -> list:
        scene.update(float(times[i]))
        return []

    anim = FuncAnimation(
        fig,
        draw,
        frames=len(times),
        init_func=lambda: [],
        blit=False,
        repeat=False,
        cache_frame_data=False,
    )
    anim.save(str(path), writer=PillowWriter(fps=fps), dpi=DPI)
    return Path(path)


def bench_gif(
    traj: Trajectory | None = None, frames: int = 200, size: tuple[int, int] = (600, 600)
) -> dict:
    """Time ``render_gif`` and the naive baseline on the same frames, in this process.

    Args:
        traj: the run to render; default: a synthetic 10-robot, 120 s run (seed 0).
        frames: frames per GIF.
        size: (width, height) in pixels.

    Returns:
        ``{"frames", "size", "seconds", "baseline_seconds", "speedup"}``; seconds are wall time
        from trajectory to finished file, encoding included.
    """
    if traj is None:
        traj = synthetic_trajectory(np.random.default_rng(BENCH_SEED), robots=10)
    render_frame(traj, float(traj.times_s[0]), size=(64, 64))  # warm-up: imports, font cache
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        render_gif(traj, Path(tmp) / "fast.gif", frames=frames, size=size)
        t1 = time.perf_counter()
        baseline_gif(traj, Path(tmp) / "baseline.gif", frames=frames, size=size)
        t2 = time.perf_counter()
    seconds, baseline = t1 - t0, t2 - t1
    return {
        "frames": int(frames),
        "size": f"{size[0]}x{size[1]}",
        "seconds": round(seconds, 3),
        "baseline_seconds": round(baseline, 3),
        "speedup": round(baseline / seconds, 1),
    }


if __name__ == "__main__":
    print(json.dumps(bench_gif()))
