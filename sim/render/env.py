"""RGB frames for the Gymnasium and PettingZoo environments (``render_mode="rgb_array"``).

In a spatial world the environment keeps a :class:`sim.recording.TrajectoryRecorder`, and the
frame is :func:`sim.render.frames.render_frame` of that recording at the current time: the very
frames the GIF writer draws. The abstract world has no positions, so its frame is a status board:
one row per robot (free, or busy with the seconds of work left) and the announced batch (type
colour, star for high priority).
"""

from __future__ import annotations

import numpy as np

from sim.render.frames import render_frame
from sim.render.style import type_colours

FRAME_SIZE = (600, 600)


def env_frame(
    world, batch, scenario, recorder=None, size: tuple[int, int] = FRAME_SIZE
) -> np.ndarray:
    """(H, W, 3) uint8 frame of an allocation environment now: the recording's last instant
    (a spatial world with a ``recorder``), else the status board of ``world`` and ``batch``."""
    if recorder is not None and recorder.has_poses():
        traj = recorder.finish()
        return render_frame(traj, float(traj.times_s[-1]), size=size)
    return status_frame(world.snapshot(), batch, scenario, size)


def status_frame(state, batch, scenario, size: tuple[int, int] = FRAME_SIZE) -> np.ndarray:
    """Status board of an abstract world: robots' busy time and the announced batch."""
    from PIL import Image, ImageDraw

    w, h = size
    img = Image.new("RGB", (w, h), (248, 248, 250))
    draw = ImageDraw.Draw(img)
    m = scenario.n_robots
    top, left = 40, 60
    row_h = max(4, (h - top - 90) // max(m, 1))
    horizon = max(max(scenario.exec_time_s, default=1.0), 1e-9)
    draw.text(
        (10, 10), f"t = {state.time_s:.1f} s   free {int(state.free.sum())}/{m}", fill=(20, 20, 20)
    )
    for j, robot in enumerate(scenario.robots):
        y = top + j * row_h
        draw.text((10, y), robot.name[:8], fill=(20, 20, 20))
        left_s = float(state.busy_until_s[j] - state.time_s)
        frac = min(max(left_s / horizon, 0.0), 1.0)
        colour = (60, 60, 60) if not state.free[j] else (200, 200, 200)
        draw.rectangle(
            [left, y + 2, left + int(frac * (w - left - 20)), y + row_h - 2], fill=colour
        )
        draw.rectangle([left, y + 2, w - 20, y + row_h - 2], outline=(160, 160, 160))
    y = h - 70
    draw.text((10, y), "batch:", fill=(20, 20, 20))
    palette = (type_colours(scenario.n_types)[:, :3] * 255).astype(int)
    if batch is not None:
        for k in range(len(batch)):
            x = left + k * 60
            rgb = tuple(int(c) for c in palette[int(batch.types[k])])
            draw.rectangle([x, y, x + 40, y + 40], fill=rgb)
            label = scenario.task_types[int(batch.types[k])]
            draw.text((x + 4, y + 4), label[:5], fill=(255, 255, 255))
            if batch.high[k]:
                draw.text((x + 4, y + 24), "HIGH", fill=(255, 255, 255))
    return np.asarray(img, dtype=np.uint8)
