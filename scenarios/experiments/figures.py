"""Result figures of ``mrta reproduce`` (paper Fig. 1, Fig. 2 and the calibration trade-off).

matplotlib is imported lazily and used through the Agg canvas directly, so importing this
module, or calling it from a program with another backend, changes nothing. Every bar and line
carries a ``gid`` so tests can read the drawn values back and compare them with metrics.json.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from sim.scenario import ContactSpec, StallSpec
from sim.spatial.stalls import CAUSES

ALLOCATOR_COLOURS = {"market": "#4c72b0", "ql": "#dd8452", "expt": "#55a868"}
ALLOCATOR_LABELS = {"market": "Market (MRTA)", "ql": "QL-MRTA", "expt": "ExpT-MRTA"}
BEHAVIOUR_LABELS = ("B0 regular", "B1 eager/hesitant", "B2 refused")
STYLE = {
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 9,
    "axes.spines.top": False,
    "axes.spines.right": False,
}


def new_figure(w_in: float, h_in: float):
    """A constrained-layout Figure on its own Agg canvas (no pyplot, no backend switch)."""
    import matplotlib as mpl
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with mpl.rc_context(STYLE):
        fig = Figure(figsize=(w_in, h_in), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig, path: Path | None) -> None:
    """Write ``fig`` to ``path`` atomically (temporary file, then rename); None: do nothing."""
    if path is not None:
        path = Path(path)
        tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
        fig.savefig(tmp)
        tmp.replace(path)


def allocator_colour(name: str, k: int = 0) -> str:
    return ALLOCATOR_COLOURS.get(name, f"C{k + 3}")


def allocator_bars(ax, x: np.ndarray, series: list[tuple[str, list, list, list[str]]]) -> None:
    """Grouped bars, one colour per allocator, 95% CI whiskers, a gid per bar.

    ``series`` holds (allocator, values, ci95 half-widths, gids), one entry per allocator.
    """
    width = 0.8 / len(series)
    for k, (name, vals, errs, gids) in enumerate(series):
        bars = ax.bar(
            x + (k - (len(series) - 1) / 2) * width,
            vals,
            width,
            yerr=errs,
            capsize=2,
            color=allocator_colour(name, k),
            label=ALLOCATOR_LABELS.get(name, name),
            error_kw={"elinewidth": 0.8},
        )
        for bar, gid in zip(bars, gids, strict=True):
            bar.set_gid(gid)


def fig_completion(metrics: dict, path: Path | None = None):
    """Paper Fig. 1: completion ratio per task type and priority, allocators side by side, CI95."""
    allocs = list(metrics["allocators"])
    types = list(metrics["allocators"][allocs[0]]["completion"]["by_type"])
    panels = [types[i : i + 2] for i in range(0, len(types), 2)]
    cols = 2 if len(panels) > 1 else 1
    rows = math.ceil(len(panels) / cols)
    import matplotlib as mpl

    with mpl.rc_context(STYLE):
        fig = new_figure(4.2 * cols, 2.9 * rows)
        axes = fig.subplots(rows, cols, squeeze=False).ravel()
        for ax, pair, letter in zip(axes, panels, "abcdefghijklmnopqrstuvwxyz", strict=False):
            groups = [(t, p) for t in pair for p in ("low", "high")]
            x = np.arange(len(groups))
            series = []
            for name in allocs:
                comp = metrics["allocators"][name]["completion"]
                vals = [comp["by_type"][t][p] for t, p in groups]
                errs = [comp["ci95"]["by_type"][t][p] for t, p in groups]
                series.append((name, vals, errs, [f"{name}|{t}|{p}" for t, p in groups]))
            allocator_bars(ax, x, series)
            ax.set_xticks(x, [f"{t}\n{p}" for t, p in groups])
            ax.set_ylim(0, 1.05)
            ax.set_ylabel("completion ratio")
            ax.set_title(f"({letter}) {' and '.join(pair)}")
            ax.grid(axis="y", alpha=0.3)
        for ax in axes[len(panels) :]:
            ax.set_visible(False)
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncols=len(allocs), frameon=False)
        scen = metrics.get("scenario", "")
        n = len(metrics.get("seeds", []))
        fig.suptitle(f"Task completion ratio on the test sets ({scen}, {n} seeds, 95% CI)")
    save_figure(fig, path)
    return fig


def fig_robot_trace(trace: dict, path: Path | None = None):
    """Paper Fig. 2: TEM per task, behaviour per task and learning-space size of one robot."""
    import matplotlib as mpl

    rounds = np.asarray(trace["round"])
    caps = trace["capabilities"]
    all_types = trace["task_types"]
    tem = np.asarray(trace["tem"])
    beh = np.asarray(trace["behaviour"])
    with mpl.rc_context(STYLE):
        fig = new_figure(6.4, 7.0)
        ax_u, ax_b, ax_s = fig.subplots(3, 1, sharex=True)
        for k, t in enumerate(caps):
            i = all_types.index(t)
            colour = f"C{i % 10}"
            (line,) = ax_u.plot(rounds, tem[:, i], color=colour, label=t, lw=1.4)
            line.set_gid(f"tem|{t}")
            offset = 0.08 * (k - (len(caps) - 1) / 2)
            (step,) = ax_b.step(rounds, beh[:, i] + offset, where="post", color=colour, label=t)
            step.set_gid(f"behaviour|{t}")
        ax_u.axhline(1.0, color="0.6", lw=0.8, ls=":")
        ax_u.set_ylabel("TEM $u$")
        ax_u.set_title(f"(a) Task experience measure of {trace['robot']}")
        ax_u.legend(ncols=len(caps), frameon=False, loc="upper left")
        ax_b.set_yticks([0, 1, 2], BEHAVIOUR_LABELS)
        ax_b.set_ylim(-0.4, 2.4)
        ax_b.set_title(f"(b) Behaviour of {trace['robot']} per task")
        (space,) = ax_s.step(rounds, trace["space"], where="post", color="k")
        space.set_gid("space")
        ax_s.set_yscale("log")
        ax_s.set_ylabel("|S| x |A|")
        ax_s.set_xlabel("announcement round (learning sets)")
        ax_s.set_title(f"(c) Learning-space dimension of {trace['robot']}")
        levels = sorted(set(int(v) for v in trace["space"]))
        ax_s.set_yticks(levels, [str(v) for v in levels])
        ax_s.minorticks_off()
        for ax in (ax_u, ax_b, ax_s):
            ax.grid(alpha=0.3)
    save_figure(fig, path)
    return fig


def fig_tradeoff(points: list[dict], references: dict, path: Path | None = None):
    """Final learning space against overall completion as delta_u varies (CI95 both ways)."""
    import matplotlib as mpl

    with mpl.rc_context(STYLE):
        fig = new_figure(9.6, 3.9)
        ax, ax2 = fig.subplots(1, 2)
        xs = [p["space"] for p in points]
        ys = [p["all"] for p in points]
        ax.errorbar(
            xs,
            ys,
            xerr=[p["space_ci95"] for p in points],
            yerr=[p["all_ci95"] for p in points],
            fmt="o-",
            color=ALLOCATOR_COLOURS["expt"],
            label="ExpT-MRTA",
            capsize=2,
            gid="expt",
        )
        for p in points:
            ax.annotate(
                f"δu={p['delta_u']:g}",
                (p["space"], p["all"]),
                textcoords="offset points",
                xytext=(4, 4),
                fontsize=8,
            )
        for name, ref in references.items():
            if ref.get("space"):
                ax.errorbar(
                    [ref["space"]],
                    [ref["all"]],
                    yerr=[ref["all_ci95"]],
                    fmt="s",
                    color=allocator_colour(name),
                    label=ALLOCATOR_LABELS.get(name, name),
                    capsize=2,
                )
            else:
                ax.axhline(
                    ref["all"],
                    color=allocator_colour(name),
                    ls="--",
                    lw=1,
                    label=f"{ALLOCATOR_LABELS.get(name, name)} (no learning)",
                )
        ax.set_xscale("log")
        _log_ticks(ax, xs + [r["space"] for r in references.values() if r.get("space")])
        ax.set_xlabel("final learning space, sum over robots of |S| x |A| (log)")
        ax.set_ylabel("completion ratio, all tasks")
        ax.set_title("(a) Learning space against completion")
        ax.legend(frameon=False, fontsize=8)
        ax.grid(alpha=0.3)
        du = [p["delta_u"] for p in points]
        for prio, style in (("high", "-"), ("low", "--")):
            ax2.errorbar(
                du,
                [p[prio] for p in points],
                yerr=[p[f"{prio}_ci95"] for p in points],
                fmt="o" + style,
                color=ALLOCATOR_COLOURS["expt"],
                capsize=2,
                label=f"ExpT-MRTA, {prio} priority",
            )
            ref = references.get("ql")
            if ref:
                ax2.axhline(
                    ref[prio],
                    color=ALLOCATOR_COLOURS["ql"],
                    ls=style,
                    lw=1,
                    label=f"QL-MRTA, {prio} priority",
                )
        ax2.set_xscale("log")
        _log_ticks(ax2, du)
        ax2.set_xlabel("refusal threshold δu (log)")
        ax2.set_ylabel("completion ratio")
        ax2.set_title("(b) Completion by priority against δu")
        ax2.legend(frameon=False, fontsize=8)
        ax2.grid(alpha=0.3)
    save_figure(fig, path)
    return fig


def _log_ticks(ax, values) -> None:
    """Plain-number ticks on a log axis at 1-2-5 steps spanning the plotted values."""
    vals = [float(v) for v in values if v]
    lo, hi = min(vals), max(vals)
    ticks = [
        m * 10.0**e
        for e in range(math.floor(math.log10(lo)) - 1, math.ceil(math.log10(hi)) + 1)
        for m in (1, 2, 5)
        if lo / 1.15 <= m * 10.0**e <= hi * 1.15
    ]
    ax.set_xticks(ticks, [f"{t:g}" for t in ticks])
    ax.minorticks_off()


def fig_run_spatial(table: dict, spatial: dict, cost: str, path: Path | None = None):
    """One spatial run: waiting and finishing times, bid against reality, distance per robot."""
    import matplotlib as mpl

    high = np.asarray(table["high"], dtype=bool)
    ok = np.asarray(table["ok"], dtype=bool)
    start = np.asarray(table["time_to_start_s"])
    finish = np.asarray(table["time_to_finish_s"])
    with mpl.rc_context(STYLE):
        fig = new_figure(9.6, 7.0)
        (a, b), (c, d) = fig.subplots(2, 2)
        bins = np.linspace(0, max(float(np.nanmax(finish[ok], initial=1.0)), 1.0), 30)
        for sel, label, colour in (
            (high & ok, "high priority", "C3"),
            (~high & ok, "low priority", "C0"),
        ):
            a.hist(
                start[sel], bins=bins, alpha=0.6, label=label, color=colour, gid=f"start|{label}"
            )
            b.hist(
                finish[sel], bins=bins, alpha=0.6, label=label, color=colour, gid=f"finish|{label}"
            )
        a.set(title="(a) Time to start (allocation to arrival)", xlabel="s", ylabel="tasks")
        b.set(title="(b) Time to finish (allocation to done)", xlabel="s", ylabel="tasks")
        a.legend(frameon=False)
        actual = {"distance": np.asarray(table["distance_m"]), "time": finish}.get(cost)
        if actual is not None:
            bid = np.asarray(table["bid"])
            c.scatter(bid[ok], actual[ok], s=6, alpha=0.5, color="C2", gid="estimate")
            top = float(max(np.nanmax(bid[ok], initial=1.0), np.nanmax(actual[ok], initial=1.0)))
            c.plot([0, top], [0, top], color="0.4", lw=0.8, ls="--", label="estimate = actual")
            unit = "m" if cost == "distance" else "s"
            c.set(
                title=f"(c) Bid against actual ({cost} cost)",
                xlabel=f"bid [{unit}]",
                ylabel=f"actual [{unit}]",
            )
            c.legend(frameon=False)
        else:
            c.text(
                0.5,
                0.5,
                "abstract cost: bids are not physical",
                ha="center",
                va="center",
                transform=c.transAxes,
            )
            c.set(title="(c) Bid against actual")
        robots = sorted(set(table["robot"]), key=lambda r: (len(r), r))
        dist = [
            float(np.sum(np.asarray(table["distance_m"])[np.asarray(table["robot"]) == r]))
            for r in robots
        ]
        d.bar(robots, dist, color="0.45", gid="distance")
        d.set(title="(d) Distance driven per robot, test sets", ylabel="m")
        d.tick_params(axis="x", rotation=90 if len(robots) > 12 else 0)
        for ax in (a, b, c, d):
            ax.grid(alpha=0.3)
        fig.suptitle(contact_line(spatial, f"; failed tasks {int((~ok).sum())}"))
    save_figure(fig, path)
    return fig


def contact_line(spatial: dict, extra: str = "", contacts: ContactSpec | None = None) -> str:
    """Contacts begun per robot-hour by kind, the deepest overlap (then ``extra``) and the
    one-line definition (``contacts``: the run's ``[spatial.contacts]``), on three lines."""
    impact_mps = (contacts or ContactSpec()).impact_mps
    rate = {k: spatial.get(f"contacts_{k}_per_robot_h", float("nan")) for k in CONTACT_KINDS}
    return "\n".join(
        [
            f"contacts per robot-hour: robot-robot {rate['robot_touch']:.2f} touch, "
            f"{rate['robot_impact']:.2f} impact; robot-wall {rate['wall_touch']:.2f} touch, "
            f"{rate['wall_impact']:.2f} impact",
            f"deepest overlap {1000 * spatial.get('max_overlap_m', 0.0):.1f} mm{extra}",
            f"(a contact begun is a touch below {impact_mps:g} m/s closing speed along its "
            "normal, else an impact)",
        ]
    )


CONTACT_KINDS = ("robot_touch", "robot_impact", "wall_touch", "wall_impact")


def stall_line(spatial: dict, stalls: StallSpec | None = None) -> str:
    """Where driving robots stood still (``sim.spatial.stalls``), largest cause first, on one line
    (``stalls``: the run's ``[spatial.stalls]``); empty for a summary without the stall counts."""
    stalls = stalls or StallSpec()
    if "still_share" not in spatial:
        return ""
    causes = [(k[len("still_s_") :], v) for k, v in spatial.items() if k.startswith("still_s_")]
    causes = sorted(causes, key=lambda kv: -kv[1])
    parts = ", ".join(f"{name.replace('_', ' ')} {v:,.0f} s" for name, v in causes if v > 0)
    long = sum(v for k, v in spatial.items() if k.startswith("still_long_s_"))
    beyond = f"; {long:,.0f} s of it past {stalls.long_s:g} s into a stand" if long > 0 else ""
    return (
        f"driving robots stood still (below {stalls.still_mps:g} m/s) "
        f"{spatial['still_share']:.1%} of "
        f"{spatial['driving_s']:,.0f} robot-s driving" + (f": {parts}" if parts else "") + beyond
    )


# the panels of the stall map: a title and the causes (sim.spatial.stalls.CAUSES) in it
STALL_GROUPS = (
    ("meeting a driving robot", ("robot_head_on", "robot_crossing", "robot_same_way")),
    ("beside a robot at work or idle", ("robot_at_work", "robot_idle")),
    ("holding in a site's queue", ("queue",)),
    ("no robot near (corners, walls)", ("no_robot",)),
)


def stall_places(seconds: np.ndarray, cell_m: float, k: int = 3) -> list[dict]:
    """The ``k`` cells of a stall map (``sim.spatial.stalls.StallMeter.seconds_map``) where driving
    robots stood longest, longest first (ties: lower row, then column): each cell's lower-left
    corner ``x_m``, ``y_m``, its standing ``seconds`` and the ``cause`` with most of them."""
    total = seconds.sum(axis=0)
    flat = total.ravel()
    order = np.lexsort((np.arange(flat.size), -flat))[:k]
    out = []
    for idx in order.tolist():
        if flat[idx] <= 0:
            break
        row, col = divmod(idx, total.shape[1])
        out.append(
            {
                "x_m": col * cell_m,
                "y_m": row * cell_m,
                "seconds": float(flat[idx]),
                "cause": CAUSES[int(np.argmax(seconds[:, row, col]))],
            }
        )
    return out


def places_line(places: list[dict], cell_m: float) -> str:
    """:func:`stall_places` on one line (empty if robots never stood)."""
    if not places:
        return ""
    parts = [
        f"x {p['x_m']:g}-{p['x_m'] + cell_m:g} y {p['y_m']:g}-{p['y_m'] + cell_m:g} m "
        f"{p['seconds']:,.0f} s (mostly {p['cause'].replace('_', ' ')})"
        for p in places
    ]
    return "stood longest at " + "; ".join(parts)


def fig_stall_map(
    seconds: np.ndarray,
    cell_m: float,
    arena_wh: tuple[float, float],
    obstacles,
    path: Path | None = None,
    still_mps: float = StallSpec().still_mps,
):
    """Where driving robots stood still, one panel per group of causes (``STALL_GROUPS``):
    robot-seconds per cell over the arena, obstacles in grey, cells with none left blank
    (``still_mps``: the run's ``[spatial.stalls] still_mps``)."""
    import matplotlib as mpl
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Polygon

    width, height = arena_wh
    _, ny, nx = seconds.shape
    extent = (0.0, nx * cell_m, 0.0, ny * cell_m)
    groups = [
        (title, seconds[[CAUSES.index(c) for c in causes]].sum(axis=0))
        for title, causes in STALL_GROUPS
    ]
    top = max(float(g.max()) for _, g in groups)
    norm = LogNorm(vmin=0.1, vmax=max(top, 1.0))
    aspect = height / max(width, 1e-9)
    with mpl.rc_context(STYLE):
        fig = new_figure(10.0, 10.0 * aspect * 0.95 + 1.2)
        axes = fig.subplots(2, 2).ravel()
        for ax, (title, grid) in zip(axes, groups, strict=True):
            shown = np.ma.masked_less_equal(grid, 0.0)
            image = ax.imshow(
                shown, origin="lower", extent=extent, cmap="magma_r", norm=norm, gid=title
            )
            for poly in obstacles:
                ax.add_patch(Polygon(np.asarray(poly), closed=True, color="0.7", lw=0))
            ax.set(xlim=(0, width), ylim=(0, height), aspect="equal")
            ax.set_title(f"{title}: {grid.sum():,.0f} robot-s")
            ax.tick_params(labelsize=8)
        fig.colorbar(image, ax=list(axes), shrink=0.8, label=f"robot-s per {cell_m:g} m cell")
        fig.suptitle(f"Where driving robots stood still (commanded below {still_mps:g} m/s)")
    save_figure(fig, path)
    return fig


def fig_faults_run(faults: dict, path: Path | None = None):
    """One run with robot faults: (a) each robot's availability (share of the run not broken)
    and its breakdowns; (b) the fates of the test-set tasks (``learning.fates``)."""
    import matplotlib as mpl

    avail = faults["availability"]["per_robot"]
    names = list(avail)
    with mpl.rc_context(STYLE):
        fig = new_figure(11.0, 4.0)
        a, b = fig.subplots(1, 2, gridspec_kw={"width_ratios": [max(len(names), 4), 6]})
        x = np.arange(len(names))
        a.bar(x, [avail[n] for n in names], color="C0", gid="availability")
        for k, n in enumerate(names):
            a.text(k, avail[n] + 0.01, str(faults["failures_per_robot"][n]), ha="center",
                   va="bottom", fontsize=7)  # fmt: skip
        a.set_xticks(x, names, rotation=90 if len(names) > 12 else 0)
        a.set_ylim(0, 1.1)
        a.axhline(faults["availability"]["mean"], color="0.3", lw=0.8, ls="--", label="mean")
        a.set(title="(a) Availability per robot (number: breakdowns)", ylabel="share not broken")
        a.legend(frameon=False, loc="lower right")
        fates = faults["fates"]
        keys = list(fates)
        b.barh(np.arange(len(keys)), [fates[k] for k in keys], color="C2", gid="fates")
        b.set_yticks(np.arange(len(keys)), [k.replace("_", " ") for k in keys])
        b.invert_yaxis()
        b.set(title="(b) Test-set task fates", xlabel="tasks")
        ends = faults["abandon_ends"]
        fig.suptitle(
            f"Robot faults (MTTF {faults['mttf_s']:g} s, policy {faults['policy']}): "
            f"{faults['abandoned']} tasks abandoned on the test sets, {ends['requeued']} "
            f"re-announced, {ends['dropped']} dropped, {ends['set_end']} lost at a set's end"
        )
        save_figure(fig, path)
    return fig
