"""``mrta sweep``: expansion, local and Dask runners agree, resume, summaries, bad files."""

from __future__ import annotations

import argparse
import csv
import json
import sys

import numpy as np
import pytest

import scenarios.sweep.runner as sweep_runner
from scenarios.cli.commands import cmd_sweep
from scenarios.cli.parser import add_sweep_parser
from scenarios.experiments.metrics import ci95
from scenarios.loader import ScenarioError, bundled_names
from scenarios.protocol import UserError
from scenarios.sweep import load_sweep, run_sweep
from scenarios.sweep.spec import bundled_sweeps

SHORT = """
[fixed]
"stream.n_sets" = 6
"stream.rounds_per_set" = 6
"stream.learn_sets" = 4
"stream.test_sets" = 3
"experience.n_min" = 3
"""

ABSTRACT = (
    """
[sweep]
name = "abstract"
scenarios = ["paper"]
allocators = ["ql", "expt"]
seeds = 5
"""
    + SHORT
    + """
[grid]
"experience.delta_u" = [0.05, 0.3, 0.5]
"""
)


@pytest.fixture()
def abstract_file(tmp_path):
    path = tmp_path / "abstract.toml"
    path.write_text(ABSTRACT)
    return path


@pytest.fixture(scope="module")
def local_run(tmp_path_factory):
    """The abstract sweep run once on local processes: (rows, output folder)."""
    folder = tmp_path_factory.mktemp("sweep")
    (folder / "abstract.toml").write_text(ABSTRACT)
    rows = run_sweep(folder / "abstract.toml", folder / "local", workers=2, progress=False)
    return rows, folder


def test_expansion_is_every_combination_in_spec_order(abstract_file):
    sw = load_sweep(abstract_file)
    assert len(sw.runs) == 3 * 2 * 5
    assert sw.parameters == ("experience.delta_u",)
    first = sw.runs[0].spec
    assert (first.scenario, first.allocator, first.cost) == ("paper", "ql", "abstract")
    assert first.seed == 0
    assert dict(first.overrides)["stream.n_sets"] == 6
    keys = [sw.key(r) for r in sw.runs]
    assert len(set(keys)) == len(keys)
    assert [k[1] for k in keys[:15]] == ["ql"] * 15 and keys[5][4] == "0.3"


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
    other.write_text(ABSTRACT.replace("[0.05, 0.3, 0.5]", "[0.05, 0.3]"))
    with pytest.raises(UserError, match="not part of this sweep"):
        run_sweep(other, folder / "local", workers=1, progress=False)
    columns = tmp_path / "columns.toml"
    text = ABSTRACT.replace('"experience.n_min" = 3\n', "")
    grid = '"experience.delta_u" = [0.05, 0.3, 0.5]'
    columns.write_text(text.replace(grid, '"learning.history" = [3]'))
    with pytest.raises(UserError, match="columns"):
        run_sweep(columns, folder / "local", workers=1, progress=False)


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


