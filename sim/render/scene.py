"""One frame of a recorded run: a figure built once, its moving artists updated per instant.

``FrameScene`` lays out the arena, obstacles, axes and legend once and draws them into a cached
background. Each ``draw(t_s)`` restores that background, moves the reused artists (``set_data``,
``set_offsets``) and draws only them (blitting); moving text is stamped with Pillow
(``sim.render.text``), the costliest part otherwise.

Matplotlib is imported inside functions and used through ``Figure`` + ``FigureCanvasAgg``
directly, so the importing process's backend is never selected or switched and no display is
needed. Frames are drawn under matplotlib's default style, so a user's matplotlibrc does not
change them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sim.recording import Trajectory
from sim.render.style import (
    ASSIGN_COLOUR,
    BOTTOM_PX,
    DASHED,
    DONE_ALPHA,
    DPI,
    GAP_PX,
    HIGH_PX,
    LEFT_PX,
    LOST_HIGH_PX,
    LOST_LOW_PX,
    LOW_PX,
    MIN_ROBOT_RADIUS_PX,
    OBSTACLE_EDGE,
    OBSTACLE_FACE,
    OUTSIDE_FACE,
    ROBOT_RADIUS_M,
    SITE_PX,
    STATE_FILL,
    TEXT_COLOUR,
    TRAIL_ALPHA,
    TRAIL_COLOUR,
    WAIT_RING,
    add_legend,
    default_style,
    layout_options,
    type_colours,
)
from sim.render.timeline import (
    nan_joined,
    robot_poses_at,
    task_counts_at,
    task_view_at,
    trails_at,
)
from sim.states import DRIVING, IDLE, WAITING, WORKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure


class FrameScene:
    """A figure for one trajectory whose moving artists are redrawn per simulated instant.

    Args:
        traj: the recorded run.
        size: (width, height) of the frame in pixels.
        trail_s: seconds of history shown: robot trails; done and lost tasks vanish after it.
        figure: draw into this figure (its canvas must be Agg) instead of a new one.
        blit: cache the background and stamp text with Pillow (``draw`` needs this). With
            ``blit=False`` every artist, text included, is an ordinary matplotlib artist that a
            full ``canvas.draw()`` renders (the baseline in ``scenarios.bench.gif``).
    """

    def __init__(
        self,
        traj: Trajectory,
        size: tuple[int, int] = (600, 600),
        trail_s: float = 10.0,
        *,
        figure: Figure | None = None,
        blit: bool = True,
    ) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.colors import to_rgba_array
        from matplotlib.figure import Figure

        self.traj = traj
        self.width, self.height = (int(v) for v in size)
        self.trail_s = float(trail_s)
        self.blit = blit
        self.scale = float(np.clip(min(size) / 600.0, 0.5, 2.0))  # fonts, markers, margins
        self.time_decimals = 1  # of the clock in the title
        if figure is None:
            figure = Figure(figsize=(self.width / DPI, self.height / DPI), dpi=DPI)
            FigureCanvasAgg(figure)
        self.fig, self.canvas = figure, figure.canvas
        self.type_rgba = type_colours(len(traj.type_names))
        self._state_rgba = to_rgba_array([STATE_FILL[s] for s in (IDLE, DRIVING, WORKING, WAITING)])
        types = np.asarray(traj.task_type, dtype=int)
        self._task_rgba = self.type_rgba[types] if types.size else np.zeros((0, 4))
        self._task_faded = self._task_rgba.copy()
        self._task_faded[:, 3] = DONE_ALPHA
        self._high = np.asarray(traj.task_high, dtype=bool)
        with default_style():
            self.fig.set_facecolor("white")
            self._layout()
            self._build_static()
            self._build_animated()
        self._background = None
        self._title = ""
        self._xy = np.zeros((len(traj.robot_names), 2))

    # --- layout and static background -------------------------------------------------------

    def _pt(self, pixels: float) -> float:
        """Scaled pixels to points (marker sizes and line widths are in points)."""
        return pixels * self.scale * 72.0 / DPI

    def _layout(self) -> None:
        """Arena axes with the arena's aspect, and the legend where it costs the arena least:
        in a column on the right or in a row underneath, whichever leaves the arena larger."""
        s, width, height = self.scale, self.width, self.height
        arena_w, arena_h = (float(v) for v in self.traj.arena_wh)
        self.pad_m = 0.03 * max(arena_w, arena_h)  # robots at the walls are not clipped
        span_w, span_h = arena_w + 2 * self.pad_m, arena_h + 2 * self.pad_m
        self.top_px = 30 * s
        options = layout_options(width, height, span_w, span_h, s)
        mode = max(options, key=lambda k: (options[k][3], k == "right"))  # larger arena wins
        x0, box_w, box_h, _ = options[mode]
        self.legend_mode = mode
        self.px_per_m = min(box_w / span_w, box_h / span_h)
        ax_w, ax_h = span_w * self.px_per_m, span_h * self.px_per_m
        x0 = x0 + (box_w - ax_w) / 2
        y0 = height - self.top_px - ax_h - (box_h - ax_h) / 2
        self.ax = self.fig.add_axes((x0 / width, y0 / height, ax_w / width, ax_h / height))
        if mode == "right":
            self.legend_xy = ((x0 + ax_w + GAP_PX * s) / width, 1.0 - self.top_px / height)
        else:
            self.legend_xy = (LEFT_PX * s / width, (y0 - BOTTOM_PX * s - GAP_PX * s) / height)

    def _build_static(self) -> None:
        from matplotlib.patches import Polygon, Rectangle
        from matplotlib.ticker import FixedLocator, FuncFormatter, MaxNLocator

        ax, s, traj = self.ax, self.scale, self.traj
        arena_w, arena_h = (float(v) for v in traj.arena_wh)
        ax.set_xlim(-self.pad_m, arena_w + self.pad_m)
        ax.set_ylim(-self.pad_m, arena_h + self.pad_m)
        ax.set_autoscale_on(False)
        ax.set_facecolor(OUTSIDE_FACE)
        for spine in ax.spines.values():
            spine.set_visible(False)
        for axis, lo, hi, shift in (
            (ax.xaxis, *ax.get_xlim(), float(traj.map_origin_xy[0])),
            (ax.yaxis, *ax.get_ylim(), float(traj.map_origin_xy[1])),
        ):
            if shift == 0.0:
                axis.set_major_locator(MaxNLocator(5, integer=True))
            else:  # a map's arena: ticks and labels in the map's frame, as RViz shows it
                ticks = MaxNLocator(5, integer=True).tick_values(lo + shift, hi + shift)
                axis.set_major_locator(FixedLocator(ticks - shift))
                axis.set_major_formatter(FuncFormatter(lambda v, _, d=shift: f"{v + d:g}"))
        ax.tick_params(labelsize=7 * s, length=3 * s, pad=1.5 * s, colors="#444444")
        wall = {"facecolor": "white", "edgecolor": "#333333", "linewidth": self._pt(2.0)}
        ax.add_patch(Rectangle((0, 0), arena_w, arena_h, zorder=0.5, **wall))
        grey = np.asarray(traj.map_grey)
        if grey.size:  # the map's cells, one grey image, instead of its many polygons
            extent = (0.0, arena_w, 0.0, arena_h)
            ax.imshow(grey, cmap="gray", vmin=0, vmax=255, extent=extent, origin="lower",
                      interpolation="nearest", aspect="auto", zorder=0.6)  # fmt: skip
        block = {"facecolor": OBSTACLE_FACE, "edgecolor": OBSTACLE_EDGE}
        own = len(traj.obstacles) - int(traj.map_polygons)
        for poly in traj.obstacles[:own]:
            pts = poly[np.all(np.isfinite(poly), axis=1)]
            if len(pts) >= 3:
                ax.add_patch(Polygon(pts, closed=True, linewidth=self._pt(1.2), zorder=1, **block))
        sites = np.asarray(traj.site_xy, dtype=float).reshape(-1, 2)
        if len(sites):
            edge = self.type_rgba[np.asarray(traj.site_type, dtype=int)]
            ax.scatter(*sites.T, s=self._pt(SITE_PX) ** 2, marker="o", facecolors="white",
                       edgecolors=edge, linewidths=1.4 * s, zorder=1.5)  # fmt: skip
        note = f"arena {arena_w:g} \u00d7 {arena_h:g} m\nobstacles shaded"
        if grey.size:
            note = f"map {arena_w:g} \u00d7 {arena_h:g} m\nwalls dark, unknown grey"
        note += "\nsites: hollow when idle" if len(sites) else ""
        add_legend(
            self.fig,
            *self.legend_xy,
            self.scale,
            self.trail_s,
            self.type_rgba,
            self.traj.type_names,
            note,
            row=self.legend_mode == "below",
        )

    # --- moving artists --------------------------------------------------------------------

    def _build_animated(self) -> None:
        ax, s, m = self.ax, self.scale, len(self.traj.robot_names)
        anim = {"animated": self.blit}
        self.robot_r_m = max(ROBOT_RADIUS_M, MIN_ROBOT_RADIUS_PX * s / self.px_per_m)
        robot_d_pt = 2 * self.robot_r_m * self.px_per_m * 72.0 / DPI
        (self.trails,) = ax.plot(
            [],
            [],
            color=TRAIL_COLOUR,
            linewidth=1.6 * s,
            alpha=TRAIL_ALPHA,
            solid_capstyle="round",
            zorder=2,
            **anim,
        )
        (self.assign,) = ax.plot(
            [], [], color=ASSIGN_COLOUR, linewidth=1.2 * s, linestyle=DASHED, zorder=3, **anim
        )

        def tasks(shape, size_px, z, edge, lw=0.6):
            return ax.scatter(
                [],
                [],
                s=self._pt(size_px) ** 2,
                marker=shape,
                edgecolors=[edge],
                linewidths=lw * s,
                zorder=z,
                **anim,
            )

        faded_edge = (0.0, 0.0, 0.0, DONE_ALPHA)
        self.done_high = tasks("*", HIGH_PX, 3, faded_edge)
        self.done_low = tasks("D", LOW_PX, 3, faded_edge)
        self.lost = tasks("X", LOST_LOW_PX, 4, "white", lw=0.5)
        self.open_high = tasks("*", HIGH_PX, 4, "black")
        self.open_low = tasks("D", LOW_PX, 4, "black")
        self.robots = ax.scatter(
            np.zeros(m),
            np.zeros(m),
            s=robot_d_pt**2,
            marker="o",
            edgecolors="black",
            linewidths=1.2 * s,
            zorder=5,
            **anim,
        )
        self.rings = ax.scatter(  # round waiting robots
            np.zeros(0),
            np.zeros(0),
            s=(WAIT_RING * robot_d_pt) ** 2,
            marker="o",
            facecolors="none",
            edgecolors="black",
            linewidths=0.9 * s,
            zorder=5,
            **anim,
        )
        (self.ticks,) = ax.plot(
            [], [], color="black", linewidth=1.8 * s, solid_capstyle="butt", zorder=6, **anim
        )
        self._animated = [
            self.trails,
            self.done_high,
            self.done_low,
            self.assign,
            self.lost,
            self.open_high,
            self.open_low,
            self.robots,
            self.rings,
            self.ticks,
        ]
        self.labels, self.title, self.text = [], None, None
        if self.blit:
            self._build_text_stamp()
            return
        box = {
            "boxstyle": "round,pad=0.12",
            "facecolor": "white",
            "edgecolor": "none",
            "alpha": 0.75,
        }
        self.labels = [
            ax.text(
                0,
                0,
                str(name),
                fontsize=7.5 * s,
                fontweight="bold",
                va="bottom",
                zorder=7,
                bbox=box,
                clip_on=True,
            )
            for name in self.traj.robot_names
        ]
        self.title = self.fig.text(
            0.02,
            1 - 7 * s / self.height,
            "",
            va="top",
            fontsize=10 * s,
            fontweight="bold",
            color=TEXT_COLOUR,
        )

    def _build_text_stamp(self) -> None:
        from sim.render.text import TextStamp

        s, box = self.scale, self.ax.bbox  # display coordinates, y up
        clip = (
            int(np.floor(box.x0)),
            int(np.ceil(box.x1)),
            int(np.floor(self.height - box.y1)),
            int(np.ceil(self.height - box.y0)),
        )
        self.text = TextStamp(
            self.traj.robot_names,
            label_px=round(7.5 * s * DPI / 72),
            title_px=round(10 * s * DPI / 72),
            width=self.width,
            title_h=max(1, min(self.height, round(self.top_px - 4 * s))),
            clip=clip,
            colour=TEXT_COLOUR,
        )

    def update(self, t_s: float) -> None:
        """Move every moving artist to simulated time ``t_s`` (does not draw)."""
        traj, r = self.traj, self.robot_r_m
        xy, heading, state = robot_poses_at(traj, t_s)
        self._xy = xy
        self.robots.set_offsets(xy)
        self.robots.set_facecolors(self._state_rgba[np.clip(state, 0, WAITING)])
        self.rings.set_offsets(xy[state == WAITING].reshape(-1, 2))
        u = np.column_stack([np.cos(heading), np.sin(heading)])
        self.ticks.set_data(*nan_joined(np.stack([xy + r * u, xy + 1.9 * r * u], axis=1)))
        for k, label in enumerate(self.labels):
            label.set_position((xy[k, 0] + 0.75 * r, xy[k, 1] + 0.75 * r))
        self.trails.set_data(*nan_joined(trails_at(traj, t_s, self.trail_s, xy)))

        view = task_view_at(traj, t_s, self.trail_s)
        high = self._high
        self._set_tasks(self.open_high, view.waiting & high, self._task_rgba)
        self._set_tasks(self.open_low, view.waiting & ~high, self._task_rgba)
        self._set_tasks(self.done_high, view.done & high, self._task_faded)
        self._set_tasks(self.done_low, view.done & ~high, self._task_faded)
        self._set_tasks(self.lost, view.lost, self._task_rgba)
        self.lost.set_sizes(self._pt(np.where(high[view.lost], LOST_HIGH_PX, LOST_LOW_PX)) ** 2)
        k = np.flatnonzero(view.taken & (traj.task_robot < len(xy)))
        pairs = np.stack([xy[traj.task_robot[k]], traj.task_xy[k]], axis=1)
        self.assign.set_data(*nan_joined(pairs))

        c = task_counts_at(traj, t_s)
        self._title = (
            f"t = {t_s:.{self.time_decimals}f} s   done {c['done']}   lost {c['lost']}   "
            f"in progress {c['in_progress']}   announced {c['announced']}"
        )
        if self.title is not None:
            self.title.set_text(self._title)

    def _set_tasks(self, coll, mask: np.ndarray, rgba: np.ndarray) -> None:
        coll.set_offsets(self.traj.task_xy[mask])
        coll.set_facecolors(rgba[mask])

    # --- drawing ---------------------------------------------------------------------------

    def draw(self, t_s: float) -> np.ndarray:
        """Render time ``t_s``: the canvas's (H, W, 4) RGBA buffer, valid until the next draw."""
        if not self.blit:
            raise RuntimeError("draw() needs a FrameScene built with blit=True")
        if self._background is None:
            with default_style():
                self.canvas.draw()  # animated artists are left out of this
            self._background = self.canvas.copy_from_bbox(self.fig.bbox)
        self.update(t_s)
        self.canvas.restore_region(self._background)
        renderer = self.canvas.get_renderer()
        for artist in self._animated:
            artist.draw(renderer)
        buf = np.asarray(self.canvas.buffer_rgba())
        r_px = self.robot_r_m * self.px_per_m
        self.text.stamp(buf, self._title, self.pixel_xy(self._xy), r_px)
        return buf

    def pixel_xy(self, xy_m: np.ndarray) -> np.ndarray:
        """Arena points (k, 2) in metres to (column, row) pixel coordinates of the frame."""
        disp = self.ax.transData.transform(np.atleast_2d(xy_m))
        return np.column_stack([disp[:, 0], self.height - disp[:, 1]])
