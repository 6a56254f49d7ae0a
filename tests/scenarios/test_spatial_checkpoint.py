"""Spatial checkpoints: the pymunk world's state between sets, resume equal to a straight run
(at every set boundary, and after SIGKILL at random moments), and the rebuild at set ends."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import scenarios.experiments.protocol as protocol
from learning.checkpoint import load_checkpoint
from learning.rounds import play_round
from scenarios.experiments.protocol import RunSpec, execute
from scenarios.loader import load_scenario
from sim.spatial.world import PymunkWorld

ROOT = Path(__file__).resolve().parents[2]
BUNDLED = ROOT / "scenarios" / "data" / "paper_spatial.toml"


def small_spatial(tmp_path: Path, n_sets: int = 6, rounds: int = 6) -> Path:
    """paper_spatial with a short stream: ``n_sets`` sets of ``rounds`` announcements."""
    text = BUNDLED.read_text()
    for key, value in (
        ("n_sets", n_sets),
        ("rounds_per_set", rounds),
        ("learn_sets", n_sets // 2),
        ("test_sets", n_sets - n_sets // 2),
    ):
        lines = [ln for ln in text.splitlines() if ln.split("=")[0].strip() == key]
        assert len(lines) == 1, key
        text = text.replace(lines[0], f"{key} = {value}")
    path = tmp_path / f"small_{n_sets}x{rounds}.toml"
    path.write_text(text)
    return path


class Stop(Exception):
    pass


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


@pytest.mark.parametrize(
    ("allocator", "cost"), [("market", "distance"), ("expt", "abstract"), ("ql", "time")]
)
def test_resume_at_every_set_boundary_equals_the_straight_run(
    tmp_path, monkeypatch, allocator, cost
):
    scenario = small_spatial(tmp_path)
    spec = RunSpec(str(scenario), allocator, cost, 7)
    straight = execute(spec, task_table=True)
    assert straight["spatial"]["sim_time_s"] > 0
    for after in range(1, 6):
        ck = tmp_path / f"ck{after}.npz"
        interrupted(spec, ck, after, monkeypatch)
        resumed = execute(spec, checkpoint=ck, resume=True, task_table=True)
        assert json.dumps(resumed, sort_keys=True) == json.dumps(straight, sort_keys=True), after


def test_resume_with_look_ahead_equals_the_straight_run(tmp_path, monkeypatch):
    """``[spatial] look_ahead = "on"`` keeps marks between control periods (robots given a
    task, robots that began work) that no checkpoint holds: every set ends with them spent,
    so a resumed run equals the straight one. The rule acts here (the run differs from the
    same with it off)."""
    scenario = small_spatial(tmp_path)
    spec = RunSpec(str(scenario), "market", "distance", 7, (("spatial.look_ahead", "on"),))
    straight = execute(spec, task_table=True)
    off = execute(RunSpec(str(scenario), "market", "distance", 7), task_table=True)
    assert off["spatial"] != straight["spatial"] and off["task_table"] != straight["task_table"]
    for after in (2, 4):
        ck = tmp_path / f"ahead{after}.npz"
        interrupted(spec, ck, after, monkeypatch)
        resumed = execute(spec, checkpoint=ck, resume=True, task_table=True)
        assert json.dumps(resumed, sort_keys=True) == json.dumps(straight, sort_keys=True), after


def test_resume_with_robot_faults_equals_the_straight_run(tmp_path, monkeypatch):
    """With faults the checkpoint also holds the fault model (its generator included) and the
    path planner marks the robots that stand broken, in the straight and the resumed run."""
    scenario = small_spatial(tmp_path, n_sets=6, rounds=8)
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


def test_world_state_round_trip_for_both_controls(tmp_path):
    path = small_spatial(tmp_path)
    sc = load_scenario(path)
    spec = RunSpec(str(path), "market", "distance", 3)
    for control in ("scalar", "array"):
        _, stream, _, cost, allocator, rng = protocol.build_run(spec)
        world = PymunkWorld(sc, control=control)
        world.reset(rng)
        for batch in list(stream.batches(0))[:4]:
            play_round(world, batch, cost, allocator.allocate, 10.0)
        assert (world.fleet.task >= 0).any()
        with pytest.raises(RuntimeError, match="in progress"):
            world.state_arrays()
        world.drain()
        first = world.state_arrays()
        assert int(first["clock/steps"]) == world.clock.steps > 0
        assert first["motors/robots"].shape == (10, 6)
        assert int(first["contacts/robot_hits"]) == world.contacts.robot_hits
        world.restore_arrays(first)
        second = world.state_arrays()
        assert first.keys() == second.keys()
        for key in first:
            np.testing.assert_array_equal(first[key], second[key], err_msg=f"{control}: {key}")


def test_restore_rebuilds_the_space_and_keeps_the_counts(tmp_path):
    sc = load_scenario(small_spatial(tmp_path))
    world = PymunkWorld(sc)
    world.reset(np.random.default_rng(0))
    state = world.state_arrays()
    state["motors/robots"][0, :2] = (4.5, 2.5)
    state["contacts/wall_hits"] = np.array(17)
    state["clock/steps"] = np.array(600)
    space = world.space
    world.restore_arrays(state)
    assert world.space is not space  # a fresh space: no cached contacts carried over
    assert world.contacts.wall_hits == 17 and world.contacts.touching == 0
    assert world.time_s == pytest.approx(600 * sc.spatial.dt_s)
    xy, _ = world.poses()
    assert tuple(xy[0]) == (4.5, 2.5)


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


def test_spatial_run_killed_five_times_resumes_to_identical_outputs(tmp_path):
    """Each kill comes at a random moment (seeded) after the run has written at least one new
    checkpoint since it was (re)started, so that every kill interrupts real progress, whatever
    the machine's load."""
    scenario = str(small_spatial(tmp_path, n_sets=40, rounds=8))
    common = [scenario, "--allocator", "expt", "--cost", "distance", "--seed", "5"]
    straight = tmp_path / "straight"
    proc = _mrta("run", *common, "--out", str(straight))
    assert proc.wait(timeout=300) == 0, proc.stderr.read().decode()
    out = tmp_path / "killed"
    ck = out / "checkpoint.npz"
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
            for name in ("metrics.json", "tasks.csv", "checkpoint.npz"):
                (out / name).unlink()
            continue
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        kills += 1
        _, meta = load_checkpoint(ck)
        sets_seen.append((meta["phase"], meta["set_pos"]))
    assert not (out / "metrics.json").exists()
    proc = _mrta("run", *common, "--checkpoint", "--resume", "--out", str(out))
    assert proc.wait(timeout=300) == 0, proc.stderr.read().decode()
    assert len(set(sets_seen)) == 5, sets_seen  # every kill after new progress
    for name in ("metrics.json", "tasks.csv"):
        assert (out / name).read_bytes() == (straight / name).read_bytes(), name
    with np.load(out / "stalls.npz") as a, np.load(straight / "stalls.npz") as b:
        assert np.array_equal(a["seconds"], b["seconds"])  # the map went through the checkpoints
        assert a["seconds"].sum() > 0