BAD = [
    ("[sweep]\n", "[grd]\n", "grd: unknown key (did you mean 'grid'?)"),
    ("allocators =", "alocators =", "sweep.alocators: unknown key (did you mean 'allocators'?)"),
    (
        '"experience.delta_u" = [',
        '"experience.delta_uu" = [',
        "grid.experience.delta_uu: unknown parameter (did you mean 'experience.delta_u'?)",
    ),
    (
        '"experience.delta_u" = [',
        '"experiance.delta_u" = [',
        "grid.experiance.delta_u: unknown parameter (did you mean 'experience.delta_u'?)",
    ),
    ('"expt"]', '"exptt"]', "sweep.allocators[1]: unknown allocator 'exptt' (did you mean"),
    ("[0.05, 0.3, 0.5]", "[0.05, 5.0]", "grid.experience.delta_u: must be in [0, 2]"),
    ('n_min" = 3', 'n_min" = 2.5', "fixed.experience.n_min: must be an integer"),
    ("seeds = 5", "seeds = 0", "sweep.seeds: need at least one seed"),
    ("seeds = 5", 'seeds = 5\ncosts = ["distance"]', "sweep.costs[0]: cost model 'distance' needs"),
    ('["paper"]', '["papr"]', "did you mean 'paper'?"),
    (
        '"stream.learn_sets" = 4\n',
        "",
        "fixed: makes scenario 'paper' invalid: stream.learn_sets: must be in 1..n_sets (6)",
    ),
    ("[0.05, 0.3, 0.5]", "[0.3, 0.3]", "grid.experience.delta_u: lists a value twice"),
    ("[0.05, 0.3, 0.5]", "[]", "grid.experience.delta_u: must be a non-empty list"),
    (
        '"experience.n_min" = 3\n',
        '"experience.n_min" = 3\n[[points]]\n"learning.history" = 2\n',
        "points: use either [grid] or [[points]], not both",
    ),
    ("seeds = 5", "seeds = 5 5", "TOML syntax error"),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_bad_sweep_files_fail_in_one_line(tmp_path, old, new, message):
    assert old in ABSTRACT
    path = tmp_path / "bad.toml"
    path.write_text(ABSTRACT.replace(old, new, 1))
    with pytest.raises((ScenarioError, UserError)) as info:
        run_sweep(path, tmp_path / "out", workers=1, progress=False)
    text = str(info.value)
    assert message in text
    assert text.startswith(str(path)) and "\n" not in text
    assert not (tmp_path / "out").exists()  # nothing was written


def test_missing_dask_is_one_clear_line(abstract_file, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(UserError, match=r"pip install 'expt-mrta\[cluster\]'"):
        run_sweep(abstract_file, tmp_path / "out", scheduler="tcp://127.0.0.1:1", progress=False)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("name", bundled_sweeps())
def test_bundled_example_sweeps_validate(name):
    try:
        sw = load_sweep(name)
    except ScenarioError as exc:
        if "paper_spatial" in str(exc) and "paper_spatial" not in bundled_names():
            pytest.skip("paper_spatial scenario not in this checkout yet")
        raise
    assert sw.runs and sw.parameters


def test_cli_entry_points(abstract_file, tmp_path, capsys):
    parser = argparse.ArgumentParser(prog="mrta")
    add_sweep_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(
        ["sweep", str(abstract_file), "--out", str(tmp_path / "cli"), "--workers", "2",
         "--no-progress"]
    )  # fmt: skip
    assert cmd_sweep(args) == 0
    out = capsys.readouterr().out
    assert "30 runs (6 combinations x 5 seeds)" in out
    assert (tmp_path / "cli" / "runs.csv").read_text().count("\n") == 31


def test_a_sweep_over_avoidance_writes_the_before_and_after_report(tmp_path, capsys):
    """`mrta sweep` with spatial.avoidance none and orca in its grid writes avoidance.md and
    avoidance.json (scenarios.sweep.avoidance_report) and says so; their rows are the runs'."""
    from scenarios.cli.app import main

    path = tmp_path / "avoid.toml"
    path.write_text(
        '[sweep]\nscenarios = ["paper_spatial"]\nallocators = ["market"]\n'
        'costs = ["abstract"]\nseeds = 2\n'
        '[fixed]\n"stream.n_sets" = 2\n"stream.rounds_per_set" = 3\n'
        '"stream.learn_sets" = 1\n"stream.test_sets" = 1\n'
        '[grid]\n"spatial.avoidance" = ["none", "orca"]\n'
    )
    out = tmp_path / "out"
    assert main(["sweep", str(path), "--out", str(out), "--workers", "2", "--no-progress"]) == 0
    assert "avoidance.md, avoidance.json, avoidance.png" in capsys.readouterr().out
    assert (out / "avoidance.png").stat().st_size > 0
    doc = json.loads((out / "avoidance.json").read_text())
    (row,) = doc["rows"]
    assert row["avoidance"] == "orca" and row["seeds"] == [0, 1]
    with (out / "runs.csv").open() as fh:
        runs = list(csv.DictReader(fh))
    orca = [float(r["tasks_allocated"]) for r in runs if r["spatial.avoidance"] == "orca"]
    assert row["after"]["tasks_allocated"] == pytest.approx(sum(orca) / 2)
    assert "| paper_spatial | market | abstract | orca | 2 |" in (out / "avoidance.md").read_text()
