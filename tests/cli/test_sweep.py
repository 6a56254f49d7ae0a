"""``mrta sweep`` on the command line: its entry points, the avoidance report, and ``--against``."""

from __future__ import annotations

import argparse
import csv
import json

import pytest

from scenarios.cli.commands import cmd_sweep
from scenarios.cli.parser import add_sweep_parser


def test_the_cli_checks_the_old_file_before_running_and_writes_the_comparison(tmp_path, capsys):
    from scenarios.cli.app import main

    spec = tmp_path / "s.toml"
    spec.write_text(
        '[sweep]\nscenarios = ["paper"]\nallocators = ["market"]\nseeds = 2\n'
        '[fixed]\n"stream.n_sets" = 3\n"stream.rounds_per_set" = 3\n'
        '"stream.learn_sets" = 2\n"stream.test_sets" = 1\n'
        '[grid]\n"experience.delta_u" = [0.3]\n'
    )
    out = tmp_path / "out"
    code = main(["sweep", str(spec), "--out", str(out), "--against", str(tmp_path / "no.csv")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no.csv: no such file" in err[0]
    assert not out.exists()  # nothing ran, nothing written
    args = ["sweep", str(spec), "--out", str(out), "--workers", "1", "--no-progress"]
    assert main(args) == 0
    old = tmp_path / "old.csv"
    old.write_text((out / "runs.csv").read_text())
    assert main([*args, "--against", str(old)]) == 0  # the same runs: every change is zero
    assert "1 group(s) paired by seed" in capsys.readouterr().out
    doc = json.loads((out / "against.json").read_text())
    (row,) = doc["rows"]
    assert row["seeds"] == [0, 1] and row["completion_all"]["diff"] == 0.0
    assert (out / "against.md").read_text().count("| paper | market |") == 1


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
