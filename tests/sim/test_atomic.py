"""Atomic writes (`sim.atomic`) and the writers that use them: a failing write leaves the
target as it was and no temporary file behind."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from sim.atomic import atomic_open, replacing, temp_beside


def _names(folder):
    return sorted(p.name for p in folder.iterdir())


def test_temp_file_is_hidden_beside_the_target_and_names_the_process(tmp_path):
    target = tmp_path / "runs" / "metrics.json"
    assert temp_beside(target) == tmp_path / "runs" / f".metrics.json.{os.getpid()}.tmp"
    assert temp_beside(target, ".gif").name == f".metrics.json.{os.getpid()}.tmp.gif"


@pytest.mark.parametrize("mode, data", [("w", "new text\n"), ("wb", b"\x00new bytes")])
def test_atomic_open_replaces_the_target_only_at_the_end(tmp_path, mode, data):
    target = tmp_path / "out.txt"
    target.write_bytes(b"old")
    with atomic_open(target, mode) as fh:
        fh.write(data)
        assert target.read_bytes() == b"old"  # nothing visible before the block ends
        assert temp_beside(target).exists()
    assert target.read_bytes() == (data.encode() if mode == "w" else data)
    assert _names(tmp_path) == ["out.txt"]


def test_atomic_open_creates_a_new_file(tmp_path):
    with atomic_open(tmp_path / "new.csv", newline="") as fh:
        fh.write("a,b\r\n")
    assert (tmp_path / "new.csv").read_bytes() == b"a,b\r\n"  # newline="" writes as given


@pytest.mark.parametrize("error", [RuntimeError, KeyboardInterrupt])
def test_a_failing_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, error):
    target = tmp_path / "out.txt"
    target.write_text("old")
    with pytest.raises(error):
        with atomic_open(target) as fh:
            fh.write("half of the new")
            raise error("interrupted")
    assert target.read_text() == "old"
    assert _names(tmp_path) == ["out.txt"]


def test_replacing_a_path_for_writers_that_take_one(tmp_path):
    target = tmp_path / "movie.gif"
    with replacing(target, ".gif", sync_folder=True) as tmp:
        assert tmp.suffix == ".gif" and tmp.parent == tmp_path
        tmp.write_bytes(b"GIF89a")
    assert target.read_bytes() == b"GIF89a"
    assert _names(tmp_path) == ["movie.gif"]


def test_replacing_with_a_writer_that_wrote_nothing_fails_and_keeps_the_target(tmp_path):
    target = tmp_path / "movie.gif"
    target.write_bytes(b"old")
    with pytest.raises(FileNotFoundError):
        with replacing(target):
            pass  # e.g. an external program that exited without writing
    assert target.read_bytes() == b"old"
    assert _names(tmp_path) == ["movie.gif"]


def test_atomic_open_refuses_reading_and_appending_modes(tmp_path):
    for mode in ("r", "a", "w+", "ab"):
        with pytest.raises(ValueError, match="mode must be"):
            with atomic_open(tmp_path / "x", mode):
                pass
    assert _names(tmp_path) == []


def test_trajectory_save_that_fails_keeps_the_old_file(tmp_path, monkeypatch):
    from sim.recording import TrajectoryRecorder

    rec = TrajectoryRecorder((4.0, 3.0), [], ["a"], ["r0"])
    traj = rec.finish()
    target = tmp_path / "traj.npz"
    traj.save(target)
    before = target.read_bytes()

    def broken(fh, **arrays):
        fh.write(b"PK\x03\x04 half a zip")
        raise OSError("disk full")

    monkeypatch.setattr(np, "savez_compressed", broken)
    with pytest.raises(OSError, match="disk full"):
        traj.save(target)
    assert target.read_bytes() == before
    assert _names(tmp_path) == ["traj.npz"]


def test_json_that_cannot_be_written_touches_nothing(tmp_path):
    from scenarios.experiments.output import write_json_atomic

    target = tmp_path / "metrics.json"
    write_json_atomic(target, {"a": 1.0, "b": float("nan")})
    assert json.loads(target.read_text()) == {"a": 1.0, "b": None}
    with pytest.raises(TypeError):
        write_json_atomic(target, {"a": object()})
    assert json.loads(target.read_text()) == {"a": 1.0, "b": None}
    assert _names(tmp_path) == ["metrics.json"]
