"""``mrta run``: replay from a manifest, resume with and without a checkpoint, Ctrl-C, refused
runs that leave the output folder alone, a spatial run killed five times that resumes to the
same files, where robots stood, and checkpoints whose world does not fit."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import learning.checkpoint as ck
from learning.checkpoint import load_checkpoint
from scenarios.cli import main
from scenarios.experiments.outdir import staging_dir
from scenarios.loader import load_scenario
from tests.worlds import small_spatial_file

ROOT = Path(__file__).resolve().parents[2]


def test_cli_replay_gives_identical_metrics(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "paper", "--allocator", "ql", "--seed", "4", "--out", str(out)]) == 0
    manifest = json.loads((out / "run_manifest.json").read_text())
    assert manifest["runs"][0]["seed"] == 4 and manifest["scenario"]["name"] == "paper"
    assert manifest["libraries"]["numpy"] == np.__version__
    assert (
        main(["run", "--replay", str(out / "run_manifest.json"), "--out", str(tmp_path / "again")])
        == 0
    )
    assert (tmp_path / "again" / "metrics.json").read_bytes() == (out / "metrics.json").read_bytes()


def test_manifest_records_the_numerics_and_replay_says_when_they_differ(tmp_path, capsys):
    """The manifest holds the machine and numpy's SIMD kernels in use (they decide a run's
    last bits); a replay on other numerics runs, with one note line on stderr, and one on the
    same numerics prints nothing."""
    from numpy._core import _multiarray_umath as umath

    out = tmp_path / "run"
    args = ["--no-progress", "--out"]
    assert main(["run", "paper", "--allocator", "market", "--seed", "1", *args, str(out)]) == 0
    path = out / "run_manifest.json"
    doc = json.loads(path.read_text())
    rec = doc["numerics"]
    assert rec["numpy_baseline"] == list(umath.__cpu_baseline__)
    assert set(rec["numpy_dispatch"]) <= set(umath.__cpu_dispatch__)
    capsys.readouterr()
    assert main(["run", "--replay", str(path), *args, str(tmp_path / "same")]) == 0
    assert "note" not in capsys.readouterr().err
    rec["numpy_dispatch"] = ["NOT_A_CPU"]
    path.write_text(json.dumps(doc))
    assert main(["run", "--replay", str(path), *args, str(tmp_path / "other")]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "mrta: note:" in err and "NOT_A_CPU" in err
    same = (tmp_path / "same" / "metrics.json").read_bytes()
    assert (tmp_path / "other" / "metrics.json").read_bytes() == same


def test_cli_resume_without_checkpoint_is_a_clean_error(tmp_path, capsys):
    code = main(["run", "paper", "--resume", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and "no checkpoint to resume from" in err and err.count("\n") == 1


def test_ctrl_c_stops_cleanly_and_says_where_to_resume(tmp_path, capsys, monkeypatch):
    calls = {"n": 0}
    real = ck.save_checkpoint

    def save_then_interrupt(path, arrays, meta):
        real(path, arrays, meta)
        calls["n"] += 1
        if calls["n"] == 5:
            raise KeyboardInterrupt

    monkeypatch.setattr("scenarios.experiments.protocol.save_checkpoint", save_then_interrupt)
    out = tmp_path / "run"
    quiet = ["--no-progress", "--out", str(out)]
    code = main(["run", "paper", "--allocator", "ql", "--checkpoint", *quiet])
    err = capsys.readouterr().err
    assert code == 130
    assert "--resume" in err and err.count("\n") == 1
    assert not (out / "metrics.json").exists()
    monkeypatch.setattr("scenarios.experiments.protocol.save_checkpoint", real)
    assert main(["run", "paper", "--allocator", "ql", "--resume", "--out", str(out)]) == 0
    straight = tmp_path / "straight"
    assert main(["run", "paper", "--allocator", "ql", "--out", str(straight)]) == 0
    assert (out / "metrics.json").read_bytes() == (straight / "metrics.json").read_bytes()


def test_refused_run_leaves_the_output_folder_as_it_was(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["run", "paper", "--allocator", "market", "--seed", "1", "--out", str(out)]
    assert main([*args, "--checkpoint"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()
    code = main(["run", "paper", "--allocator", "ql", "--resume", "--no-progress", *args[-2:]])
    err = capsys.readouterr().err
    assert code == 2 and "written by another run" in err and err.count("\n") == 1
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def _mrta(*args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONHASHSEED": "0"}
    return subprocess.Popen(
        [sys.executable, "-m", "scenarios.cli", *args, "--no-progress"],
        cwd=ROOT,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )


def _stamp(path: Path):
    return path.stat().st_mtime_ns if path.exists() else None


@pytest.mark.slow
def test_spatial_run_killed_five_times_resumes_to_identical_outputs(tmp_path):
    """Each kill comes at a random moment (seeded) after the run has written at least one new
    checkpoint since it was (re)started, so that every kill interrupts real progress, whatever
    the machine's load."""
    scenario = str(small_spatial_file(tmp_path, n_sets=40, rounds=8))
    common = [scenario, "--allocator", "expt", "--cost", "distance", "--seed", "5"]
    straight = tmp_path / "straight"
    proc = _mrta("run", *common, "--out", str(straight))
    assert proc.wait(timeout=300) == 0, proc.stderr.read().decode()
    out = tmp_path / "killed"
    ck = staging_dir(out) / "checkpoint.npz"  # a run in progress writes beside its folder
    rng = np.random.default_rng(20261123)
    kills, sets_seen = 0, []
    while kills < 5:
        resume = ["--resume"] if ck.exists() else []
        before = _stamp(ck)
        proc = _mrta("run", *common, "--checkpoint", *resume, "--out", str(out))
        give_up = time.monotonic() + 120.0
        while proc.poll() is None and _stamp(ck) == before:
            assert time.monotonic() < give_up, "no checkpoint written within 120 s"
            time.sleep(0.02)
        time.sleep(float(rng.uniform(0.0, 0.25)))
        if proc.poll() is not None:  # finished before the kill: start over to kill it again
            assert proc.returncode == 0, proc.stderr.read().decode()
            shutil.rmtree(out)
            continue
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        kills += 1
        _, meta = load_checkpoint(ck)
        sets_seen.append((meta["phase"], meta["set_pos"]))
    assert not (out / "metrics.json").exists()
    proc = _mrta("run", *common, "--checkpoint", "--resume", "--out", str(out))
    assert proc.wait(timeout=300) == 0, proc.stderr.read().decode()
    assert not ck.parent.exists() and (out / "checkpoint.npz").exists()  # swapped in whole
    assert len(set(sets_seen)) == 5, sets_seen  # every kill after new progress
    for name in ("metrics.json", "tasks.csv"):
        assert (out / name).read_bytes() == (straight / name).read_bytes(), name
    with np.load(out / "stalls.npz") as a, np.load(straight / "stalls.npz") as b:
        assert np.array_equal(a["seconds"], b["seconds"])  # the map went through the checkpoints
        assert a["seconds"].sum() > 0


