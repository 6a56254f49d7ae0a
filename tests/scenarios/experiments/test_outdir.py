"""Output folders written as a whole: checked before work, staged, locked, swapped in."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest

from scenarios.experiments import outdir
from scenarios.experiments.budget import MAX_RUNS, check_count, check_work, estimate_bytes
from scenarios.experiments.outdir import (
    OutputError,
    check_out_dir,
    check_out_file,
    folder_lock,
    lock_path,
    os_error_line,
    staged_folder,
    staging_dir,
)
from scenarios.experiments.protocol import UserError
from scenarios.loader import load_scenario


def old_output(out: Path) -> None:
    out.mkdir()
    (out / "metrics.json").write_text("old")
    (out / "stale.png").write_text("old")


def test_paths_that_name_no_writable_folder_are_refused_in_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    (tmp_path / "loop_a").symlink_to(tmp_path / "loop_b")
    (tmp_path / "loop_b").symlink_to(tmp_path / "loop_a")
    cases = {
        "": "--out '': an empty path names no folder",
        "afile": "--out afile: is a file, not a folder",
        "afile/below": f"--out afile/below: {Path('afile')} is a file, so no folder can be made",
        ".": "--out .: the folder you are in (or one above it) cannot be replaced",
        "loop_a/out": "--out loop_a/out: cannot be resolved",
    }
    for path, message in cases.items():
        with pytest.raises(OutputError) as err:
            check_out_dir(path)
        assert str(err.value).startswith(message) and "\n" not in str(err.value)
    assert check_out_dir("new/deeper") == Path("new/deeper")  # made later, under a folder


def test_a_folder_without_write_permission_is_refused(tmp_path, monkeypatch):
    """Root may write anywhere, so the permission answer is what the test sets."""
    locked = tmp_path / "ro"
    locked.mkdir()
    monkeypatch.setattr(outdir.os, "access", lambda p, mode: Path(p) != locked)
    with pytest.raises(OutputError, match=f"--out {locked}/out: {locked} is not writable"):
        check_out_dir(locked / "out")
    with pytest.raises(OutputError, match="the folder is not writable"):
        check_out_dir(locked)
    with pytest.raises(OutputError, match=f"--gif {locked}/a.gif: the folder .* is not writable"):
        check_out_file(locked / "a.gif", "--gif")


def test_a_file_option_refuses_folders_and_missing_parents(tmp_path):
    with pytest.raises(OutputError, match="is a folder, not a file"):
        check_out_file(tmp_path, "--gif")
    with pytest.raises(OutputError, match=r"the folder .*nope does not exist"):
        check_out_file(tmp_path / "nope" / "a.gif", "--gif")


def test_a_finished_run_replaces_the_folder_whole(tmp_path):
    out = tmp_path / "run"
    old_output(out)
    with staged_folder(out) as stage:
        assert stage == staging_dir(out) and not (stage / "metrics.json").exists()
        (stage / "metrics.json").write_text("new")
        assert (out / "metrics.json").read_text() == "old"  # nothing moves before the end
    assert sorted(p.name for p in out.iterdir()) == ["metrics.json"]  # the stale file is gone
    assert (out / "metrics.json").read_text() == "new"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]  # no stage, lock or old copy


@pytest.mark.parametrize("failure", [RuntimeError("boom"), KeyboardInterrupt()])
def test_a_failed_run_leaves_the_old_folder_exactly_as_it_was(tmp_path, failure):
    out = tmp_path / "run"
    old_output(out)
    with pytest.raises(type(failure)), staged_folder(out) as stage:
        (stage / "metrics.json").write_text("half")
        raise failure
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        "metrics.json": "old",
        "stale.png": "old",
    }
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_a_run_with_a_checkpoint_keeps_its_stage_and_the_next_one_resumes_from_it(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(RuntimeError), staged_folder(out, keep_on_failure=True) as stage:
        (stage / "checkpoint.npz").write_text("set 3")
        raise RuntimeError("killed")
    assert not out.exists() and (staging_dir(out) / "checkpoint.npz").exists()
    with staged_folder(out, fresh=False) as stage:
        assert (stage / "checkpoint.npz").read_text() == "set 3"
        (stage / "metrics.json").write_text("done")
    assert sorted(p.name for p in out.iterdir()) == ["checkpoint.npz", "metrics.json"]


def test_a_failed_rename_puts_the_previous_output_back(tmp_path, monkeypatch):
    out = tmp_path / "run"
    old_output(out)
    real = os.replace
    calls = []

    def second_fails(src, dst):
        calls.append((Path(src).name, Path(dst).name))
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device", str(dst))
        return real(src, dst)

    monkeypatch.setattr(outdir.os, "replace", second_fails)
    with pytest.raises(OSError), staged_folder(out) as stage:
        (stage / "metrics.json").write_text("new")
    assert (out / "metrics.json").read_text() == "old" and (out / "stale.png").exists()
    assert calls[1] == (".run.partial", "run")


def test_a_live_holder_keeps_the_lock_and_a_dead_one_loses_it(tmp_path):
    out = tmp_path / "run"
    lock = lock_path(out)
    with folder_lock(out):
        assert lock.read_text().split()[0] == str(os.getpid())
        with pytest.raises(OutputError, match=rf"another mrta run \(pid {os.getpid()}\)"):
            with folder_lock(out):
                pass
    assert not lock.exists()
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    lock.write_text(f"{dead} {outdir.socket.gethostname()}\n")  # its process has ended
    with folder_lock(out):
        assert lock.read_text().split()[0] == str(os.getpid())


def test_a_second_run_into_a_locked_folder_is_one_line_and_exit_2(tmp_path):
    """Two runs into one folder: while this process holds the folder, ``mrta run`` refuses
    before any work and writes nothing."""
    out = tmp_path / "run"
    old_output(out)
    with folder_lock(out):
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "scenarios.cli",
                "run",
                "paper",
                "--seed",
                "0",
                "--out",
                str(out),
                "--no-progress",
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "another mrta run" in lines[0] and str(out) in lines[0]
    assert sorted(p.name for p in out.iterdir()) == ["metrics.json", "stale.png"]


@pytest.mark.parametrize(
    ("code", "words"),
    [
        (errno.ENOSPC, "no space left on the device"),
        (errno.EROFS, "read-only file system"),
        (errno.ELOOP, "too many symbolic links (a loop?)"),
        (errno.EACCES, "Permission denied"),
    ],
)
def test_file_system_errors_are_one_line_with_the_path(code, words):
    exc = OSError(code, os.strerror(code) if code == errno.EACCES else "x", "/data/run/a.csv")
    assert os_error_line(exc) == f"/data/run/a.csv: {words}"
    assert os_error_line(OSError(code, "msg")) in (words, "msg")


def test_counts_and_memory_are_bounded_before_work():
    with pytest.raises(UserError, match="runs: 100,001 is more than the 100,000 one command"):
        check_count("runs", MAX_RUNS + 1, MAX_RUNS)
    check_count("runs", MAX_RUNS, MAX_RUNS)
    sc = load_scenario("paper_spatial")
    need = estimate_bytes(sc, 1000, 2)
    check_work(sc, 1000, 2, memory_bytes=int(need / 0.8) + 1)  # just fits
    with pytest.raises(UserError, match=r"1,000 runs of 'paper_spatial' on 2 worker\(s\) need"):
        check_work(sc, 1000, 2, memory_bytes=int(need / 0.8) - 1)
    assert estimate_bytes(sc, 2000, 2) - need == 1000 * 64 * 1024  # one summary per run
