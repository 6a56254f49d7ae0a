"""Headless rendering of a finished run: frames, animated GIFs and MP4s, environment frames.

An adapter over the record: the simulation never draws, and nothing here is imported by the
physics. Matplotlib is imported lazily, inside the functions that draw, and used through its Agg
canvas directly, so the importing process's backend is never selected or switched.

- ``timeline``: what a frame shows at one simulated instant (numpy only);
- ``style``: colours, mark sizes and the legend;
- ``text``: moving text stamped with Pillow;
- ``scene``: :class:`FrameScene`, a figure built once whose moving artists are redrawn;
- ``frames``: frame times, one frame, a stream of frames;
- ``animation``: GIF and MP4 files;
- ``env``: frames of the Gymnasium and PettingZoo environments.
"""

from sim.render.animation import render_gif, render_mp4
from sim.render.env import env_frame
from sim.render.frames import frame_times, render_frame, render_frames

__all__ = [
    "env_frame",
    "frame_times",
    "render_frame",
    "render_frames",
    "render_gif",
    "render_mp4",
]
