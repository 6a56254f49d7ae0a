"""Rows, resume and outputs of a sweep: runs.csv, summary.csv, summary.json, sensitivity plots
(and the avoidance report, :mod:`scenarios.sweep.avoidance_report`).

runs.csv holds one row per run: the key columns (scenario, allocator, cost, seed, one column per
swept parameter) and the metric columns below. Numbers are written as Python's shortest exact
text (``repr``), so a row reads back bit for bit, wherever and whenever it was computed.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from learning.episode import LOSS_CAUSES
from scenarios.experiments.metrics import ci95
from scenarios.experiments.output import write_json_atomic, write_rows_atomic
from scenarios.experiments.protocol import UserError
from scenarios.sweep.avoidance_report import write_avoidance_report
from scenarios.sweep.columns import INT_COLUMNS, METRIC_COLUMNS, SPATIAL_CONTACTS
from scenarios.sweep.spec import PARAMETERS

SUMMARY_METRICS = (
    "completion_low",
    "completion_high",
    "completion_all",
    "space_final",
    "space_joint_log10",
    "kept_capabilities",
    "min_willing",
    "offered_load",
    *(f"lost_{cause}" for cause in LOSS_CAUSES),
    "specialisation_bits",
    "distance_per_task_m",
    "time_per_task_s",
    "completion_scarce_low",
    "completion_scarce_high",
    "abandoned",
    "availability",
)
PANELS = (
    ("completion_high", "high-priority completion"),
    ("completion_all", "overall completion"),
    ("space_final", "final learning space"),
)
LINESTYLES = ("-", "--", ":", "-.")


def _num(x: float | int) -> str:
    return str(x) if isinstance(x, int) else repr(float(x))


def _opt(x: float | None) -> str:
    """A number as CSV text; empty for None or NaN (no value)."""
    return "" if x is None or (isinstance(x, float) and math.isnan(x)) else _num(x)


def metric_row(summary: dict) -> dict[str, str]:
    """The metric columns of one run, as CSV text, from a summary of
    :func:`scenarios.experiments.protocol.execute`."""
    comp = summary["completion"]["overall"]
    row = {
        "completion_low": _num(comp["low"]),
        "completion_high": _num(comp["high"]),
        "completion_all": _num(comp["all"]),
        "tasks_announced": _num(summary["tasks"]["announced"]),
        "tasks_allocated": _num(summary["tasks"]["allocated"]),
        "space_initial": "",
        "space_final": "",
        "space_joint_log10": "",
        "kept_capabilities": "",
        "min_willing": _num(min(summary["willing_per_type"].values())),
        "offered_load": _num(summary["offered_load"]),
        **{f"lost_{c}": _num(n) for c, n in summary["lost"].items()},
        "specialisation_bits": _opt(summary["specialisation"]["entropy_bits_mean"]),
        "distance_per_task_m": "",
        "time_per_task_s": "",
        "time_to_start_s": "",
        "failed_tasks": "",
        **{c: "" for c in SPATIAL_CONTACTS},
    }
    spatial = summary.get("spatial")
    if spatial is not None:
        row["distance_per_task_m"] = _opt(spatial["distance_per_task_m"])
        row["time_per_task_s"] = _opt(spatial["time_to_finish_s"])
        row["time_to_start_s"] = _opt(spatial["time_to_start_s"])
        row["failed_tasks"] = _num(spatial["failed_tasks"])
        for c in SPATIAL_CONTACTS:
            row[c] = _opt(spatial.get(c))
    willing = summary["willing_per_type"]
    fewest = min(willing.values())
    scarce = [t for t, n in willing.items() if n == fewest]
    by_type = summary["completion"]["by_type"]
    row["scarce_types"] = ";".join(scarce)
    for prio in ("low", "high"):
        vals = [by_type[t][prio] for t in scarce if not math.isnan(by_type[t][prio])]
        row[f"completion_scarce_{prio}"] = _opt(float(np.mean(vals)) if vals else None)
    faults = summary.get("faults")
    row["abandoned"] = _num(faults["abandoned"]) if faults else ""
    row["requeued"] = _num(faults["requeued"]) if faults else ""
    row["availability"] = _opt(faults["availability"]["mean"]) if faults else ""
    space = summary.get("learning_space")
    if space is not None:
        row["space_initial"] = _num(int(space["initial"]))
        row["space_final"] = _num(int(space["final"]))
        row["space_joint_log10"] = _num(space["joint_log10"])
        kept = sum(len(types) for types in summary["experienced_tasks"].values())
        row["kept_capabilities"] = _num(kept)
    return row


def key_columns(sweep) -> list[str]:
    """The columns that identify a run of ``sweep``."""
    return sweep.key_columns()


def read_rows(path: Path, header: list[str], wanted: set[tuple[str, ...]]) -> dict:
    """Rows of an earlier (possibly interrupted) run of the same sweep, by run key.

    A last line without its newline is an interrupted write and is dropped; anything else that
    does not fit (other columns, a run not in this sweep, a broken line in the middle) is an
    error, so results of another sweep are never mixed in or overwritten.
    """
    if not path.exists():
        return {}
    text = path.read_bytes().decode("utf-8", errors="replace")
    complete = text[: text.rfind("\n") + 1]
    lines = complete.splitlines()
    if not lines:
        return {}
    rows = list(csv.reader(lines))
    if rows[0] != header:
        raise UserError(
            f"{path}: columns {rows[0]} differ from this sweep's {header}; "
            "use another --out folder (or move the file away)"
        )
    n_key = len(header) - len(METRIC_COLUMNS)
    out: dict[tuple[str, ...], list[str]] = {}
    for lineno, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise UserError(f"{path}: line {lineno}: {len(row)} fields, expected {len(header)}")
        key = tuple(row[:n_key])
        if key not in wanted:
            raise UserError(
                f"{path}: line {lineno}: run {','.join(key)} is not part of this sweep; "
                "use another --out folder"
            )
        out.setdefault(key, row)
    return out


def _parse(column: str, text: str, bools: set[str]):
    if text == "":
        return None
    if column in bools:
        return text == "true"
    if column in INT_COLUMNS:
        return int(text)
    try:
        return int(text) if text.lstrip("-").isdigit() else float(text)
    except ValueError:
        return text


def typed_row(row: Sequence[str], sweep) -> dict:
    """A runs.csv row as a dict with numbers, booleans and None (empty cells) parsed."""
    bools = {p for p in sweep.parameters if isinstance(PARAMETERS[p], bool)}
    strings = {p for p in sweep.parameters if isinstance(PARAMETERS[p], str)}
    out = {}
    for column, text in zip(sweep.columns(), row, strict=True):
        if column in ("scenario", "allocator", "cost") or column in strings:
            out[column] = text
        elif column in sweep.parameters and isinstance(PARAMETERS[column], float):
            out[column] = float(text)
        else:
            out[column] = _parse(column, text, bools)
    return out


def mean_ci(values: list) -> tuple[float, float]:
    """(mean, 95% CI half-width) ignoring missing values; -inf (an empty space) stays -inf."""
    arr = [float(v) for v in values if v is not None and not math.isnan(float(v))]
    if not arr:
        return math.nan, math.nan
    if not all(math.isfinite(v) for v in arr):
        return float(np.mean(arr)), math.nan
    return float(np.mean(arr)), ci95(arr)


def json_number(x):
    """JSON has no NaN or infinity: they become null."""
    return None if isinstance(x, float) and not math.isfinite(x) else x


def summarize(sweep, records: list[dict]) -> list[dict]:
    """Mean and 95% CI over seeds of every (scenario, allocator, cost, parameters) group."""
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        key = (r["scenario"], r["allocator"], r["cost"], *(r[p] for p in sweep.parameters))
        groups.setdefault(key, []).append(r)
    out = []
    for key, runs in groups.items():
        entry = dict(zip(["scenario", "allocator", "cost", *sweep.parameters], key, strict=True))
        entry["seeds"] = len(runs)
        for m in SUMMARY_METRICS:
            entry[f"{m}_mean"], entry[f"{m}_ci95"] = mean_ci([r[m] for r in runs])
        out.append(entry)
    return out


def write_outputs(sweep, rows: list[list[str]], out: Path) -> list[dict]:
    """summary.csv, summary.json and the sensitivity plots of finished runs (spec order);
    avoidance.md and avoidance.json too when the sweep varies ``spatial.avoidance`` against
    ``"none"`` (:mod:`scenarios.sweep.avoidance_report`)."""
    records = [typed_row(r, sweep) for r in rows]
    summary = summarize(sweep, records)
    header = list(summary[0])
    write_rows_atomic(
        out / "summary.csv",
        header,
        [[_cell(e[h]) for h in header] for e in summary],
    )
    doc = {
        "sweep": {
            "name": sweep.name,
            "file": sweep.source,
            "sha256": sweep.sha256,
            "scenarios": list(sweep.scenarios),
            "allocators": list(sweep.allocators),
            "costs": list(sweep.costs),
            "seeds": list(sweep.seeds),
            "fixed": dict(sweep.fixed),
            "parameters": list(sweep.parameters),
            "runs": len(records),
        },
        "groups": [{k: json_number(v) for k, v in e.items()} for e in summary],
    }
    write_json_atomic(out / "summary.json", doc)
    for p in sweep.parameters:
        fig_sensitivity(sweep, records, p, out / f"sensitivity_{p}.png")
    write_avoidance_report(records, sweep.parameters, out)
    return summary


def _cell(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return _num(value) if isinstance(value, int | float) else str(value)


def fig_sensitivity(sweep, records: list[dict], parameter: str, path: Path | None = None):
    """Completion and final learning space against one parameter, one line per allocator/cost.

    Points are means over seeds and over the other swept parameters (marginal effect), with 95%
    confidence bars over those runs. Each line carries ``gid = "<metric>:<label>"``.
    """
    from scenarios.experiments.figures import (
        ALLOCATOR_LABELS,
        allocator_colour,
        new_figure,
        save_figure,
    )

    xs = sorted({r[parameter] for r in records})
    numeric = all(isinstance(x, int | float) and not isinstance(x, bool) for x in xs)
    pos = {x: (float(x) if numeric else float(i)) for i, x in enumerate(xs)}
    fig = new_figure(4.0 * len(PANELS), 3.6)
    axes = fig.subplots(1, len(PANELS))
    lines = [(s, a, c) for s in sweep.scenarios for a in sweep.allocators for c in sweep.costs]
    for k, (s, a, c) in enumerate(lines):
        label = ALLOCATOR_LABELS.get(a, a)
        label += f" / {c}" if len(sweep.costs) > 1 else ""
        label += f" / {s}" if len(sweep.scenarios) > 1 else ""
        mine = [r for r in records if (r["scenario"], r["allocator"], r["cost"]) == (s, a, c)]
        for ax, (metric, _) in zip(axes, PANELS, strict=True):
            stats = [mean_ci([r[metric] for r in mine if r[parameter] == x]) for x in xs]
            mean = np.array([m for m, _ in stats])
            if np.isnan(mean).all():
                continue
            half = np.nan_to_num(np.array([h for _, h in stats]))
            ax.errorbar(
                [pos[x] for x in xs], mean, yerr=half, marker="o", capsize=3,
                color=allocator_colour(a, k), linestyle=LINESTYLES[sweep.costs.index(c) % 4],
                label=label, gid=f"{metric}:{label}",
            )  # fmt: skip
    for ax, (_, title) in zip(axes, PANELS, strict=True):
        ax.set_title(title)
        ax.set_xlabel(parameter)
        if not numeric:
            ax.set_xticks([pos[x] for x in xs], [_cell(x) for x in xs])
    axes[0].set_ylabel("completion ratio (test sets)")
    axes[-1].set_ylabel("sum over robots of |S| x |A|")
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        axes[0].legend(handles, labels, loc="best")
    fig.suptitle(f"sweep {sweep.name}: sensitivity to {parameter} (mean ± 95% CI)")
    save_figure(fig, path)
    return fig
