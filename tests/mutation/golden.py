"""Mutants that survived mutmut's tests, run again against the golden runs.

mutmut picks the tests for a mutant by which tests called the mutated function during its stats
run, in its own process. The golden runs (``tests/test_golden.py``) compute their cases in a
child Python, so mutmut never sees them call anything and never selects them, though they
catch any change to the pymunk world's trajectories bit for bit. This script gives each
survivor that chance: it computes the golden cases in a child Python of the mutated copy
(``mutants/``, with ``MUTANT_UNDER_TEST`` set, as mutmut does) and compares trajectories and
metrics with ``tests/golden/golden.json``.

Run after ``mutmut run`` from the project root::

    python tests/mutation/golden.py "sim.control.*" "sim.contacts.*"   # survivors matching
    python tests/mutation/score.py                                      # counts them killed

Results go to ``mutants/golden-kills.json`` (mutant name -> "killed", "survived" or "crashed",
with the hash of the mutated function as mutmut recorded it, so a result is dropped when the
function changes). By default only the cases with collision avoidance on run (about 10 s a
mutant); ``--cases all`` runs every case.
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

MUTANTS = Path("mutants")
OUT = MUTANTS / "golden-kills.json"
SURVIVED = 0


def survivors(patterns: list[str]) -> dict[str, str]:
    """Survivor name -> hash of its function, for the names matching any of ``patterns``:
    mutmut's survivors and, of the mutants it has not run, those that survived the screen
    (``tests/mutation/screen.py``, the same function hash)."""
    screen_path = MUTANTS / "screen.json"
    screen = json.loads(screen_path.read_text()) if screen_path.exists() else {}
    out = {}
    for meta in sorted(MUTANTS.rglob("*.py.meta")):
        doc = json.loads(meta.read_text())
        hashes = doc.get("hash_by_function_name", {})
        for name, code in doc["exit_code_by_key"].items():
            digest = hashes.get(name.rsplit("__mutmut_", 1)[0].rsplit(".", 1)[1], "")
            row = screen.get(name, {})
            if code is None and row.get("result") == "survived" and row.get("hash") == digest:
                code = SURVIVED
            if code != SURVIVED or not any(fnmatch.fnmatchcase(name, p) for p in patterns):
                continue
            out[name] = digest
    return out


def load() -> dict[str, dict[str, str]]:
    return json.loads(OUT.read_text()) if OUT.exists() else {}


def check(name: str, cases: list[str]) -> str:
    """Run the golden cases with mutant ``name`` active; "killed" if any number or trajectory
    differs from golden.json, "crashed" if the child failed, else "survived"."""
    from tests.golden.cases import GOLDEN, compute_portable  # the copy in mutants/ (main)
    from tests.test_golden import canonical

    want = json.loads(GOLDEN.read_text())
    try:
        got = compute_portable(cases, env={"MUTANT_UNDER_TEST": name})
    except RuntimeError:
        return "crashed"  # the mutant broke the run: caught, though not by a comparison
    same = all(
        got[n].get("trajectory") == want[n].get("trajectory")
        and canonical(got[n]["summary"]) == canonical(want[n]["summary"])
        for n in cases
    )
    return "survived" if same else "killed"


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("patterns", nargs="*", default=["*"], help="mutant name patterns")
    parser.add_argument("--jobs", type=int, default=2, help="child Pythons at once (default 2)")
    parser.add_argument(
        "--cases", choices=("orca", "all"), default="orca", help="golden cases to run"
    )
    args = parser.parse_args(argv)
    if not MUTANTS.is_dir():
        print("no mutants/ here: run mutmut first, from the project root", file=sys.stderr)
        return 2
    sys.path.insert(0, str(MUTANTS.resolve()))
    from tests.golden.cases import CASES

    cases = [c[0] for c in CASES if args.cases == "all" or "orca" in c[0]]
    todo = survivors(args.patterns)
    done = load()
    todo = {n: h for n, h in todo.items() if done.get(n, {}).get("hash") != h}
    print(f"{len(todo)} survivors to run against {len(cases)} golden cases", flush=True)

    def one(item):
        name, digest = item
        return name, {"result": check(name, cases), "hash": digest}

    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        for k, (name, row) in enumerate(pool.map(one, todo.items()), 1):
            done[name] = row
            tmp = OUT.with_suffix(".tmp")
            tmp.write_text(json.dumps(done, indent=1, sort_keys=True) + "\n")
            tmp.replace(OUT)
            print(f"[{k}/{len(todo)}] {row['result']:8s} {name}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
