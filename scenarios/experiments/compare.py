"""``mrta compare``: cost models x allocators on the same seeded streams, side by side."""

from __future__ import annotations

import math
from pathlib import Path

from scenarios.experiments.budget import check_work
from scenarios.experiments.figures import STYLE, allocator_bars, new_figure, save_figure
from scenarios.experiments.metrics import aggregate
from scenarios.experiments.outdir import check_out_dir, staged_folder
from scenarios.experiments.output import write_json_atomic
from scenarios.experiments.protocol import (
    RunSpec,
    check_cost,
    default_workers,
    load_named,
    run_many,
)
from sim.scenario.overrides import apply_overrides

COLUMNS = (
    ("low", "completion low", "{:.3f}"),
    ("high", "completion high", "{:.3f}"),
    ("all", "completion all", "{:.3f}"),
    ("distance_m", "distance driven [m]", "{:.0f}"),
    ("distance_per_task_m", "distance per task [m]", "{:.2f}"),
    ("time_to_finish_s", "time per task [s]", "{:.2f}"),
    ("high_wait_s", "high-prio wait [s]", "{:.2f}"),
    ("space", "learning space", "{:.0f}"),
)


def compare(
    scenario: str,
    costs: list[str],
    allocators: list[str],
    seeds: list[int],
    out: Path,
    workers: int | None = None,
    progress: bool = True,
    overrides: tuple[tuple[str, float], ...] = (),
) -> dict:
    """Run every (cost, allocator, seed), write compare.json, compare.md and compare.png into
    ``out``, as a whole (:mod:`scenarios.experiments.outdir`)."""
    out = check_out_dir(out)
    sc = apply_overrides(load_named(scenario), overrides)
    for cost in costs:
        check_cost(sc, cost)
    combos = [(c, a) for c in costs for a in allocators]
    specs = [RunSpec(scenario, a, c, s, overrides) for c, a in combos for s in seeds]
    workers = default_workers() if workers is None else workers
    check_work(sc, len(specs), min(workers, len(specs)))
    with staged_folder(out) as stage:
        return _compare_into(stage, sc, seeds, combos, specs, workers, progress)


def _compare_into(stage: Path, sc, seeds, combos, specs, workers, progress) -> dict:
    """Run ``specs`` and write compare's files into ``stage``; returns compare.json's doc."""
    results = run_many(specs, workers=workers, progress=progress, desc=f"compare {sc.name}")
    n = len(seeds)
    table = {}
    for k, (cost, alloc) in enumerate(combos):
        agg = aggregate(results[k * n : (k + 1) * n])
        table[f"{cost}/{alloc}"] = {"cost": cost, "allocator": alloc, **_row(agg)}
    doc = {"scenario": sc.name, "seeds": list(seeds), "rows": table}
    out = Path(stage)
    write_json_atomic(out / "compare.json", doc)
    (out / "compare.md").write_text(markdown_table(doc) + "\n")
    fig_compare(doc, out / "compare.png")
    return doc


def _row(agg: dict) -> dict:
    comp, ci = agg["completion"]["overall"], agg["completion"]["ci95"]["overall"]
    row = {p: comp[p] for p in ("low", "high", "all")}
    row.update({f"{p}_ci95": ci[p] for p in ("low", "high", "all")})
    spatial = agg.get("spatial", {})
    for key in (
        "distance_m",
        "distance_per_task_m",
        "high_wait_s",
        "time_to_finish_s",
        "estimate_abs_error",
        "max_overlap_m",
    ):
        row[key] = spatial.get(key, float("nan"))
        row[f"{key}_ci95"] = spatial.get("ci95", {}).get(key, float("nan"))
    space = agg.get("learning_space")
    row["space"] = space["final"] if space else float("nan")
    row["space_ci95"] = space["final_ci95"] if space else float("nan")
    return row


def markdown_table(doc: dict) -> str:
    head = "| cost | allocator | " + " | ".join(label for _, label, _ in COLUMNS) + " |"
    lines = [head, "|---|---|" + "---|" * len(COLUMNS)]
    for row in doc["rows"].values():
        cells = []
        for key, _, fmt in COLUMNS:
            value, half = row[key], row.get(f"{key}_ci95", float("nan"))
            if isinstance(value, float) and math.isnan(value):
                cells.append("–")
            elif isinstance(half, float) and not math.isnan(half):
                cells.append(f"{fmt.format(value)} ± {fmt.format(half)}")
            else:
                cells.append(fmt.format(value))
        lines.append(f"| {row['cost']} | {row['allocator']} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def fig_compare(doc: dict, path: Path | None = None):
    """Six panels: completion (high, low, all), distance, high-priority waiting, learning space."""
    import matplotlib as mpl
    import numpy as np

    rows = list(doc["rows"].values())
    costs = list(dict.fromkeys(r["cost"] for r in rows))
    allocs = list(dict.fromkeys(r["allocator"] for r in rows))
    panels = (
        ("high", "completion ratio, high priority"),
        ("low", "completion ratio, low priority"),
        ("all", "completion ratio, all tasks"),
        ("distance_m", "distance driven, test sets [m]"),
        ("high_wait_s", "wait of high-priority tasks [s]"),
        ("space", "final learning space |S| x |A|"),
    )
    with mpl.rc_context(STYLE):
        fig = new_figure(12.0, 6.6)
        axes = fig.subplots(2, 3).ravel()
        x = np.arange(len(costs))
        for ax, (key, title) in zip(axes, panels, strict=True):
            series = [
                (
                    alloc,
                    [doc["rows"][f"{c}/{alloc}"][key] for c in costs],
                    [doc["rows"][f"{c}/{alloc}"][f"{key}_ci95"] for c in costs],
                    [f"{key}|{c}|{alloc}" for c in costs],
                )
                for alloc in allocs
            ]
            allocator_bars(ax, x, series)
            ax.set_xticks(x, [f"{c} cost" for c in costs])
            ax.set_title(title)
            ax.grid(axis="y", alpha=0.3)
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncols=len(allocs), frameon=False)
        fig.suptitle(f"{doc['scenario']}: cost models compared ({len(doc['seeds'])} seeds, 95% CI)")
    save_figure(fig, path)
    return fig
