"""``mrta reproduce``: the paper protocol for all allocators over seeds, with figures and tables."""

from __future__ import annotations

from pathlib import Path

from learning.qtable import space_size
from learning.registry import PAPER_ALLOCATORS
from scenarios.experiments.budget import check_work
from scenarios.experiments.figures import fig_completion, fig_robot_trace, fig_tradeoff
from scenarios.experiments.manifest import build_manifest, write_manifest
from scenarios.experiments.metrics import aggregate
from scenarios.experiments.outdir import check_out_dir, staged_folder
from scenarios.experiments.output import write_json_atomic
from scenarios.experiments.protocol import (
    RunSpec,
    UserError,
    check_cost,
    default_workers,
    load_named,
    run_many,
)
from scenarios.experiments.reference import PAPER_TABLE2
from sim.scenario import did_you_mean
from sim.scenario.overrides import apply_overrides

DEFAULT_DELTA_U_GRID = (0.02, 0.03, 0.05, 0.08, 0.1, 0.2, 0.3, 0.5)
SPATIAL_DELTA_U_GRID = (0.02, 0.3)  # physics runs cost ~100x more: a short curve by default


def reproduce(
    scenario: str,
    seeds: list[int],
    out: Path,
    cost: str = "abstract",
    workers: int | None = None,
    delta_u_grid: tuple[float, ...] = DEFAULT_DELTA_U_GRID,
    trace_robot: str = "R5",
    progress: bool = True,
    extra_allocators: tuple[str, ...] = (),
    overrides: tuple[tuple[str, object], ...] = (),
) -> dict:
    """Run market, QL-MRTA and ExpT-MRTA (plus the delta_u trade-off) and write all outputs.

    ``extra_allocators`` (e.g. ``("greedy", "cbba")`` or ``"mypkg.alloc:Mine"``) are run on the
    same streams and appear in metrics.json and fig1 beside the paper's three. ``overrides``
    (``(("spatial.avoidance", "none"),)``) apply to every run. ``out`` is written as a whole
    (:mod:`scenarios.experiments.outdir`): an interrupted run leaves it as it was.

    Raises:
        UserError: ``trace_robot`` names no robot of the scenario; the work cannot run here.
        OutputError: ``out`` cannot be written (checked before any run).
    """
    out = check_out_dir(out)
    sc = apply_overrides(load_named(scenario), overrides)
    check_cost(sc, cost)
    names = [r.name for r in sc.robots]
    if trace_robot not in names:
        hint = did_you_mean(trace_robot, names)
        raise UserError(f"--robot {trace_robot!r}: no such robot in {sc.name!r}{hint}")
    allocs = list(PAPER_ALLOCATORS) + [a for a in extra_allocators if a not in PAPER_ALLOCATORS]
    specs = [
        RunSpec(
            scenario,
            a,
            cost,
            s,
            overrides,
            trace_robot=trace_robot if (a == "expt" and s == seeds[0]) else "",
        )
        for a in allocs
        for s in seeds
    ]
    grid = [du for du in delta_u_grid if du != sc.experience.delta_u]
    specs += [
        RunSpec(scenario, "expt", cost, s, (*overrides, ("experience.delta_u", du)))
        for du in grid
        for s in seeds
    ]
    workers = default_workers() if workers is None else workers
    check_work(sc, len(specs), min(workers, len(specs)))
    with staged_folder(out) as stage:
        metrics = _reproduce_into(stage, sc, seeds, cost, specs, allocs, grid, workers, progress)
    return metrics


def _reproduce_into(stage, sc, seeds, cost, specs, allocs, grid, workers, progress) -> dict:
    """Run ``specs`` and write reproduce's files into ``stage``; returns metrics.json's doc."""
    results = run_many(specs, workers=workers, progress=progress, desc=f"reproduce {sc.name}")
    by_alloc = {a: results[k * len(seeds) : (k + 1) * len(seeds)] for k, a in enumerate(allocs)}
    metrics = {
        "scenario": sc.name,
        "cost_model": cost,
        "seeds": list(seeds),
        "scenario_sha256": sc.source_sha256,
        "allocators": {a: aggregate(runs) for a, runs in by_alloc.items()},
    }
    tradeoff_runs = {sc.experience.delta_u: by_alloc["expt"]}
    for k, du in enumerate(grid):
        start = len(allocs) * len(seeds) + k * len(seeds)
        tradeoff_runs[du] = results[start : start + len(seeds)]
    points = [tradeoff_point(du, aggregate(runs)) for du, runs in sorted(tradeoff_runs.items())]
    metrics["tradeoff"] = {"parameter": "experience.delta_u", "points": points}
    out = Path(stage)
    write_manifest(out, build_manifest(sc, specs))
    write_json_atomic(out / "metrics.json", metrics)
    fig_completion(metrics, out / "fig1_completion.png")
    trace = next((r["trace"] for r in by_alloc["expt"] if "trace" in r), None)
    if trace is not None:
        fig_robot_trace(trace, out / "fig2_r5.png")
    if grid:
        refs = {a: tradeoff_point(None, metrics["allocators"][a]) for a in allocs if a != "expt"}
        fig_tradeoff(points, refs, out / "tradeoff.png")
    (out / "table2.md").write_text(table2_markdown(sc, metrics["allocators"]["expt"]))
    return metrics


