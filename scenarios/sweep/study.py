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
quotes), ``load.png``, ``losses.png``, ``frontier.png`` and ``spatial.png``. The tables are
computed in :mod:`scenarios.sweep.study_analysis`, the figures drawn in
:mod:`scenarios.sweep.study_figures`.
"""

from __future__ import annotations

from pathlib import Path

from scenarios.experiments.output import write_json_atomic
from scenarios.sweep.runner import run_sweep
from scenarios.sweep.study_analysis import PARTS, analyse, markdown
from scenarios.sweep.study_figures import fig_frontier, fig_load, fig_losses, fig_spatial

STUDIES = {"refusal": PARTS, "faults": ("faults",)}  # name -> its sweep files (bundled names)


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
