"""The visual language of rendered frames: colours, mark sizes, and the legend explaining them.

Robots are grey levels (their state) so that hue is left to task types alone; a task's shape is
its priority. Sizes are in pixels at a 600-pixel frame and scale with the frame.
"""

from __future__ import annotations

from collections.abc import Iterable
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING

import numpy as np

from sim.recording import DRIVING, IDLE, WORKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

DPI = 100
ROBOT_RADIUS_M = 0.25  # DriveSpec default; the trajectory does not record body sizes
MIN_ROBOT_RADIUS_PX = 6.5  # large arenas: robots stay visible
STATE_NAMES = {IDLE: "idle", DRIVING: "driving", WORKING: "working"}
# Robots are drawn in grey levels so that hue is left to task types alone.
STATE_FILL = {IDLE: "#ffffff", DRIVING: "#a6a6a6", WORKING: "#262626"}
TRAIL_COLOUR, TRAIL_ALPHA = "#4f7cac", 0.8
ASSIGN_COLOUR = "#222222"
TEXT_COLOUR = "#222222"
OUTSIDE_FACE = "#e6e6e6"
OBSTACLE_FACE, OBSTACLE_EDGE = "#b9ad9b", "#6e6353"
DONE_ALPHA = 0.25
HIGH_PX, LOW_PX, LOST_HIGH_PX, LOST_LOW_PX = 17.0, 8.0, 13.0, 9.0  # task marker sizes
DASHED = (0, (1.5, 1.5))


def type_colours(n: int) -> np.ndarray:
    """(n, 4) RGBA task-type colours: tab10, then light tab20, greys removed; cycles if n > 18."""
    from matplotlib import colormaps

    tab10 = [c for k, c in enumerate(colormaps["tab10"].colors) if k != 7]
    tab20 = [c for k, c in enumerate(colormaps["tab20"].colors) if k % 2 and k != 15]
    base = np.array(tab10 + tab20)
    return np.column_stack([base[np.arange(n) % len(base)], np.ones(n)])


def default_style() -> AbstractContextManager:
    """Matplotlib's default style for the duration of a ``with`` (the backend is untouched)."""
    from matplotlib import style

    return style.context("default")


def legend_entries(
    scale: float, trail_s: float, type_rgba: np.ndarray, type_names: Iterable[str]
) -> tuple[tuple[str, list[tuple]], ...]:
    """(title, [(handle, label), ...]) for robots, tasks and task types."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    grey = "#8c8c8c"

    def marker(shape, face, size_px, edge="black", alpha=1.0, lw=0.6):
        style = {"markerfacecolor": face, "markeredgecolor": edge, "alpha": alpha}
        size = size_px * scale * 72.0 / DPI
        return Line2D(
            [],
            [],
            linestyle="none",
            marker=shape,
            markersize=size,
            markeredgewidth=lw * scale,
            **style,
        )

    trail = Line2D([], [], color=TRAIL_COLOUR, linewidth=1.6 * scale, alpha=TRAIL_ALPHA)
    assign = Line2D([], [], color=ASSIGN_COLOUR, linestyle=DASHED, linewidth=1.2 * scale)
    robots = [(marker("o", STATE_FILL[k], 12, lw=1.2), STATE_NAMES[k]) for k in STATE_NAMES]
    robots.append((trail, f"trail, last {trail_s:g} s"))
    tasks = [
        (marker("*", grey, HIGH_PX), "high priority"),
        (marker("D", grey, LOW_PX), "low priority"),
        (assign, "robot \u2192 its task"),
        (marker("*", grey, HIGH_PX, alpha=DONE_ALPHA), "done (faded)"),
        (marker("X", grey, 11, edge="white", lw=0.5), "lost: no robot"),
    ]
    types = [
        (Patch(facecolor=c, edgecolor="none"), str(name))
        for c, name in zip(type_rgba, type_names, strict=True)
    ]
    return (("Robots (fill = state)", robots), ("Tasks", tasks), ("Task types (colour)", types))


def add_legend(
    fig: Figure,
    x: float,
    top: float,
    scale: float,
    trail_s: float,
    type_rgba: np.ndarray,
    type_names: Iterable[str],
    note: str,
) -> None:
    """Stack the three legends from (x, top) down (figure fractions), then ``note`` below them."""
    renderer = fig.canvas.get_renderer()
    height = fig.bbox.height
    spacing = {
        "handlelength": 1.6,
        "handletextpad": 0.5,
        "labelspacing": 0.45,
        "borderpad": 0.2,
        "borderaxespad": 0.0,
        "columnspacing": 0.8,
    }
    for title, entries in legend_entries(scale, trail_s, type_rgba, type_names):
        if not entries:
            continue
        handles, labels = zip(*entries, strict=True)
        leg = fig.legend(
            handles,
            labels,
            loc="upper left",
            bbox_to_anchor=(x, top),
            frameon=False,
            fontsize=7.5 * scale,
            title=title,
            title_fontsize=8 * scale,
            alignment="left",
            ncol=1 if len(entries) <= 10 else 2,
            **spacing,
        )
        leg.get_title().set_fontweight("bold")
        top = (leg.get_window_extent(renderer).y0 - 10 * scale) / height
    fig.text(
        x + 3 * scale / fig.bbox.width,
        top,
        note,
        va="top",
        fontsize=7 * scale,
        color="#555555",
        linespacing=1.3,
    )