def tradeoff_point(delta_u: float | None, agg: dict) -> dict:
    """One point of tradeoff.png: final learning space and completion (with CIs) of a run group."""
    comp = agg["completion"]
    space = agg.get("learning_space", {})
    return {
        "delta_u": delta_u,
        "space": space.get("final"),
        "space_ci95": space.get("final_ci95"),
        **{p: comp["overall"][p] for p in ("low", "high", "all")},
        **{f"{p}_ci95": comp["ci95"]["overall"][p] for p in ("low", "high", "all")},
    }


def table2_markdown(sc, expt: dict) -> str:
    """Experienced tasks after ExpT-MRTA (paper Table 2) beside the capabilities (Table 1)."""
    h = sc.learning.history
    types = list(sc.task_types)
    share = expt["experienced_tasks_share"]
    lines = [
        f"# Experienced tasks after ExpT-MRTA ({sc.name})",
        "",
        "`+` capable (Table 1); `E` still done at the end of the first seed (our Table 2);",
        "`x` refused; the number is the share of seeds in which the robot kept the task.",
        "",
        "| Robot | " + " | ".join(types) + " | space initial | space final |",
        "|---" * (len(types) + 3) + "|",
    ]
    final = expt["experienced_tasks"]
    total0 = total1 = 0
    for r in sc.robots:
        caps = [types[i] for i in r.capabilities]
        cells = []
        for t in types:
            if t not in caps:
                cells.append("")
            else:
                mark = "E" if t in final[r.name] else "x"
                cells.append(f"+ {mark} {share[r.name][t]:.0%}")
        s0, s1 = space_size(len(caps), h), space_size(len(final[r.name]), h)
        total0, total1 = total0 + s0, total1 + s1
        lines.append(f"| {r.name} | " + " | ".join(cells) + f" | {s0} | {s1} |")
    lines.append("| total | " + " | " * len(types) + f"{total0} | {total1} |")
    if sc.n_types == 8 and [r.name for r in sc.robots] == list(PAPER_TABLE2):
        paper = sum(space_size(len(v), h) for v in PAPER_TABLE2.values())
        lines += [
            "",
            f"Paper Table 2 for reference (learning space {paper}; ours, first seed: {total1}; "
            f"mean over seeds: {expt['learning_space']['final']:.0f}):",
            "",
            "| Robot | " + " | ".join(types) + " |",
            "|---" * (len(types) + 1) + "|",
        ]
        for name, kept in PAPER_TABLE2.items():
            lines.append(
                f"| {name} | " + " | ".join("+" if t in kept else "" for t in types) + " |"
            )
    return "\n".join(lines) + "\n"


def summary_table(metrics: dict) -> str:
    """The printed summary: completion low/high/all (CI95) and learning space per allocator."""
    head = ["low", "high", "all", "space initial", "space final"]
    rows = [f"{'allocator':<10} " + " ".join(f"{h:>14}" for h in head)]
    for name, agg in metrics["allocators"].items():
        comp, ci = agg["completion"]["overall"], agg["completion"]["ci95"]["overall"]
        cells = [f"{comp[p]:.3f} ± {ci[p]:.3f}" for p in ("low", "high", "all")]
        space = agg.get("learning_space")
        s0 = f"{space['initial']}" if space else "-"
        s1 = f"{space['final']:.0f} ± {space['final_ci95']:.0f}" if space else "-"
        rows.append(f"{name:<10} {cells[0]:>14} {cells[1]:>14} {cells[2]:>14} {s0:>14} {s1:>14}")
    return "\n".join(rows)


__all__ = [
    "DEFAULT_DELTA_U_GRID",
    "SPATIAL_DELTA_U_GRID",
    "reproduce",
    "summary_table",
    "table2_markdown",
    "tradeoff_point",
]