@pytest.mark.slow
def test_run_writes_where_robots_stood_and_it_adds_up(tmp_path, capsys):
    """``mrta run`` on a spatial scenario writes ``stalls.npz`` (loads without pickle) whose
    cells add up, cause by cause, to the standing seconds in ``metrics.json``; ``stalls.png``
    beside it; and the line naming the cell robots stood in longest is that of the map."""
    from scenarios.cli import main
    from scenarios.experiments.figures import stall_places
    from sim.spatial.stalls import CAUSES

    out = tmp_path / "run"
    scenario = str(small_spatial_file(tmp_path, n_sets=4, rounds=6))
    assert main(["run", scenario, "--allocator", "market", "--no-progress", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    metrics = json.loads((out / "metrics.json").read_text())
    spatial = metrics["allocators"]["market"]["spatial"]
    with np.load(out / "stalls.npz", allow_pickle=False) as data:
        seconds, causes, cell = data["seconds"], data["causes"].tolist(), float(data["cell_m"])
        assert data["arena_wh"].tolist() == [20.0, 20.0]  # paper_spatial's arena
    assert causes == list(CAUSES)
    per_cause = seconds.sum(axis=(1, 2))
    for k, name in enumerate(CAUSES):
        assert per_cause[k] == pytest.approx(spatial[f"still_s_{name}"], abs=1e-6), name
    assert per_cause.sum() > 0
    (top,) = stall_places(seconds, cell, k=1)
    assert f"stood longest at x {top['x_m']:g}-{top['x_m'] + cell:g} y {top['y_m']:g}" in printed
    assert (out / "stalls.png").stat().st_size > 10_000


@pytest.mark.slow
@pytest.mark.parametrize("damage", ["map", "stands"])
def test_a_checkpoint_whose_world_does_not_fit_is_one_line_and_exit_2(tmp_path, capsys, damage):
    """A damaged checkpoint (the stall map of another arena, or the stands of a fleet one robot
    larger) stops ``--resume`` with one line naming the file and the array, exit code 2, and
    leaves the outputs as they were."""
    from learning.checkpoint import save_checkpoint
    from scenarios.cli import main

    out = tmp_path / "run"
    scenario = str(small_spatial_file(tmp_path, n_sets=4, rounds=4))
    args = ["run", scenario, "--allocator", "market", "--no-progress", "--out", str(out)]
    assert main([*args, "--checkpoint"]) == 0
    arrays, meta = load_checkpoint(out / "checkpoint.npz")
    if damage == "map":
        arrays["world/stalls/map"] = np.zeros((7, 3, 3), dtype=np.int64)
        want = "checkpoint.npz: world/stalls/map: expected shape"
    else:
        m = len(arrays["world/stalls/run"])
        assert m == load_scenario(scenario).n_robots  # the meter sampled: one stand per robot
        arrays["world/stalls/run"] = np.zeros(m + 1, dtype=np.int64)
        arrays["world/stalls/run_task"] = np.full(m + 1, -1, dtype=np.int64)
        want = f"checkpoint.npz: world/stalls/run: {m + 1} robots' stands, the fleet has {m}"
    save_checkpoint(out / "checkpoint.npz", arrays, meta)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()
    assert main([*args, "--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and want in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
