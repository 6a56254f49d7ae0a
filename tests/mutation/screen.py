"""Mutants mutmut has not run, screened in-process against a fast selection of the suite.

A surviving mutant costs mutmut its function's whole test selection, and for the control
periods (``sim.control.scalar``, ``sim.control.array``: every simulation test calls them) that
is three to four minutes a survivor. This script runs the mutants instead against a few fast
tests that pin the control law (by default ``tests/sim/test_control.py``, whose parity tests
compare the two control periods state by state in a crowd and in three hard cases, and four
parity tests of ``tests/sim/test_physics.py``): each mutant is switched on in one Python with
``MUTANT_UNDER_TEST`` (mutmut's trampolines read it at every call) and the tests run with
``pytest.main``, stopping at the first failure.

The tests first run once with no mutant on, and nothing is screened (exit code 2) unless they
pass: a wrong test id, or a stale copy of the tests in ``mutants/``, would otherwise fail every
mutant and count it killed.

A mutant that makes the child Python die (an abort inside numpy's or scipy's C code) is
recorded "crashed" (mutmut calls a test process that aborts "suspicious"; ``score.py`` counts
it under "other", neither killed nor survived), and a new child screens the rest.

A mutant the screen kills is killed by tests of the suite. One it does not kill has passed
only the screen's tests: ``score.py`` counts it as a survivor (so the score is a lower bound)
and ``golden.py`` takes it as it takes mutmut's survivors.

Run after ``mutmut run`` has generated the mutants, from the project root::

    python tests/mutation/screen.py "sim.control.scalar.*"    # mutants not run by mutmut
    python tests/mutation/screen.py --again "sim.control.scalar.*"  # after adding tests
    python tests/mutation/golden.py "sim.control.scalar.*"    # the screen's survivors
    python tests/mutation/score.py

Results go to ``mutants/screen.json`` (mutant name -> "killed", "survived", "timeout" or
"crashed", with the hash of its function as mutmut recorded it: a result is dropped when the
function changes).
"""

from __future__ import annotations

import argparse
import fcntl
import fnmatch
import json
import os
import queue
import signal
import subprocess
import sys
import threading
from pathlib import Path

MUTANTS = Path("mutants")
TESTS = [
    "tests/sim/test_control.py",
    "tests/sim/test_physics.py::test_small_team_and_array_control_periods_agree",
    "tests/sim/test_physics.py::test_both_control_periods_agree_in_a_crowd_with_caps_and_keep_right",
    "tests/sim/test_physics.py::test_obstacle_caps_in_python_equal_the_array_version",
    "tests/sim/test_physics.py::test_nearest_obstacle_point_in_python_equals_the_array_version",
]
# A mutant whose tests run longer than this hangs (they take about 12 s): the alarm fails the
# test it interrupts, a kill as mutmut counts one, or is a "timeout" outside a test (collection).
LIMIT_S = 120


def not_run(patterns: list[str], root: Path = MUTANTS) -> dict[str, str]:
    """Mutants mutmut has not run (exit code None) matching any of ``patterns`` -> the hash
    of their function."""
    out = {}
    for meta in sorted(root.rglob("*.py.meta")):
        doc = json.loads(meta.read_text())
        hashes = doc.get("hash_by_function_name", {})
        for name, code in doc["exit_code_by_key"].items():
            if code is None and any(fnmatch.fnmatchcase(name, p) for p in patterns):
                out[name] = hashes.get(name.rsplit("__mutmut_", 1)[0].rsplit(".", 1)[1], "")
    return out


def load(root: Path = MUTANTS) -> dict[str, dict[str, str]]:
    path = root / "screen.json"
    return json.loads(path.read_text()) if path.exists() else {}


