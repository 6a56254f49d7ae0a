"""``mrta study faults``: completion against the robots' mean time to failure (issue 17, part 5).

One bundled sweep, ``faults`` (``scenarios/data/sweeps/faults.toml``): every allocator on the
same streams, with robots that break after an exponential time of mean ``faults.mttf_s``
(``inf``: never, the reference) and are repaired after 60 s. Read per allocator:

- completion (all tasks, high-priority tasks) against MTTF, mean and 95% CI over seeds;
- the relative loss against no faults, paired by seed: ``1 - c(MTTF) / c(inf)`` (same stream,
  same allocator, only the faults differ);
- the same for the *scarce* types: those with the fewest willing robots at the end of the run.
  For ExpT-MRTA these are the types most robots refused, left to the specialists that kept them;
  if experience made the fleet fragile, its scarce types would lose more than the market's or
  QL-MRTA's when robots break.

Outputs: ``study.json`` (strict JSON), ``study.md`` (the README's table) and ``faults.png``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from scenarios.experiments.metrics import ci95
from scenarios.experiments.output import write_json_atomic
from scenarios.sweep.runner import run_sweep

PART = "faults"
MTTF = "faults.mttf_s"
METRICS = ("completion_all", "completion_high", "completion_scarce_high", "availability")
LOSSES = ("completion_all", "completion_high", "completion_scarce_high")
ORDER = ("market", "ql", "expt", "greedy", "cbba")
LABELS = {"market": "market", "ql": "QL-MRTA", "expt": "ExpT-MRTA", "greedy": "greedy",
          "cbba": "CBBA"}  # fmt: skip


def _stat(values) -> dict:
    vals = [float(v) for v in values if v is not None and not math.isnan(float(v))]
    if not vals:
        return {"mean": None, "ci95": None}
    half = ci95(vals)
    return {"mean": float(np.mean(vals)), "ci95": None if math.isnan(half) else half}


def analyse(rows: list[dict]) -> dict:
    """Per allocator and MTTF: means and CIs of :data:`METRICS`, and the paired relative loss
    of :data:`LOSSES` against the same allocator and seed without faults."""
    allocators = [a for a in ORDER if any(r["allocator"] == a for r in rows)]
    allocators += sorted({r["allocator"] for r in rows} - set(allocators))
    mttfs = sorted({float(r[MTTF]) for r in rows}, reverse=True)  # inf (no faults) first
    base = {(r["allocator"], r["seed"]): r for r in rows if math.isinf(float(r[MTTF]))}
    table = []
    for a in allocators:
        for mttf in mttfs:
            runs = [r for r in rows if r["allocator"] == a and float(r[MTTF]) == mttf]
            if not runs:
                continue
            entry = {"allocator": a, "mttf_s": None if math.isinf(mttf) else mttf,
                     "seeds": len(runs)}  # fmt: skip
            for m in METRICS:
                entry[m] = _stat([r[m] for r in runs])
            for m in LOSSES:
                losses = []
                for r in runs:
                    ref = base.get((a, r["seed"]))
                    if ref is not None and ref[m] and r[m] is not None:
                        losses.append(1.0 - r[m] / ref[m])
                entry[f"loss_{m}"] = _stat(losses)
            entry["abandoned"] = _stat([r["abandoned"] for r in runs])
            entry["scarce_types"] = sorted({r["scarce_types"] for r in runs})
            table.append(entry)
    return {"sweep": PART, "mttf_s": [None if math.isinf(m) else m for m in mttfs],
            "table": table}  # fmt: skip


def _cell(stat: dict, pct: bool = False) -> str:
    if stat["mean"] is None:
        return "–"
    k = 100.0 if pct else 1.0
    ci = f" ± {stat['ci95'] * k:.1f}" if stat["ci95"] is not None and pct else ""
    ci = f" ± {stat['ci95']:.3f}" if stat["ci95"] is not None and not pct else ci
    return f"{stat['mean'] * k:.1f}{ci}" if pct else f"{stat['mean']:.3f}{ci}"


def markdown(doc: dict) -> str:
    """The study's table: completion and relative loss per allocator and MTTF."""
    lines = [
        "| allocator | MTTF (s) | availability | completion, all | completion, high | "
        "loss all (%) | loss high (%) | loss scarce-type high (%) | abandoned / run |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for e in doc["table"]:
        mttf = "∞" if e["mttf_s"] is None else f"{e['mttf_s']:g}"
        lines.append(
            f"| {LABELS.get(e['allocator'], e['allocator'])} | {mttf} | "
            f"{_cell(e['availability'])} | {_cell(e['completion_all'])} | "
            f"{_cell(e['completion_high'])} | {_cell(e['loss_completion_all'], True)} | "
            f"{_cell(e['loss_completion_high'], True)} | "
            f"{_cell(e['loss_completion_scarce_high'], True)} | "
            f"{'–' if e['abandoned']['mean'] is None else format(e['abandoned']['mean'], '.0f')} |"
        )
    return "\n".join(lines)


def fig_faults(doc: dict, path: Path | None = None):
    """Completion (a) and relative loss against no faults (b: all tasks, c: the scarce types'
    high-priority tasks) against MTTF; no faults (MTTF = inf) drawn at the right edge."""
    from scenarios.experiments.figures import new_figure, save_figure

    finite = [m for m in doc["mttf_s"] if m is not None]
    inf_x = max(finite) * 2.0 if finite else 1.0
    fig = new_figure(13.5, 4.2)
    axes = fig.subplots(1, 3)
    panels = (
        ("completion_all", "(a) completion, all tasks", "completion ratio (test sets)", 1.0),
        ("loss_completion_all", "(b) loss against no faults, all tasks", "loss (%)", 100.0),
        ("loss_completion_scarce_high", "(c) loss, high tasks of the scarce types", "loss (%)",
         100.0),
    )  # fmt: skip
    allocators = list(dict.fromkeys(e["allocator"] for e in doc["table"]))
    for ax, (metric, title, ylabel, k) in zip(axes, panels, strict=True):
        for n, a in enumerate(allocators):
            pts = [e for e in doc["table"] if e["allocator"] == a and e[metric]["mean"] is not None]
            x = [inf_x if e["mttf_s"] is None else e["mttf_s"] for e in pts]
            y = [e[metric]["mean"] * k for e in pts]
            err = [(e[metric]["ci95"] or 0.0) * k for e in pts]
            ax.errorbar(x, y, yerr=err, marker="o", capsize=3, color=f"C{n}",
                        label=LABELS.get(a, a), gid=f"{metric}:{a}")  # fmt: skip
        ax.set_xscale("log")
        ticks = [*finite, inf_x]
        ax.set_xticks(ticks)
        ax.set_xticklabels([f"{t:g}" for t in finite] + ["∞"])
        ax.minorticks_off()
        ax.set_title(title)
        ax.set_xlabel("mean time to failure per robot (s); ∞: no faults")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    axes[0].legend(loc="lower right")
    fig.suptitle(
        "Robot faults: exponential time to failure, 60 s repair, task re-announced "
        "(paper scenario, mean and 95% CI over seeds; loss paired by seed)"
    )
    save_figure(fig, path)
    return fig


def run_fault_study(
    out: Path,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
) -> dict:
    """Run (or resume) the ``faults`` sweep into ``out/faults/``; write the study's outputs."""
    out = Path(out)
    rows = run_sweep(PART, out / PART, workers, scheduler, progress)
    doc = analyse(rows)
    write_json_atomic(out / "study.json", doc)
    tmp = out / ".study.md.tmp"
    tmp.write_text(markdown(doc) + "\n")
    tmp.replace(out / "study.md")
    fig_faults(doc, out / "faults.png")
    return doc
