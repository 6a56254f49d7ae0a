"""Running the protocol (``scenarios.experiments.protocol``): checkpoints and resume equal to a
straight run (abstract and spatial, with look-ahead and with faults), SIGKILL during a checkpoint
write, corrupt and foreign checkpoints, no pickles; parallel runs equal serial ones. The same
through ``mrta run`` is in ``tests/cli/test_run.py``."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import learning.checkpoint as ck
import scenarios.experiments.protocol as protocol
from learning.checkpoint import load_checkpoint
from scenarios.experiments.protocol import RunSpec, execute
from scenarios.protocol import run_many
from tests.worlds import small_spatial_file

SPEC = RunSpec("paper", "expt", seed=7)


class Stop(Exception):
    pass


def q_tables(path):
    arrays, meta = ck.load_checkpoint(path)
    return {k: v for k, v in arrays.items() if k.startswith(("q/", "alphabet/", "exp/"))}, meta


@pytest.mark.slow
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


@pytest.mark.slow
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


def interrupted(spec: RunSpec, checkpoint: Path, after_sets: int, monkeypatch) -> None:
    """Play ``spec`` with checkpoints and stop it right after the ``after_sets``-th set."""
    real = protocol.run_protocol
    calls = {"n": 0}

    def run(*args, on_set_end=None, **kwargs):
        def hook(phase, pos, record):
            on_set_end(phase, pos, record)
            calls["n"] += 1
            if calls["n"] == after_sets:
                raise Stop

        return real(*args, on_set_end=hook, **kwargs)

    monkeypatch.setattr(protocol, "run_protocol", run)
    with pytest.raises(Stop):
        execute(spec, checkpoint=checkpoint, task_table=True)
    monkeypatch.setattr(protocol, "run_protocol", real)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("allocator", "cost"), [("market", "distance"), ("expt", "abstract"), ("ql", "time")]
)
def test_resume_at_every_set_boundary_equals_the_straight_run(
    tmp_path, monkeypatch, allocator, cost
):
    scenario = small_spatial_file(tmp_path)
    spec = RunSpec(str(scenario), allocator, cost, 7)
    straight = execute(spec, task_table=True)
    assert straight["spatial"]["sim_time_s"] > 0
    for after in range(1, 6):
        ck = tmp_path / f"ck{after}.npz"
        interrupted(spec, ck, after, monkeypatch)
        resumed = execute(spec, checkpoint=ck, resume=True, task_table=True)
        assert json.dumps(resumed, sort_keys=True) == json.dumps(straight, sort_keys=True), after


@pytest.mark.slow
def test_resume_with_look_ahead_equals_the_straight_run(tmp_path, monkeypatch):
    """``[spatial] look_ahead = "on"`` keeps marks between control periods (robots given a
    task, robots that began work) that no checkpoint holds: every set ends with them spent,
    so a resumed run equals the straight one. The rule acts here (the run differs from the
    same with it off)."""
    scenario = small_spatial_file(tmp_path)
    spec = RunSpec(str(scenario), "market", "distance", 7, (("spatial.look_ahead", "on"),))
    straight = execute(spec, task_table=True)
    off = execute(
        RunSpec(str(scenario), "market", "distance", 7, (("spatial.look_ahead", "off"),)),
        task_table=True,
    )
    assert off["spatial"] != straight["spatial"] and off["task_table"] != straight["task_table"]
    for after in (2, 4):
        ck = tmp_path / f"ahead{after}.npz"
        interrupted(spec, ck, after, monkeypatch)
        resumed = execute(spec, checkpoint=ck, resume=True, task_table=True)
        assert json.dumps(resumed, sort_keys=True) == json.dumps(straight, sort_keys=True), after


@pytest.mark.slow
def test_resume_with_robot_faults_equals_the_straight_run(tmp_path, monkeypatch):
    """With faults the checkpoint also holds the fault model (its generator included) and the
    path planner marks the robots that stand broken, in the straight and the resumed run."""
    scenario = small_spatial_file(tmp_path, n_sets=6, rounds=8)
    spec = RunSpec(str(scenario), "expt", "distance", 2, (("faults.mttf_s", 300.0),))
    straight = execute(spec, task_table=True)
    assert sum(straight["faults"]["failures_per_robot"].values()) > 0
    for after in (2, 4):
        ck = tmp_path / f"faults{after}.npz"
        interrupted(spec, ck, after, monkeypatch)
        arrays, _ = load_checkpoint(ck)
        assert "world/faults/rng_state" in arrays
        resumed = execute(spec, checkpoint=ck, resume=True, task_table=True)
        assert json.dumps(resumed, sort_keys=True) == json.dumps(straight, sort_keys=True), after


@pytest.mark.slow
def test_parallel_equals_serial():
    specs = [RunSpec("paper", a, seed=s) for a in ("ql", "expt") for s in (0, 1)]
    assert run_many(specs, workers=2, progress=False) == run_many(specs, workers=1, progress=False)


def test_a_scenario_file_written_again_is_read_again(tmp_path):
    """``load_named`` shares a scenario between the runs of a process only while its file
    holds the same text: a file written again at the same path (a notebook's edit, a test
    writing case after case) is read again, and an unchanged one is the same object."""
    text = Path(protocol.load_scenario("paper").source).read_text()
    path = tmp_path / "mine.toml"
    path.write_text(text.replace("n_sets = 45", "n_sets = 44", 1))
    first = protocol.load_named(str(path))
    assert first.stream.n_sets == 44
    assert protocol.load_named(str(path)) is first
    path.write_text(text.replace("n_sets = 45", "n_sets = 43", 1))
    assert protocol.load_named(str(path)).stream.n_sets == 43
    path.write_text(text.replace("n_sets = 45", "n_sets = 44", 1))
    assert protocol.load_named(str(path)) is first
