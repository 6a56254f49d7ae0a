"""``mrta study refusal``: where ExpT-MRTA's refusals cost completion, and what wins it back.

The study is three bundled sweep files run into one folder, each resumable on its own
(``runs.csv`` per part), then read together:

- ``refusal_load``: market, QL-MRTA and ExpT-MRTA (paper and reserve refusal) against offered
  load on the abstract paper scenario, with the causes of every lost task;
- ``refusal_frontier``: ExpT-MRTA's learning space against completion as delta_u and the
  coverage guard k vary, per refusal rule;
- ``refusal_spatial``: the same allocators in the pymunk world (paper_spatial) with abstract
  and distance bids: distance and time per completed task, specialisation per robot.

Outputs: ``study.json`` (strict JSON: no NaN or infinity), ``study.md`` (the tables the README
quotes), ``load.png``, ``losses.png``, ``frontier.png`` and ``spatial.png``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from learning.episode import LOSS_CAUSES
from scenarios.protocol import write_json_atomic
from scenarios.sweep_report import json_number, mean_ci

PARTS = ("refusal_load", "refusal_frontier", "refusal_spatial")
GOAL_GAP = 0.02  # ExpT completion (all and high) at most this far below QL-MRTA
GOAL_SPACE = 700  # final learning space at the paper load (3498 / 5)
PAPER_LOAD = 1.5
SERIES = (  # (key, label, colour, marker)
    ("market", "Market (MRTA)", "#4c72b0", "s"),
    ("ql", "QL-MRTA", "#dd8452", "o"),
    ("expt/paper", "ExpT-MRTA, paper refusal", "#c44e52", "v"),
    ("expt/reserve", "ExpT-MRTA, reserve refusal", "#55a868", "^"),
)
CAUSE_LABELS = {
    "no_capable_free": "no capable robot free",
    "capable_taken": "capable robots all given other tasks",
    "refused": "free capable robots had refused",
    "waited": "a willing robot waited",
}


def series_key(row: dict) -> str:
    """market, ql, expt/paper or expt/reserve for a runs.csv row."""
    if row["allocator"] != "expt":
        return row["allocator"]
    return f"expt/{row.get('experience.refusal', 'reserve')}"


def run_study(
    out: Path,
    parts: tuple[str, ...] = PARTS,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
) -> dict:
    """Run (or resume) every part into ``out/<part>/`` and write the study's outputs.

    ``parts`` are sweep files or bundled sweep names; a part whose name does not start with
    ``refusal_load``, ``refusal_frontier`` or ``refusal_spatial`` is run but not analysed.
    """
    from scenarios.sweep import run_sweep

    out = Path(out)
    rows: dict[str, list[dict]] = {}
    for part in parts:
        name = Path(str(part)).stem
        rows[name] = run_sweep(part, out / name, workers, scheduler, progress)
    doc = analyse(rows)
    write_json_atomic(out / "study.json", doc)
    tmp = out / ".study.md.tmp"
    tmp.write_text(markdown(doc) + "\n")
    tmp.replace(out / "study.md")
    if doc.get("load"):
        fig_load(doc["load"], out / "load.png")
        fig_losses(doc["load"], out / "losses.png")
    if doc.get("frontier"):
        fig_frontier(doc["frontier"], doc.get("load", []), out / "frontier.png")
    if doc.get("spatial"):
        fig_spatial(doc["spatial"], out / "spatial.png")
    return doc


def _part(rows: dict[str, list[dict]], prefix: str) -> list[dict]:
    return next((r for name, r in rows.items() if name.startswith(prefix)), [])


def _group(rows: list[dict], key) -> dict:
    groups: dict = {}
    for r in rows:
        groups.setdefault(key(r), []).append(r)
    return groups


def _stat(runs: list[dict], column: str) -> dict:
    mean, half = mean_ci([r[column] for r in runs])
    return {"mean": json_number(mean), "ci95": json_number(half)}


def analyse(rows: dict[str, list[dict]]) -> dict:
    """Means and 95% CIs per group, gaps to QL-MRTA and whether the goal is met."""
    doc: dict = {"goal": {"max_gap": GOAL_GAP, "max_space_at_paper_load": GOAL_SPACE}}
    load_rows = _part(rows, "refusal_load")
    if load_rows:
        doc["load"] = _load_table(load_rows)
        doc["goal"].update(_goal(doc["load"]))
    frontier_rows = _part(rows, "refusal_frontier")
    if frontier_rows:
        doc["frontier"] = _frontier_table(frontier_rows)
    spatial_rows = _part(rows, "refusal_spatial")
    if spatial_rows:
        doc["spatial"] = _spatial_table(spatial_rows)
    return doc


def _load_table(rows: list[dict]) -> list[dict]:
    def condition(r):
        return (r["offered_load"], r["stream.announce_interval_s"], series_key(r))

    out = []
    for (load, interval, key), runs in _group(rows, condition).items():
        announced = np.mean([r["tasks_announced"] for r in runs])
        entry = {
            "offered_load": load,
            "batch": f"{runs[0]['stream.batch_min']}-{runs[0]['stream.batch_max']}",
            "announce_interval_s": interval,
            "all_free": interval >= 30.0,
            "series": key,
            "seeds": len(runs),
            **{m: _stat(runs, f"completion_{m}") for m in ("all", "high", "low")},
            "space_final": _stat(runs, "space_final"),
            "min_willing": _stat(runs, "min_willing"),
            "lost_share": {
                c: json_number(np.mean([r[f"lost_{c}"] for r in runs]) / announced)
                for c in LOSS_CAUSES
            },
        }
        out.append(entry)
    out.sort(key=lambda e: (e["all_free"], e["offered_load"], e["series"]))
    by = {(e["offered_load"], e["all_free"], e["series"]): e for e in out}
    for e in out:
        ql = by.get((e["offered_load"], e["all_free"], "ql"))
        if ql is not None and e["series"].startswith("expt"):
            e["gap_to_ql"] = {
                m: json_number(e[m]["mean"] - ql[m]["mean"]) for m in ("all", "high", "low")
            }
    return out


def _goal(load: list[dict]) -> dict:
    """Per refusal rule: the worst gap to QL-MRTA (all, high) over the loads, and the space."""
    out = {}
    for rule in ("paper", "reserve"):
        mine = [e for e in load if e["series"] == f"expt/{rule}" and "gap_to_ql" in e]
        if not mine:
            continue
        worst = {m: min(e["gap_to_ql"][m] for e in mine) for m in ("all", "high")}
        paper = [e for e in mine if e["offered_load"] == PAPER_LOAD and not e["all_free"]]
        space = paper[0]["space_final"]["mean"] if paper else None
        out[rule] = {
            "worst_gap_all": worst["all"],
            "worst_gap_high": worst["high"],
            "space_at_paper_load": space,
            "met": bool(
                worst["all"] >= -GOAL_GAP
                and worst["high"] >= -GOAL_GAP
                and space is not None
                and space <= GOAL_SPACE
            ),
        }
    return out


def _frontier_table(rows: list[dict]) -> list[dict]:
    def setting(r):
        return (r["experience.refusal"], r["experience.delta_u"], r["experience.coverage_k"])

    out = []
    for (rule, delta_u, k), runs in _group(rows, setting).items():
        out.append(
            {
                "rule": rule,
                "delta_u": delta_u,
                "coverage_k": k,
                "seeds": len(runs),
                "space_final": _stat(runs, "space_final"),
                "all": _stat(runs, "completion_all"),
                "high": _stat(runs, "completion_high"),
                "low": _stat(runs, "completion_low"),
            }
        )
    for rule in ("paper", "reserve"):
        front = pareto_front([e for e in out if e["rule"] == rule], "all")
        for e in out:
            if e["rule"] == rule:
                e["on_frontier"] = any(e is f for f in front)
    return sorted(out, key=lambda e: (e["rule"], e["coverage_k"], e["delta_u"]))


def pareto_front(entries: list[dict], metric: str) -> list[dict]:
    """The best ``metric`` reachable at each space size: entries that no entry of smaller or
    equal space beats, in order of growing space."""
    front, best = [], -math.inf
    ordered = sorted(entries, key=lambda e: (e["space_final"]["mean"], -(e[metric]["mean"] or 0)))
    for e in ordered:
        value = e[metric]["mean"]
        if value is not None and value > best:
            front.append(e)
            best = value
    return front


def _spatial_table(rows: list[dict]) -> list[dict]:
    out = []
    columns = (
        "completion_all",
        "completion_high",
        "completion_low",
        "distance_per_task_m",
        "time_per_task_s",
        "specialisation_bits",
        "space_final",
    )
    for (cost, key), runs in _group(rows, lambda r: (r["cost"], series_key(r))).items():
        out.append(
            {"cost": cost, "series": key, "seeds": len(runs)} | {c: _stat(runs, c) for c in columns}
        )
    order = [s[0] for s in SERIES]
    return sorted(out, key=lambda e: (e["cost"], order.index(e["series"])))


def _fmt(stat: dict, digits: int) -> str:
    if stat["mean"] is None:
        return "–"
    text = f"{stat['mean']:.{digits}f}"
    return text + (f" ± {stat['ci95']:.{digits}f}" if stat["ci95"] is not None else "")


def markdown(doc: dict) -> str:
    """The study's tables as Markdown (what the README quotes)."""
    labels = {k: label for k, label, _, _ in SERIES}
    parts = []
    if doc.get("load"):
        parts.append(
            "| offered load | batch, interval | allocator | completion all | high | low "
            "| gap to QL (all / high) | final space | lost: "
            + " / ".join(CAUSE_LABELS[c] for c in LOSS_CAUSES)
            + " |\n|---|---|---|---|---|---|---|---|---|"
        )
        for e in doc["load"]:
            gap = e.get("gap_to_ql")
            gap_text = f"{gap['all']:+.3f} / {gap['high']:+.3f}" if gap else ""
            lost = " / ".join(f"{e['lost_share'][c]:.3f}" for c in LOSS_CAUSES)
            parts.append(
                f"| {e['offered_load']:.2f} | {e['batch']}, {e['announce_interval_s']:.0f} s "
                f"| {labels[e['series']]} | {_fmt(e['all'], 3)} | {_fmt(e['high'], 3)} "
                f"| {_fmt(e['low'], 3)} | {gap_text} | {_fmt(e['space_final'], 0)} | {lost} |"
            )
        goal = doc["goal"]
        for rule in ("paper", "reserve"):
            g = goal.get(rule)
            if g:
                parts.append(
                    f"\n{rule} rule: worst gap to QL-MRTA {g['worst_gap_all']:+.3f} (all), "
                    f"{g['worst_gap_high']:+.3f} (high); space at the paper load "
                    f"{g['space_at_paper_load']:.0f}; goal (gaps >= -{GOAL_GAP}, space <= "
                    f"{GOAL_SPACE}) {'met' if g['met'] else 'not met'}."
                )
    if doc.get("frontier"):
        parts.append(
            "\n| rule | delta_u | k | final space | completion all | high | on frontier |"
            "\n|---|---|---|---|---|---|---|"
        )
        for e in doc["frontier"]:
            parts.append(
                f"| {e['rule']} | {e['delta_u']} | {e['coverage_k']} "
                f"| {_fmt(e['space_final'], 0)} | {_fmt(e['all'], 3)} | {_fmt(e['high'], 3)} "
                f"| {'yes' if e['on_frontier'] else ''} |"
            )
    if doc.get("spatial"):
        parts.append(
            "\n| cost | allocator | completion all | high | distance per task [m] "
            "| time per task [s] | specialisation [bits] | final space |"
            "\n|---|---|---|---|---|---|---|---|"
        )
        for e in doc["spatial"]:
            parts.append(
                f"| {e['cost']} | {labels[e['series']]} | {_fmt(e['completion_all'], 3)} "
                f"| {_fmt(e['completion_high'], 3)} | {_fmt(e['distance_per_task_m'], 2)} "
                f"| {_fmt(e['time_per_task_s'], 2)} | {_fmt(e['specialisation_bits'], 2)} "
                f"| {_fmt(e['space_final'], 0)} |"
            )
    return "\n".join(parts)


