"""Running a sweep (``scenarios.sweep.runner``): local and Dask runners agree, resume,
summaries, the sensitivity plot, foreign results."""

from __future__ import annotations

import csv
import json
import sys

import numpy as np
import pytest

import scenarios.sweep.runner as sweep_runner
from scenarios.experiments.metrics import ci95
from scenarios.loader import bundled_names
from scenarios.protocol import UserError
from scenarios.sweep import load_sweep, run_sweep
from tests.worlds import ABSTRACT_SWEEP


@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    """The abstract sweep run once on local processes: (rows, output folder)."""
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "abstract.toml").write_text(ABSTRACT_SWEEP)
    rows = run_sweep(folder / "abstract.toml", folder / "local", workers=2, progress=False)
    return rows, folder


def test_local_rows_behave(local_run):
    rows, _ = local_run
    assert len(rows) == 30
    ql = {(r["seed"], r["experience.delta_u"]): r for r in rows if r["allocator"] == "ql"}
    expt = [r for r in rows if r["allocator"] == "expt"]
    for seed in range(5):  # QL-MRTA ignores delta_u: the same run three times
        a, b = ql[(seed, 0.05)], ql[(seed, 0.5)]
        assert a["completion_all"] == b["completion_all"] and a["space_final"] == 3498
    space = {du: np.mean([r["space_final"] for r in expt if r["experience.delta_u"] == du])
             for du in (0.05, 0.3, 0.5)}  # fmt: skip
    assert space[0.5] < space[0.05] <= 3498  # a higher refusal threshold shrinks the space
    for r in rows:
        assert r["tasks_allocated"] <= r["tasks_announced"]
        assert r["completion_all"] == pytest.approx(r["tasks_allocated"] / r["tasks_announced"])


def test_summary_holds_means_and_ci95_per_combination(local_run):
    rows, folder = local_run
    doc = json.loads((folder / "local" / "summary.json").read_text())
    assert len(doc["groups"]) == 6 and doc["sweep"]["runs"] == 30
    g = next(
        g for g in doc["groups"] if g["allocator"] == "expt" and g["experience.delta_u"] == 0.3
    )
    values = [r["completion_high"] for r in rows if r["allocator"] == "expt"
              and r["experience.delta_u"] == 0.3]  # fmt: skip
    assert g["seeds"] == 5
    assert g["completion_high_mean"] == pytest.approx(np.mean(values))
    assert g["completion_high_ci95"] == pytest.approx(ci95(values))
    with (folder / "local" / "summary.csv").open() as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 6 and float(table[0]["completion_all_mean"]) > 0
    assert (folder / "local" / "sensitivity_experience.delta_u.png").stat().st_size > 10_000


def test_sensitivity_plot_draws_the_summary(local_run):
    from scenarios.sweep.report import fig_sensitivity

    rows, folder = local_run
    sw = load_sweep(folder / "abstract.toml")
    fig = fig_sensitivity(sw, rows, "experience.delta_u")
    lines = {a.get_gid(): a for ax in fig.axes for a in ax.get_children() if a.get_gid()}
    assert "completion_all:ExpT-MRTA" in lines and "space_final:QL-MRTA" in lines


@pytest.mark.slow
def test_dask_cluster_gives_identical_rows(local_run):
    distributed = pytest.importorskip("distributed")
    rows, folder = local_run
    with distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None
    ) as cluster:
        remote = run_sweep(
            folder / "abstract.toml",
            folder / "dask",
            scheduler=cluster.scheduler_address,
            progress=False,
        )
    assert remote == rows
    assert (folder / "dask" / "runs.csv").read_bytes() == (
        folder / "local" / "runs.csv"
    ).read_bytes()


def test_resume_runs_only_what_is_missing(local_run, tmp_path, monkeypatch):
    rows, folder = local_run
    full = (folder / "local" / "runs.csv").read_text()
    lines = full.splitlines(keepends=True)
    kept = lines[: 1 + 15]
    out = tmp_path / "resumed"
    out.mkdir()
    (out / "runs.csv").write_text("".join(kept) + lines[16][:25])  # half + a torn last line
    calls = []
    real = sweep_runner.run_metrics

    def counting(spec):
        calls.append(spec)
        return real(spec)

    monkeypatch.setattr(sweep_runner, "run_metrics", counting)
    again = run_sweep(folder / "abstract.toml", out, workers=1, progress=False)
    assert len(calls) == 15
    assert {(c.allocator, c.seed) for c in calls} == {("expt", s) for s in range(5)}
    assert (out / "runs.csv").read_text() == full
    assert again == rows
    calls.clear()
    run_sweep(folder / "abstract.toml", out, workers=1, progress=False)
    assert calls == []  # everything done: nothing runs


def test_foreign_results_are_never_mixed_in(local_run, tmp_path):
    _, folder = local_run
    other = tmp_path / "other.toml"
    other.write_text(ABSTRACT_SWEEP.replace("[0.05, 0.3, 0.5]", "[0.05, 0.3]"))
    with pytest.raises(UserError, match="not part of this sweep"):
        run_sweep(other, folder / "local", workers=1, progress=False)
    columns = tmp_path / "columns.toml"
    text = ABSTRACT_SWEEP.replace('"experience.n_min" = 3\n', "")
    grid = '"experience.delta_u" = [0.05, 0.3, 0.5]'
    columns.write_text(text.replace(grid, '"learning.history" = [3]'))
    with pytest.raises(UserError, match="columns"):
        run_sweep(columns, folder / "local", workers=1, progress=False)


@pytest.mark.slow
@pytest.mark.skipif(
    "paper_spatial" not in bundled_names(),
    reason="scenarios/data/paper_spatial.toml (spatial costs) is not in this checkout yet",
)
def test_spatial_sweep_over_cost_models(tmp_path):
    path = tmp_path / "spatial.toml"
    path.write_text(
        '[sweep]\nscenarios = ["paper_spatial"]\nallocators = ["expt"]\n'
        'costs = ["abstract", "time"]\nseeds = 2\n'
        '[fixed]\n"stream.n_sets" = 2\n"stream.rounds_per_set" = 3\n'
        '"stream.learn_sets" = 1\n"stream.test_sets" = 1\n'
        '[grid]\n"experience.delta_u" = [0.05, 0.3, 0.5]\n'
    )
    rows = run_sweep(path, tmp_path / "out", workers=2, progress=False)
    assert len(rows) == 3 * 2 * 2
    assert [r["cost"] for r in rows[::6]] == ["abstract", "time"]
    assert all(0.0 <= r["completion_all"] <= 1.0 for r in rows)


def test_missing_dask_is_one_clear_line(abstract_file, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(UserError, match=r"pip install 'expt-mrta\[cluster\]'"):
        run_sweep(abstract_file, tmp_path / "out", scheduler="tcp://127.0.0.1:1", progress=False)
    assert not (tmp_path / "out").exists()
