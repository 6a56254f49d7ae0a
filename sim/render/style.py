"""The visual language of rendered frames: colours, mark sizes, and the legend explaining them.

Robots are grey levels (their state) so that hue is left to task types alone; a task's shape is
its priority. Sizes are in pixels at a 600-pixel frame and scale with the frame.
"""

from __future__ import annotations

from collections.abc import Iterable
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING

import numpy as np

from sim.states import DRIVING, IDLE, WAITING, WORKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

DPI = 100
ROBOT_RADIUS_M = 0.25  # DriveSpec default; the trajectory does not record body sizes
MIN_ROBOT_RADIUS_PX = 6.5  # large arenas: robots stay visible
STATE_NAMES = {IDLE: "idle", DRIVING: "driving", WAITING: "waiting (ringed)", WORKING: "working"}
# Robots are drawn in grey levels so that hue is left to task types alone; a waiting robot (it
# holds in a site's queue or waits for a robot at work) is light grey and ringed.
STATE_FILL = {IDLE: "#ffffff", DRIVING: "#a6a6a6", WAITING: "#d9d9d9", WORKING: "#262626"}
WAIT_RING = 1.55  # the ring round a waiting robot, in robot radii
TRAIL_COLOUR, TRAIL_ALPHA = "#4f7cac", 0.8
ASSIGN_COLOUR = "#222222"
TEXT_COLOUR = "#222222"
OUTSIDE_FACE = "#e6e6e6"
OBSTACLE_FACE, OBSTACLE_EDGE = "#b9ad9b", "#6e6353"
DONE_ALPHA = 0.25
HIGH_PX, LOW_PX, LOST_HIGH_PX, LOST_LOW_PX = 17.0, 8.0, 13.0, 9.0  # task marker sizes
DASHED = (0, (1.5, 1.5))
SITE_PX = 9  # hollow ring of an idle task site
# frame layout, in pixels at scale 1 (a 600-pixel side)
LEFT_PX, BOTTOM_PX, RIGHT_PX, GAP_PX = 26, 18, 6, 8
TOP_PX = 30  # the title line
LEGEND_W_PX = 134  # legend column on the right
LEGEND_ROW_H_PX = 104  # legend row underneath
LEGEND_COL_H_PX = 370  # height the legend column needs


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
    k = list(STATE_NAMES).index(WAITING)
    ring = marker("o", "none", 12 * WAIT_RING, lw=0.9)
    robots[k] = ((ring, robots[k][0]), STATE_NAMES[WAITING])
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


def layout_options(
    width: float, height: float, span_w: float, span_h: float, scale: float
) -> dict[str, tuple[float, float, float, float]]:
    """For the legend on the "right" and "below": (left px, box width, box height, px per m)
    of the box the arena is fitted into, in a frame of ``width`` x ``height`` pixels."""
    s = scale
    box_h = max(height - TOP_PX * s - BOTTOM_PX * s, 10.0)
    right_w = max(width - LEGEND_W_PX * s - LEFT_PX * s - GAP_PX * s, 10.0)
    below_w = max(width - LEFT_PX * s - RIGHT_PX * s, 10.0)
    below_h = max(box_h - GAP_PX * s - LEGEND_ROW_H_PX * s, 10.0)
    right = (LEFT_PX * s, right_w, box_h, min(right_w / span_w, box_h / span_h))
    below = (LEFT_PX * s, below_w, below_h, min(below_w / span_w, below_h / span_h))
    if box_h < LEGEND_COL_H_PX * s:  # the column would not fit: only the row is possible
        return {"below": below}
    return {"right": right, "below": below}


def fitted_height(width: int, arena_wh, scale: float | None = None) -> int:
    """Frame height (pixels) for ``width`` with no empty band: the arena fills its box.

    The legend goes in a column on the right when the frame is then tall enough for it, else
    in a row underneath.
    """
    s = float(np.clip(width / 600.0, 0.5, 2.0)) if scale is None else scale
    arena_w, arena_h = (float(v) for v in arena_wh)
    pad = 0.03 * max(arena_w, arena_h)
    span_w, span_h = arena_w + 2 * pad, arena_h + 2 * pad
    right_w = width - LEGEND_W_PX * s - LEFT_PX * s - GAP_PX * s
    h_right = (TOP_PX + BOTTOM_PX) * s + right_w * span_h / span_w
    if h_right >= (TOP_PX + BOTTOM_PX + LEGEND_COL_H_PX) * s:
        return int(np.ceil(h_right))
    below_w = width - (LEFT_PX + RIGHT_PX) * s
    return int(
        np.ceil((TOP_PX + BOTTOM_PX + GAP_PX + LEGEND_ROW_H_PX) * s + below_w * span_h / span_w)
    )


def add_legend(
    fig: Figure,
    x: float,
    top: float,
    scale: float,
    trail_s: float,
    type_rgba: np.ndarray,
    type_names: Iterable[str],
    note: str,
    row: bool = False,
) -> None:
    """The three legends from (x, top) (figure fractions), then ``note``: stacked downwards in
    a column, or with ``row=True`` side by side to the right (types in several columns)."""
    renderer = fig.canvas.get_renderer()
    height, width = fig.bbox.height, fig.bbox.width
    spacing = {
        "handlelength": 1.6,
        "handletextpad": 0.5,
        "labelspacing": 0.45,
        "borderpad": 0.2,
        "borderaxespad": 0.0,
        "columnspacing": 0.8,
    }
    x0 = x
    for title, entries in legend_entries(scale, trail_s, type_rgba, type_names):
        if not entries:
            continue
        handles, labels = zip(*entries, strict=True)
        ncol = 1 if len(entries) <= 10 else 2
        if row and len(entries) > 5:
            ncol = -(-len(entries) // 5)
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
            ncol=ncol,
            **spacing,
        )
        leg.get_title().set_fontweight("bold")
        box = leg.get_window_extent(renderer)
        if row:
            x = (box.x1 + 14 * scale) / width
        else:
            top = (box.y0 - 10 * scale) / height
    fig.text(
        (x if row else x0) + 3 * scale / width,
        top,
        note,
        va="top",
        fontsize=7 * scale,
        color="#555555",
        linespacing=1.3,
    )