def test_run_writes_where_robots_stood_and_it_adds_up(tmp_path, capsys):
    """``mrta run`` on a spatial scenario writes ``stalls.npz`` (loads without pickle) whose
    cells add up, cause by cause, to the standing seconds in ``metrics.json``; ``stalls.png``
    beside it; and the line naming the cell robots stood in longest is that of the map."""
    from scenarios.cli import main
    from scenarios.experiments.figures import stall_places
    from sim.spatial.stalls import CAUSES

    out = tmp_path / "run"
    scenario = str(small_spatial(tmp_path, n_sets=4, rounds=6))
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


def test_rebuild_frees_the_old_spaces_and_reuses_the_batch_buffers(tmp_path):
    """A soak rebuilds the space at every set end: the old spaces must be freed (a pymunk
    space and its collision handlers form a reference cycle: by a collection once the dropped
    spaces hold ``sim.spatial.world.GC_ROBOTS`` robots) and the batch buffers, whose C arrays pymunk
    never frees, reused; otherwise memory grows set by set."""
    import math
    import weakref

    import sim.spatial.world

    world = PymunkWorld(load_scenario(small_spatial(tmp_path)))
    world.reset(np.random.default_rng(0))
    buffers = (world.motors.buf_, world.contacts.buf_)
    old = [weakref.ref(world.space)]
    for _ in range(math.ceil(sim.spatial.world.GC_ROBOTS / world.scenario.n_robots)):
        world.rebuild()
        old.append(weakref.ref(world.space))
        assert (world.motors.buf_, world.contacts.buf_) == buffers
    assert all(r() is None for r in old[:-1]) and old[-1]() is world.space


@pytest.mark.parametrize("damage", ["map", "stands"])
def test_a_checkpoint_whose_world_does_not_fit_is_one_line_and_exit_2(tmp_path, capsys, damage):
    """A damaged checkpoint (the stall map of another arena, or the stands of a fleet one robot
    larger) stops ``--resume`` with one line naming the file and the array, exit code 2, and
    leaves the outputs as they were."""
    from learning.checkpoint import save_checkpoint
    from scenarios.cli import main

    out = tmp_path / "run"
    scenario = str(small_spatial(tmp_path, n_sets=4, rounds=4))
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