def save(name: str, row: dict[str, str], root: Path = MUTANTS) -> None:
    """Add one result to ``screen.json``: read, add, write to a temporary file and rename, all
    under a lock, so screens of other modules running at the same time keep theirs."""
    with open(root / "screen.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        done = load(root)
        done[name] = row
        tmp = root / "screen.json.tmp"
        tmp.write_text(json.dumps(done, indent=1, sort_keys=True) + "\n")
        tmp.replace(root / "screen.json")


class _Hang(Exception):
    pass


def _alarm(*_) -> None:
    raise _Hang


def child(names: list[str], tests: list[str]) -> None:
    """Inside ``mutants/``: each mutant against ``tests``; one JSON line per mutant."""
    import pytest

    sys.path.insert(0, os.getcwd())
    signal.signal(signal.SIGALRM, _alarm)
    quiet = ["-x", "-q", "-p", "no:cacheprovider", "--no-header", "-p", "no:warnings"]
    with open(os.devnull, "w") as devnull:
        for name in names:
            os.environ["MUTANT_UNDER_TEST"] = name
            signal.alarm(LIMIT_S)
            out, sys.stdout = sys.stdout, devnull
            try:
                result = "survived" if pytest.main(quiet + tests) == 0 else "killed"
            except _Hang:
                result = "timeout"
            finally:
                sys.stdout = out
                signal.alarm(0)
            print(json.dumps([name, result]), flush=True)


def clean(tests: list[str]) -> int:
    """Inside ``mutants/``: ``tests`` with no mutant on; pytest's exit code."""
    import pytest

    sys.path.insert(0, os.getcwd())
    os.environ["MUTANT_UNDER_TEST"] = ""
    return int(pytest.main(["-q", "-p", "no:cacheprovider", "--no-header", *tests]))


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("patterns", nargs="*", default=["*"], help="mutant name patterns")
    parser.add_argument("--jobs", type=int, default=2, help="child Pythons at once (default 2)")
    parser.add_argument("--tests", nargs="+", default=TESTS, help="test ids (from mutants/)")
    parser.add_argument(
        "--again", action="store_true", help="screen the screen's survivors again (new tests)"
    )
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    parser.add_argument("--clean", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        child(args.child, args.tests)
        return 0
    if args.clean:
        return clean(args.tests)
    if not MUTANTS.is_dir():
        print("no mutants/ here: run mutmut first, from the project root", file=sys.stderr)
        return 2
    done = load()

    def due(name: str, digest: str) -> bool:
        row = done.get(name, {})
        return row.get("hash") != digest or (args.again and row.get("result") == "survived")

    todo = {n: h for n, h in not_run(args.patterns).items() if due(n, h)}
    names = sorted(todo)
    print(f"{len(names)} mutants not run by mutmut to screen", flush=True)
    env = {**os.environ, "MUTANT_UNDER_TEST": ""}
    script = str(Path(__file__).resolve())

    def spawn(part: list[str]):
        return subprocess.Popen(
            [sys.executable, script, "--tests", *args.tests, "--child", *part],
            cwd=MUTANTS,
            env=env,
            stdout=subprocess.PIPE,
            text=True,
        )

    k = 0

    def report(name: str, result: str, crashed: bool) -> None:  # each result saved at once
        nonlocal k
        save(name, {"result": result, "hash": todo[name]})
        k += 1
        note = " (its Python died; mutmut would call it suspicious)" if crashed else ""
        print(f"[{k}/{len(names)}] {result:8s} {name}{note}", flush=True)

    if names:  # a wrong test id or a stale copy would fail every mutant: "killed" for all
        run = [sys.executable, script, "--tests", *args.tests, "--clean"]
        ran = subprocess.run(run, cwd=MUTANTS, env=env, capture_output=True, text=True)
        if ran.returncode != 0:
            said = [x.strip() for x in ran.stdout.splitlines() if x.strip()]
            said += [x.strip() for x in ran.stderr.splitlines() if x.strip()]  # last: errors
            print(
                f"the screen's tests do not pass with no mutant on (pytest exit "
                f"{ran.returncode}: {said[-1] if said else 'no output'}): check --tests, and "
                "that mutants/tests has the current tests; nothing screened",
                file=sys.stderr,
            )
            return 2
    screen_all(names, args.jobs, spawn, report)
    return 0


def screen_all(names: list[str], jobs: int, spawn, report) -> None:
    """Screen ``names`` in ``jobs`` child Pythons at once, each taking every jobs-th name.

    ``spawn(names)`` starts a child (a process whose ``stdout`` yields one JSON line
    ``[name, result]`` per mutant, in the order given); ``report(name, result, crashed)`` is
    called for every mutant, from this thread. A child that ends before it reported all its
    mutants died on the next one (a mutant can abort Python inside numpy or scipy's C code):
    that mutant is reported "crashed" and a new child takes the rest."""
    lines: queue.Queue = queue.Queue()

    def slot(part: list[str]) -> None:
        while part:
            proc = spawn(part)
            seen = 0
            for line in proc.stdout:
                name, result = json.loads(line)
                lines.put((name, result, False))
                seen += 1
            proc.wait()
            if seen < len(part):
                lines.put((part[seen], "crashed", True))
                seen += 1
            part = part[seen:]
        lines.put(None)

    jobs = max(1, min(jobs, len(names)))
    for j in range(jobs):
        threading.Thread(target=slot, args=(names[j::jobs],), daemon=True).start()
    running = jobs if names else 0
    while running:
        item = lines.get()
        if item is None:
            running -= 1
        else:
            report(*item)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
