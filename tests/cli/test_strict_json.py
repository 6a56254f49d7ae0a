"""Every JSON a command writes or prints parses with a strict parser (no NaN or Infinity), and
says why a value is null."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenarios.cli import main
from scenarios.experiments.output import dumps, strict_json


def strict_load(text: str):
    def refuse(token):
        raise AssertionError(f"non-standard JSON token {token}")

    return json.loads(text, parse_constant=refuse)


def all_json(folder: Path) -> list[Path]:
    files = sorted(folder.rglob("*.json"))
    assert files, f"no JSON written under {folder}"
    return files


def test_strict_json_replaces_nan_and_infinity_with_null():
    import numpy as np

    doc = {"a": float("nan"), "b": [1.0, float("inf"), -np.inf], "c": np.float64(2.5), "d": "x"}
    assert strict_json(doc) == {"a": None, "b": [1.0, None, None], "c": 2.5, "d": "x"}
    assert strict_load(dumps(doc)) == strict_json(doc)


def test_a_one_seed_run_writes_null_intervals_and_says_why(tmp_path):
    out = tmp_path / "run"
    assert main(["run", "paper", "--allocator", "ql", "--out", str(out), "--no-progress"]) == 0
    for path in all_json(out):
        strict_load(path.read_text())
    metrics = strict_load((out / "metrics.json").read_text())
    entry = metrics["allocators"]["ql"]
    assert entry["completion"]["ci95"]["overall"]["all"] is None
    assert any("at least 2 seeds" in n for n in entry["notes"])


def test_compare_with_few_seeds_warns_once_and_writes_strict_json(tmp_path, capsys):
    out = tmp_path / "cmp"
    args = ["compare", "paper", "--costs", "abstract", "--allocators", "market,greedy"]
    assert main([*args, "--seeds", "2", "--out", str(out), "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert err.count("warning") == 1 and "fewer than 5 seeds" in err
    for path in all_json(out):
        strict_load(path.read_text())


def test_stream_sweep_and_soak_json_are_strict(tmp_path, capsys):
    stream = tmp_path / "stream.json"
    assert main(["stream", "paper", "--seed", "1", "--out", str(stream)]) == 0
    strict_load(stream.read_text())
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(
        '[sweep]\nscenarios = ["paper"]\nallocators = ["market", "expt"]\nseeds = 1\n'
        '[fixed]\n"stream.n_sets" = 4\n"stream.learn_sets" = 3\n"stream.test_sets" = 2\n'
        '[grid]\n"experience.delta_u" = [0.1]\n'
    )
    assert main(["sweep", str(sweep), "--out", str(tmp_path / "sw"), "--workers", "1",
                 "--no-progress"]) == 0  # fmt: skip
    for path in all_json(tmp_path / "sw"):
        strict_load(path.read_text())
    capsys.readouterr()
    assert main(["soak", "--scenario", "paper_spatial", "--tasks", "40", "--json"]) == 0
    printed = capsys.readouterr().out.strip().splitlines()[-1]
    strict_load(printed)


@pytest.mark.slow
def test_reproduce_with_two_seeds_warns_and_writes_strict_json(tmp_path, capsys):
    out = tmp_path / "rep"
    args = ["reproduce", "--seeds", "2", "--tradeoff", "none", "--out", str(out)]
    assert main([*args, "--no-progress"]) == 0
    assert capsys.readouterr().err.count("fewer than 5 seeds") == 1
    for path in all_json(out):
        strict_load(path.read_text())
