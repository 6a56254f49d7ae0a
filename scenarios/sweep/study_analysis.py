"""The refusal study read together: tables of its three sweeps and the goal, as JSON and Markdown.

Rows come from the sweeps' ``runs.csv`` (:func:`scenarios.sweep.runner.run_sweep`); means and
95% CIs are taken over seeds per group (:func:`scenarios.sweep.report.mean_ci`). What the study
is and what it writes: :mod:`scenarios.sweep.study`.
"""

from __future__ import annotations

import math

import numpy as np

from learning.episode import LOSS_CAUSES
from scenarios.sweep.report import json_number, mean_ci

PARTS = ("refusal_load", "refusal_frontier", "refusal_spatial")
GOAL_GAP = 0.02  # ExpT completion (all and high) at most this far below QL-MRTA
GOAL_SPACE = 700  # final learning space at the paper load (3498 / 5)
PAPER_LOAD = 1.5
# refusal_load's no-overload point: the paper scenario's 30 s tasks announced every 30 s, so
# every robot is free at every announcement (runs.csv does not carry execution times)
ALL_FREE_INTERVAL_S = 30.0
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
            "all_free": interval >= ALL_FREE_INTERVAL_S,
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
