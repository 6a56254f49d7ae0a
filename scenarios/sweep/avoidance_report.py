"""Collision avoidance before and after, from a sweep's runs: ``avoidance.md`` and
``avoidance.json``.

Written by every sweep that varies ``spatial.avoidance`` with ``"none"`` among its values
(``mrta sweep avoidance``, ``avoidance_seeds5_9``, ``avoidance_wide``): for each scenario,
allocator, cost model (and the values of any other swept parameter), each avoidance setting
against ``"none"`` on the seeds both have, with issue 15's targets checked. Settings that act
only with avoidance on (``spatial.orca.*``, ``spatial.traffic.*``) share one set of ``"none"``
runs: a sweep need not run ``"none"`` once per value of them. These are the
README's before-and-after tables; re-running the sweep into a finished folder rewrites them
without running anything.

Per row:

- tasks allocated and time from allocation to arrival (``time_to_start_s``): means over the
  seeds, the change as the ratio of the means less one, and the standard error of that change
  from the per-seed differences in units of the baseline's mean (paired by seed: the same
  task stream on both sides);
- failed tasks, summed over the seeds;
- robot-robot touches and impacts per robot-hour (means over seeds), the seeds with no
  robot-robot impact, and robot-wall contacts (touches and impacts) per robot-hour, the mean
  and the largest seed's.
"""

from __future__ import annotations

import math
import statistics
from pathlib import Path

import numpy as np

from scenarios.experiments.output import write_json_atomic
from scenarios.sweep.against import paired
from scenarios.sweep.columns import MOTION_METRICS

PARAMETER = "spatial.avoidance"
BASELINE = "none"

# Issue 15, item 6: robot-robot contacts at most 1 per robot-hour and impacts 0 in at least 4
# of 5 seeds; robot-wall contacts at most 0.5 per robot-hour; tasks allocated within 3% of the
# baseline's; time to arrival at most 10% longer; no failed task.
TARGETS = {
    "robot_contacts": ("robot-robot contacts <= 1 /robot-h", 1.0),
    "impact_free": ("no robot-robot impact in >= 80% of seeds", 0.8),
    "wall_contacts": ("robot-wall contacts <= 0.5 /robot-h", 0.5),
    "tasks": ("tasks allocated >= -3%", -0.03),
    "arrival": ("time to arrival <= +10%", 0.10),
    "failed": ("no failed task", 0),
}
NEEDED = MOTION_METRICS  # a run without them (an abstract scenario) is left out
# Settings that act only with avoidance on: a group that varies them finds its "none" runs in
# any group that differs from it only in them (a sweep runs "none" once, not once per value).
AVOIDANCE_ONLY = ("spatial.orca.", "spatial.traffic.")


def _mean(xs) -> float:
    return float(statistics.fmean(xs))


def _paired(base: list[float], other: list[float]) -> tuple[float, float | None]:
    """(change: the mean per-seed difference over the baseline's mean, which is the ratio of
    the means less one; its standard error, None with fewer than two seeds), from
    :func:`scenarios.sweep.against.paired`."""
    p = paired(base, other)
    if p["diff_pct"] is None:  # a baseline mean of 0: no relative change
        return math.nan, None
    return p["diff_pct"] / 100, None if p["diff_pct_se"] is None else p["diff_pct_se"] / 100


def _side(runs: list[dict]) -> dict:
    """The means and counts of one side (one avoidance setting) over its seeds."""
    impacts = [r["contacts_robot_impact_per_robot_h"] for r in runs]
    wall = [
        r["contacts_wall_touch_per_robot_h"] + r["contacts_wall_impact_per_robot_h"] for r in runs
    ]
    return {
        "tasks_allocated": _mean(r["tasks_allocated"] for r in runs),
        "time_to_start_s": _mean(r["time_to_start_s"] for r in runs),
        "failed_tasks": int(sum(r["failed_tasks"] for r in runs)),
        "robot_touch_per_robot_h": _mean(r["contacts_robot_touch_per_robot_h"] for r in runs),
        "robot_impact_per_robot_h": _mean(impacts),
        "seeds_without_impact": sum(1 for x in impacts if x == 0),
        "wall_per_robot_h": _mean(wall),
        "wall_per_robot_h_max_seed": max(wall),
    }


