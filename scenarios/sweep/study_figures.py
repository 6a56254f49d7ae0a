"""Figures of the refusal study: completion against load, loss causes, the space/completion
frontier and the pymunk-world comparison (matplotlib loaded on first use)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from learning.episode import LOSS_CAUSES
from scenarios.sweep.study_analysis import (
    CAUSE_LABELS,
    GOAL_GAP,
    GOAL_SPACE,
    PAPER_LOAD,
    SERIES,
    pareto_front,
)


def _na(x):
    return np.nan if x is None else x


def fig_load(load: list[dict], path: Path | None = None):
    """Completion (all, high, low; 95% CI) against offered load, one line per allocator/rule.

    Hollow markers: the no-overload point (every robot free at every announcement).
    """
    from scenarios.experiments.figures import new_figure, save_figure

    fig = new_figure(13.0, 4.0)
    axes = fig.subplots(1, 3, sharey=True)
    for ax, metric in zip(axes, ("all", "high", "low"), strict=True):
        for key, label, colour, marker in SERIES:
            for all_free in (False, True):
                pts = [e for e in load if e["series"] == key and e["all_free"] == all_free]
                if not pts:
                    continue
                x = [e["offered_load"] for e in pts]
                y = [_na(e[metric]["mean"]) for e in pts]
                err = [_na(e[metric]["ci95"]) or 0.0 for e in pts]
                ax.errorbar(
                    x, y, yerr=err, color=colour, marker=marker, capsize=3,
                    linestyle="none" if all_free else "-",
                    markerfacecolor="white" if all_free else colour,
                    label=None if all_free else label, gid=f"{metric}:{key}:{all_free}",
                )  # fmt: skip
        ax.axvline(PAPER_LOAD, color="0.6", lw=0.8, ls=":")
        ax.set_title(f"completion, {metric} tasks")
        ax.set_xlabel("offered load ρ")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("completion ratio (test sets)")
    axes[0].legend(loc="lower left")
    fig.suptitle(
        "Completion against offered load ρ = mean batch × exec time / (interval × robots) "
        "(paper scenario, 95% CI)\nhollow: every robot free at each announcement; "
        "dotted: the paper's load"
    )
    save_figure(fig, path)
    return fig


def fig_losses(load: list[dict], path: Path | None = None):
    """Why tasks were lost: share of announced tasks per cause, per load and allocator."""
    from scenarios.experiments.figures import new_figure, save_figure

    conditions = sorted({(e["all_free"], e["offered_load"]) for e in load})
    fig = new_figure(3.2 * len(conditions), 4.2)
    axes = fig.subplots(1, len(conditions), sharey=True, squeeze=False)[0]
    colours = ("#8172b3", "#937860", "#c44e52", "#ccb974")
    for ax, (all_free, rho) in zip(axes, conditions, strict=True):
        here = (all_free, rho)
        entries = {e["series"]: e for e in load if (e["all_free"], e["offered_load"]) == here}
        keys = [k for k, *_ in SERIES if k in entries]
        bottom = np.zeros(len(keys))
        for cause, colour in zip(LOSS_CAUSES, colours, strict=True):
            vals = np.array([entries[k]["lost_share"][cause] or 0.0 for k in keys])
            ax.bar(range(len(keys)), vals, bottom=bottom, color=colour,
                   label=CAUSE_LABELS[cause], gid=f"{rho}:{all_free}:{cause}")  # fmt: skip
            bottom += vals
        short = {"market": "market", "ql": "QL", "expt/paper": "ExpT\npaper",
                 "expt/reserve": "ExpT\nreserve"}  # fmt: skip
        ax.set_xticks(range(len(keys)), [short[k] for k in keys])
        ax.set_title(f"ρ = {rho:.2f}" + (" (all free)" if all_free else ""))
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel("tasks lost / tasks announced (test sets)")
    axes[-1].legend(loc="upper right", fontsize=8)
    fig.suptitle("Why tasks were lost: the cause counted at each lost task's announcement")
    save_figure(fig, path)
    return fig


def fig_frontier(frontier: list[dict], load: list[dict], path: Path | None = None):
    """Learning space against completion (all, high) per refusal rule, Pareto front drawn."""
    from scenarios.experiments.figures import new_figure, save_figure

    fig = new_figure(11.0, 4.4)
    axes = fig.subplots(1, 2, sharex=True)
    ql = [e for e in load if e["series"] == "ql" and e["offered_load"] == PAPER_LOAD
          and not e["all_free"]]  # fmt: skip
    style = {"paper": SERIES[2], "reserve": SERIES[3]}
    for ax, metric in zip(axes, ("all", "high"), strict=True):
        if ql:
            ref = ql[0][metric]["mean"]
            ax.axhspan(ref - GOAL_GAP, ref, color="#dd8452", alpha=0.15, lw=0)
            ax.axhline(ref, color="#dd8452", lw=1, label=f"QL-MRTA (space 3498): {ref:.3f}")
        ax.axvline(GOAL_SPACE, color="0.5", ls="--", lw=0.8, label=f"goal: space ≤ {GOAL_SPACE}")
        ax.axvline(550, color="0.5", ls=":", lw=0.8, label="paper's ExpT space (550)")
        for rule, (_, label, colour, marker) in style.items():
            mine = [e for e in frontier if e["rule"] == rule]
            if not mine:
                continue
            x = [e["space_final"]["mean"] for e in mine]
            y = [_na(e[metric]["mean"]) for e in mine]
            ax.scatter(x, y, color=colour, marker=marker, alpha=0.55, s=22,
                       gid=f"{metric}:{rule}:points")  # fmt: skip
            front = pareto_front(mine, metric)
            ax.plot([e["space_final"]["mean"] for e in front],
                    [_na(e[metric]["mean"]) for e in front], color=colour, lw=1.5,
                    label=f"{label} (front over δu, k)", gid=f"{metric}:{rule}:front")  # fmt: skip
        ax.set_xscale("log")
        ax.set_xlabel("final learning space Σ |S|×|A| (log)")
        ax.set_title(f"completion, {metric} tasks")
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("completion ratio (test sets)")
    axes[0].legend(loc="lower right", fontsize=8)
    fig.suptitle(
        "What each refusal rule reaches: space against completion as δu and k vary "
        "(paper load, 10 seeds; shaded: within 0.02 of QL-MRTA)"
    )
    save_figure(fig, path)
    return fig


def fig_spatial(spatial: list[dict], path: Path | None = None):
    """paper_spatial: completion, distance and time per completed task, specialisation."""
    from scenarios.experiments.figures import new_figure, save_figure

    panels = (
        ("completion_all", "completion, all tasks"),
        ("completion_high", "completion, high priority"),
        ("distance_per_task_m", "distance driven per completed task [m]"),
        ("time_per_task_s", "allocation to done per task [s]"),
        ("specialisation_bits", "types per robot: entropy [bits]"),
    )
    costs = list(dict.fromkeys(e["cost"] for e in spatial))
    fig = new_figure(15.0, 3.8)
    axes = fig.subplots(1, len(panels))
    width = 0.8 / len(SERIES)
    for ax, (column, title) in zip(axes, panels, strict=True):
        for k, (key, label, colour, _) in enumerate(SERIES):
            vals, errs = [], []
            for cost in costs:
                e = next((e for e in spatial if e["cost"] == cost and e["series"] == key), None)
                vals.append(_na(e[column]["mean"]) if e else np.nan)
                errs.append((_na(e[column]["ci95"]) if e else np.nan) or 0.0)
            x = np.arange(len(costs)) + (k - (len(SERIES) - 1) / 2) * width
            ax.bar(x, vals, width, yerr=errs, color=colour, label=label, capsize=2,
                   gid=f"{column}:{key}")  # fmt: skip
        ax.set_xticks(np.arange(len(costs)), [f"{c} bids" for c in costs])
        ax.set_title(title)
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(SERIES), frameon=False)
    fig.suptitle("The refusal rules in the pymunk world (paper_spatial, 10 seeds, 95% CI)")
    save_figure(fig, path)
    return fig
