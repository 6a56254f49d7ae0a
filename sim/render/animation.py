"""Animations of a finished ``Trajectory``: an animated GIF (Pillow) or an MP4 (ffmpeg).

The GIF fast path (SPEC §7): frames come from one :class:`~sim.render.scene.FrameScene`, every
frame is mapped to ONE palette built once, and Pillow writes the file. Either file is written
beside its path under a temporary name and renamed into place.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
from collections.abc import Callable
from pathlib import Path

import numpy as np

from sim.atomic import replacing
from sim.recording import Trajectory
from sim.render.frames import check_size, frame_scene, frame_times, render_frames
from sim.render.scene import FrameScene
from sim.render.style import (
    ASSIGN_COLOUR,
    DONE_ALPHA,
    OBSTACLE_EDGE,
    OBSTACLE_FACE,
    OUTSIDE_FACE,
    STATE_FILL,
    TEXT_COLOUR,
    TRAIL_ALPHA,
    TRAIL_COLOUR,
)

MAX_GIF_FPS = 50  # GIF delays are in 1/100 s; browsers slow delays under 2/100 s to 1/10 s
PALETTE_SAMPLES = 6  # frames the adaptive part of the palette is built from
PALETTE_MIN_GAP = 6  # adaptive entries keep this far (max channel difference) from fixed ones


def _fixed_colours(scene: FrameScene) -> np.ndarray:
    """The colours the scene paints with, exactly, as (k, 3) uint8 (before anti-aliasing)."""
    from matplotlib.colors import to_rgb

    white = np.ones(3)
    named = [
        to_rgb(c)
        for c in (
            "white",
            "black",
            TEXT_COLOUR,
            ASSIGN_COLOUR,
            OUTSIDE_FACE,
            OBSTACLE_FACE,
            OBSTACLE_EDGE,
            *STATE_FILL.values(),
        )
    ]
    trail = np.array(to_rgb(TRAIL_COLOUR))
    named += [TRAIL_ALPHA * trail + (1 - TRAIL_ALPHA) * white]
    types = scene.type_rgba[:, :3]
    faded = DONE_ALPHA * types + (1 - DONE_ALPHA) * white
    inks = np.vstack([types, TRAIL_ALPHA * trail + (1 - TRAIL_ALPHA) * white])
    # anti-aliased edges of thin lines and small markers over the white arena
    ramps = [a * inks + (1 - a) * white for a in (0.3, 0.55, 0.8)]
    rgb = np.vstack([np.array(named), types, faded, *ramps])
    if len(rgb) > 192:  # very many task types: leave room for the adaptive part
        rgb = rgb[: len(named) + 2 * len(types)]
    return np.unique(np.round(rgb * 255).astype(np.uint8), axis=0)


def _palette(scene: FrameScene, times: np.ndarray):
    """One 256-colour palette image: the scene's own colours plus an adaptive part.

    The adaptive part is a median cut of a few frames spread over the window (every other
    pixel), so anti-aliased edges and blends get close entries too.
    """
    from PIL import Image

    fixed = _fixed_colours(scene)
    picks = np.unique(np.linspace(0, len(times) - 1, min(len(times), PALETTE_SAMPLES)).round())
    mosaic = np.concatenate([scene.draw(float(times[int(i)]))[::2, ::2, :3] for i in picks], axis=0)
    adaptive = Image.fromarray(np.ascontiguousarray(mosaic)).quantize(
        colors=256 - len(fixed), method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE
    )
    extra = np.array(adaptive.getpalette()[: 3 * (256 - len(fixed))], dtype=np.int16)
    extra = extra.reshape(-1, 3)
    # Pillow maps pixels through a 6-bit-per-channel cache; an adaptive entry a few levels from
    # a fixed colour can capture that colour's cell and tint a whole flat area (white -> 252).
    near = np.abs(extra[:, None, :] - fixed[None, :, :].astype(np.int16)).max(axis=2)
    extra = extra[near.min(axis=1) > PALETTE_MIN_GAP].astype(np.uint8)
    colours = np.vstack([fixed, extra])
    colours = colours[np.sort(np.unique(colours, axis=0, return_index=True)[1])]
    colours = np.vstack([colours, np.repeat(colours[:1], 256 - len(colours), axis=0)])
    pal = Image.new("P", (1, 1))
    pal.putpalette(colours.ravel().tolist())
    return pal


def render_gif(
    traj: Trajectory,
    path: str | os.PathLike,
    *,
    frames: int = 200,
    fps: float = 20,
    size: tuple[int, int] = (600, 600),
    t_from: float | None = None,
    t_to: float | None = None,
    trail_s: float = 10.0,
    on_frame: Callable[[], None] | None = None,
) -> Path:
    """Write an animated, endlessly looping GIF of ``traj``; returns its path.

    ``on_frame`` is called after every frame is drawn (progress bars).

    Frames are as in :func:`render_frames`; ``fps`` (at most 50) sets the playback rate. The file
    is written beside ``path`` under a temporary name and renamed into place, so a reader never
    sees half a GIF. Parent directories are created. Pillow keeps every frame in memory until it
    writes the file: width x height bytes per frame (72 MB for 200 frames at 600x600).

    Raises:
        ValueError: on bad arguments, before anything is drawn or written.
    """
    from PIL import Image

    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and 0 < fps <= MAX_GIF_FPS):
        raise ValueError(f"fps must be in (0, {MAX_GIF_FPS}] for a GIF; got {fps!r}")
    times = frame_times(traj, frames, t_from, t_to)
    scene = frame_scene(traj, size, trail_s, times)
    path = Path(path)
    palette = _palette(scene, times)
    images = []
    for t_s in times:
        rgba = scene.draw(float(t_s))
        rgb = Image.frombuffer("RGBA", (scene.width, scene.height), rgba, "raw", "RGBA", 0, 1)
        images.append(rgb.convert("RGB").quantize(palette=palette, dither=Image.Dither.NONE))
        if on_frame is not None:
            on_frame()
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path, ".gif") as tmp:
        # optimize=True: unchanged pixels become transparent, which halves the file at 600x600
        # and costs no measurable time (palette re-ordering only runs below 512x512 pixels).
        images[0].save(
            tmp,
            format="GIF",
            save_all=True,
            append_images=images[1:],
            duration=round(1000 / fps),
            loop=0,
            optimize=True,
        )
    return path


def ffmpeg_path() -> str | None:
    """The ``ffmpeg`` program on PATH, or None (MP4s need it; GIFs need only Pillow)."""
    return shutil.which("ffmpeg")


def render_mp4(
    traj: Trajectory,
    path: str | os.PathLike,
    *,
    frames: int = 200,
    fps: float = 20,
    size: tuple[int, int] = (600, 600),
    t_from: float | None = None,
    t_to: float | None = None,
    trail_s: float = 10.0,
    crf: int = 20,
) -> Path:
    """Write an H.264 MP4 of ``traj`` by piping raw frames to ``ffmpeg``; returns its path.

    Raises:
        RuntimeError: if ``ffmpeg`` is not on PATH, or it fails (its message is included).
        ValueError: on bad arguments.
    """
    ffmpeg = ffmpeg_path()
    if ffmpeg is None:
        raise RuntimeError(
            "render_mp4 needs the ffmpeg program on PATH and it was not found; install ffmpeg "
            "(e.g. apt-get install ffmpeg) or use render_gif, which needs only Pillow"
        )
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive number; got {fps!r}")
    width, height = check_size(size)
    stream = render_frames(
        traj, frames=frames, size=size, t_from=t_from, t_to=t_to, trail_s=trail_s
    )
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path, ".mp4") as tmp:
        cmd = [
            ffmpeg,
            "-y",
            "-loglevel",
            "error",
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            "-s",
            f"{width}x{height}",
            "-r",
            f"{fps:g}",
            "-i",
            "-",
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2:color=white",  # yuv420p needs even sides
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
            "-crf",
            str(int(crf)),
            "-f",
            "mp4",
            str(tmp),
        ]
        with subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE) as proc:
            try:
                for frame in stream:
                    proc.stdin.write(frame.tobytes())
            except BrokenPipeError:
                pass
            finally:
                proc.stdin.close()
            err = proc.stderr.read().decode(errors="replace")
            proc.wait()
        if proc.returncode != 0:
            raise RuntimeError(f"ffmpeg failed (exit {proc.returncode}): {err.strip()}")
    return path