def avoidance_rows(records: list[dict], parameters) -> list[dict]:
    """Each avoidance setting against ``"none"``, per (scenario, allocator, cost, other swept
    parameters), on the seeds both ran; [] when the sweep does not vary ``spatial.avoidance``
    with ``"none"`` among its values. Runs without the spatial metrics (abstract scenarios) are
    left out."""
    if PARAMETER not in parameters:
        return []
    others = [p for p in parameters if p != PARAMETER]
    groups: dict[tuple, dict[str, dict[int, dict]]] = {}
    for r in records:
        if any(r.get(k) is None for k in NEEDED):
            continue
        key = (r["scenario"], r["allocator"], r["cost"], *(r[p] for p in others))
        groups.setdefault(key, {}).setdefault(r[PARAMETER], {})[r["seed"]] = r
    shared: dict[tuple, dict[int, dict]] = {}  # the "none" runs by key less AVOIDANCE_ONLY
    for key, by_value in groups.items():
        if BASELINE in by_value:
            shared.setdefault(_base_key(key, others), by_value[BASELINE])
    rows = []
    for key, by_value in groups.items():
        base = by_value.get(BASELINE) or shared.get(_base_key(key, others))
        if not base:
            continue
        for value, runs in by_value.items():
            seeds = sorted(set(base) & set(runs))
            if value == BASELINE or not seeds:
                continue
            b, o = [base[s] for s in seeds], [runs[s] for s in seeds]
            tasks, tasks_se = _paired(*([r["tasks_allocated"] for r in x] for x in (b, o)))
            arrival, arrival_se = _paired(*([r["time_to_start_s"] for r in x] for x in (b, o)))
            after = _side(o)
            row = dict(zip(["scenario", "allocator", "cost", *others], key, strict=True))
            row.update(
                avoidance=value,
                seeds=seeds,
                before=_side(b),
                after=after,
                tasks_change=tasks,
                tasks_change_se=tasks_se,
                arrival_change=arrival,
                arrival_change_se=arrival_se,
            )
            robot = after["robot_touch_per_robot_h"] + after["robot_impact_per_robot_h"]
            clean = after["seeds_without_impact"] / len(seeds)
            row["targets"] = {
                "robot_contacts": robot <= TARGETS["robot_contacts"][1],
                "impact_free": clean >= TARGETS["impact_free"][1],
                "wall_contacts": after["wall_per_robot_h"] <= TARGETS["wall_contacts"][1],
                "tasks": tasks >= TARGETS["tasks"][1],
                "arrival": arrival <= TARGETS["arrival"][1],
                "failed": after["failed_tasks"] <= TARGETS["failed"][1],
            }
            rows.append(row)
    return rows


def _base_key(key: tuple, others: list[str]) -> tuple:
    """``key`` (scenario, allocator, cost, other parameters' values) without the values of the
    parameters that act only with avoidance on."""
    keep = [not p.startswith(AVOIDANCE_ONLY) for p in others]
    return key[:3] + tuple(v for v, k in zip(key[3:], keep, strict=True) if k)


def _pct(x: float, se: float | None) -> str:
    return f"{100 * x:+.1f}%" + ("" if se is None else f" ({100 * se:.1f})")