def _na(x):
    return np.nan if x is None else x


def fig_load(load: list[dict], path: Path | None = None):
    """Completion (all, high, low; 95% CI) against offered load, one line per allocator/rule.

    Hollow markers: the no-overload point (every robot free at every announcement).
    """
    from scenarios.figures import new_figure, save_figure

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
    from scenarios.figures import new_figure, save_figure

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
    from scenarios.figures import new_figure, save_figure

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
    from scenarios.figures import new_figure, save_figure

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


# -- command line ------------------------------------------------------------------------------
STUDIES = {"refusal": PARTS}


def add_parser(subparsers):
    """Add ``mrta study refusal [--out DIR] [--workers N] [--scheduler ADDRESS]``."""
    from scenarios.cli_parser import int_at_least

    p = subparsers.add_parser(
        "study",
        help="a bundled study (several sweeps read together): refusal",
        description="refusal: where ExpT-MRTA's refusals cost completion and what the reserve "
        "rule wins back. Runs the bundled sweeps refusal_load (abstract paper scenario, offered "
        "load 0.45-2.4 and no overload), refusal_frontier (space against completion over delta_u "
        "x coverage_k) and refusal_spatial (paper_spatial, abstract and distance bids), 10 seeds "
        "each, into OUT/<sweep>/ (resumable: re-run to finish an interrupted study), then writes "
        "OUT/study.json, study.md, load.png, losses.png, frontier.png and spatial.png. About 5-10 "
        "minutes on two cores.",
    )
    p.add_argument("name", choices=sorted(STUDIES), help="which study (refusal)")
    p.add_argument(
        "--out", type=Path, default=None, help="output folder (default renders/study/<name>/)"
    )
    p.add_argument(
        "--only",
        default=None,
        metavar="PARTS",
        help="comma-separated subset of the parts, e.g. refusal_load,refusal_frontier "
        "(default: all three)",
    )
    p.add_argument(
        "--workers", type=int_at_least(1), default=None, help="local processes (default: all cores)"
    )
    p.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="a running Dask scheduler address"
    )
    p.add_argument("--no-progress", action="store_true", help="hide the progress bars")
    return p


def cmd_study(args) -> int:
    """The ``mrta study`` command: run (or resume) the parts, print the tables."""
    from scenarios.protocol import UserError

    parts = STUDIES[args.name]
    if args.only:
        wanted = tuple(p.strip() for p in args.only.split(",") if p.strip())
        unknown = [p for p in wanted if p not in parts]
        if unknown or not wanted:
            raise UserError(f"--only: unknown part {unknown[0] if unknown else '(none)'!r}; "
                            f"parts of {args.name}: {', '.join(parts)}")  # fmt: skip
        parts = wanted
    out = args.out or Path("renders") / "study" / args.name
    doc = run_study(out, parts, args.workers, args.scheduler, not args.no_progress)
    print(markdown(doc))
    print(f"wrote {out}/study.json, study.md and the figures")
    return 0
