"""Checkpoints, resume, SIGKILL during a write, corrupt files, replay from a manifest."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import learning.checkpoint as ck
from scenarios.cli import main
from scenarios.protocol import RunSpec, execute

SPEC = RunSpec("paper", "expt", seed=7)


class Stop(Exception):
    pass


def q_tables(path):
    arrays, meta = ck.load_checkpoint(path)
    return {k: v for k, v in arrays.items() if k.startswith(("q/", "alphabet/", "exp/"))}, meta


def test_resume_equals_straight_through(tmp_path, monkeypatch):
    straight_ck = tmp_path / "straight.npz"
    straight = execute(SPEC, checkpoint=straight_ck)

    broken_ck = tmp_path / "broken.npz"
    real_save = ck.save_checkpoint
    calls = {"n": 0}

    def save_then_stop(path, arrays, meta):
        real_save(path, arrays, meta)
        calls["n"] += 1
        if calls["n"] == 12:  # interrupted after 12 learning sets
            raise Stop

    monkeypatch.setattr("scenarios.experiments.protocol.save_checkpoint", save_then_stop)
    with pytest.raises(Stop):
        execute(SPEC, checkpoint=broken_ck)
    monkeypatch.setattr("scenarios.experiments.protocol.save_checkpoint", real_save)
    _, meta = q_tables(broken_ck)
    assert (meta["phase"], meta["set_pos"]) == (0, 12)

    resumed = execute(SPEC, checkpoint=broken_ck, resume=True)
    assert resumed == straight
    a, _ = q_tables(straight_ck)
    b, _ = q_tables(broken_ck)
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key]), key


CHILD = textwrap.dedent(
    """
    import sys, threading
    import numpy as np
    from pathlib import Path
    from scenarios.protocol import RunSpec, execute
    real = np.savez
    calls = {"n": 0}
    def savez(fh, **arrays):
        calls["n"] += 1
        if calls["n"] == 4:  # the 4th checkpoint: write half of it, then hang until killed
            fh.write(b"PK\\x03\\x04" + b"\\0" * 50000)
            fh.flush()
            print("WRITING", flush=True)
            threading.Event().wait()
        real(fh, **arrays)
    np.savez = savez
    execute(RunSpec("paper", "expt", seed=7), checkpoint=Path(sys.argv[1]))
    """
)


def test_sigkill_during_checkpoint_write_keeps_previous(tmp_path):
    path = tmp_path / "checkpoint.npz"
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(path)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "WRITING"
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    _, meta = q_tables(path)  # loads whole: the previous checkpoint (after set 3)
    assert (meta["phase"], meta["set_pos"]) == (0, 3)
    resumed = execute(SPEC, checkpoint=path, resume=True)
    assert resumed == execute(SPEC)


@pytest.mark.parametrize("damage", ["truncate", "garbage", "foreign", "empty"])
def test_corrupt_checkpoint_clear_error(tmp_path, damage):
    path = tmp_path / "checkpoint.npz"
    execute(RunSpec("paper", "ql", seed=1), checkpoint=path)
    data = path.read_bytes()
    if damage == "truncate":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        path.write_bytes(b"\x00" * 100)
    elif damage == "empty":
        path.write_bytes(b"")
    else:
        np.savez(path, meta=np.array(json.dumps({"format": "something-else"})))
    with pytest.raises(ck.CheckpointError, match="checkpoint"):
        execute(RunSpec("paper", "ql", seed=1), checkpoint=path, resume=True)


def test_checkpoint_from_other_run_is_refused(tmp_path):
    path = tmp_path / "checkpoint.npz"
    execute(RunSpec("paper", "ql", seed=1), checkpoint=path)
    with pytest.raises(ck.CheckpointError, match="another run"):
        execute(RunSpec("paper", "ql", seed=2), checkpoint=path, resume=True)


def test_checkpoint_has_no_pickles(tmp_path):
    path = tmp_path / "checkpoint.npz"
    execute(SPEC, checkpoint=path)
    with np.load(path, allow_pickle=False) as data:
        for key in data.files:
            assert data[key].dtype != object


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
    assert main(["run", "paper", "--allocator", "market", "--seed", "1", "--out", str(out)]) == 0
    path = out / "run_manifest.json"
    doc = json.loads(path.read_text())
    rec = doc["numerics"]
    assert rec["numpy_baseline"] == list(umath.__cpu_baseline__)
    assert set(rec["numpy_dispatch"]) <= set(umath.__cpu_dispatch__)
    capsys.readouterr()
    assert main(["run", "--replay", str(path), "--out", str(tmp_path / "same")]) == 0
    assert "note" not in capsys.readouterr().err
    rec["numpy_dispatch"] = ["NOT_A_CPU"]
    path.write_text(json.dumps(doc))
    assert main(["run", "--replay", str(path), "--out", str(tmp_path / "other")]) == 0
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
    code = main(["run", "paper", "--allocator", "ql", "--checkpoint", "--out", str(out)])
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
    code = main(["run", "paper", "--allocator", "ql", "--resume", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and "written by another run" in err and err.count("\n") == 1
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