def markdown(rows: list[dict], others=()) -> str:
    """The before-and-after table and, per row, the targets missed."""
    extra = "".join(f" {p} |" for p in others)
    lines = [
        "Collision avoidance against none, paired by seed (`scenarios/sweep/avoidance_report.py`).",
        "Changes: ratio of the means less one, standard error in points of the none mean in "
        "brackets. Contacts per robot-hour, means over seeds; failed tasks summed. A contact "
        "is a touch (closing speed below 0.3 m/s) or an impact.",
        "",
        f"| scenario | allocator | cost |{extra} avoidance | seeds | tasks allocated none / after "
        "| change | time to arrival s none / after | change | failed none / after "
        "| robot-robot touch /h | robot-robot impact /h | seeds without impact "
        "| robot-wall /h (largest seed) | targets missed |",
        "|---|---|---|" + "---|" * len(others) + "---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        b, a = r["before"], r["after"]
        missed = [TARGETS[k][0] for k, ok in r["targets"].items() if not ok]
        cells = [
            r["scenario"],
            r["allocator"],
            r["cost"],
            *(str(r[p]) for p in others),
            str(r["avoidance"]),
            str(len(r["seeds"])),
            f"{b['tasks_allocated']:.1f} / {a['tasks_allocated']:.1f}",
            _pct(r["tasks_change"], r["tasks_change_se"]),
            f"{b['time_to_start_s']:.2f} / {a['time_to_start_s']:.2f}",
            _pct(r["arrival_change"], r["arrival_change_se"]),
            f"{b['failed_tasks']} / {a['failed_tasks']}",
            f"{a['robot_touch_per_robot_h']:.2f}",
            f"{a['robot_impact_per_robot_h']:.3f}",
            f"{a['seeds_without_impact']}/{len(r['seeds'])}",
            f"{a['wall_per_robot_h']:.2f} ({a['wall_per_robot_h_max_seed']:.2f})",
            "; ".join(missed) if missed else "none",
        ]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _label(row: dict, rows: list[dict], others) -> str:
    """A row's bar label: the allocator, and what else tells the rows apart."""
    from scenarios.experiments.figures import ALLOCATOR_LABELS

    label = ALLOCATOR_LABELS.get(row["allocator"], row["allocator"])
    if len({r["cost"] for r in rows}) > 1:
        label += f" / {row['cost']}"
    if len({r["avoidance"] for r in rows}) > 1:
        label += f" / {row['avoidance']}"
    for p in others:
        label += f"\n{p} = {row[p]}"
    return label


def fig_avoidance(rows: list[dict], others=(), path: Path | None = None):
    """Per scenario (a row of panels): the change in tasks allocated and in time to arrival
    against ``"none"`` per allocator (bars, in % of the ``none`` mean, with the standard error
    of the per-seed change), and robot-robot and robot-wall contacts per robot-hour (bars: means
    over seeds; dots: the largest seed's wall rate), each with its issue-15 target as a dashed
    line; the panels of a column share one y range, so that scenarios (``mrta sweep
    avoidance_layouts``: the warehouse and its variants) compare at a glance. Each bar carries
    ``gid = "<panel>:<scenario>:<label>"``."""
    from scenarios.experiments.figures import allocator_colour, new_figure, save_figure

    scenarios = list(dict.fromkeys(r["scenario"] for r in rows))
    panels = (
        ("tasks", "tasks allocated, change %", 100 * TARGETS["tasks"][1]),
        ("arrival", "time to arrival, change %", 100 * TARGETS["arrival"][1]),
        ("robot", "robot-robot contacts /robot-h", TARGETS["robot_contacts"][1]),
        ("wall", "robot-wall contacts /robot-h", TARGETS["wall_contacts"][1]),
    )
    fig = new_figure(3.6 * len(panels), 3.2 * len(scenarios))
    axes = np.atleast_2d(fig.subplots(len(scenarios), len(panels), squeeze=False, sharey="col"))
    for i, sc in enumerate(scenarios):
        mine = [r for r in rows if r["scenario"] == sc]
        labels = [_label(r, rows, others) for r in mine]
        x = np.arange(len(mine))
        colours = [allocator_colour(r["allocator"], k) for k, r in enumerate(mine)]
        values = {
            "tasks": (
                [100 * r["tasks_change"] for r in mine],
                [r["tasks_change_se"] for r in mine],
            ),
            "arrival": (
                [100 * r["arrival_change"] for r in mine],
                [r["arrival_change_se"] for r in mine],
            ),
            "robot": (
                [
                    r["after"]["robot_touch_per_robot_h"] + r["after"]["robot_impact_per_robot_h"]
                    for r in mine
                ],
                [None] * len(mine),
            ),
            "wall": ([r["after"]["wall_per_robot_h"] for r in mine], [None] * len(mine)),
        }
        for ax, (key, title, target) in zip(axes[i], panels, strict=True):
            mean, se = values[key]
            for k in range(len(mine)):
                ax.bar(
                    x[k], mean[k], yerr=None if se[k] is None else 100 * se[k], capsize=3,
                    color=colours[k], gid=f"{key}:{sc}:{labels[k]}",
                )  # fmt: skip
            if key == "wall":
                ax.plot(x, [r["after"]["wall_per_robot_h_max_seed"] for r in mine], "k.",
                        label="largest seed")  # fmt: skip
                ax.legend(loc="best", fontsize="small")
            ax.axhline(target, color="grey", linestyle="--", linewidth=1)
            ax.axhline(0.0, color="black", linewidth=0.6)
            ax.set_xticks(x, labels, fontsize="small")
            ax.set_title(f"{sc}: {title}", fontsize="medium")
    fig.suptitle(
        "collision avoidance against none, paired by seed (bars: mean over seeds, "
        "± standard error; dashed: issue 15's target)"
    )
    save_figure(fig, path)
    return fig


def write_avoidance_report(records: list[dict], parameters, out: Path) -> bool:
    """``avoidance.md``, ``avoidance.json`` and ``avoidance.png`` in ``out`` if the sweep varies
    avoidance against ``"none"`` (the text files written through a temporary file and a
    rename); True if written."""
    rows = avoidance_rows(records, parameters)
    if not rows:
        return False
    others = [p for p in parameters if p != PARAMETER]
    doc = {"baseline": BASELINE, "targets": {k: v[0] for k, v in TARGETS.items()}, "rows": rows}
    write_json_atomic(out / "avoidance.json", doc)
    tmp = out / ".avoidance.md.tmp"
    tmp.write_text(markdown(rows, others) + "\n")
    tmp.replace(out / "avoidance.md")
    fig_avoidance(rows, others, out / "avoidance.png")
    return True
