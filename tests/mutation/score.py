"""Mutation score per module from mutmut's results (README, "Testing").

Run after ``mutmut run`` from the project root::

    python tests/mutation/score.py            # table of every mutated module
    python tests/mutation/score.py --survivors  # ... and the names of the survivors

Score = killed / (killed + survived), where mutants listed in ``equivalent.toml`` beside this
file (a mutant that no test can tell from the original, each with its one-line reason) are
counted apart and left out. Timeouts are counted apart too (a mutant that makes the code hang
is caught, but not by an assertion); mutants not run yet are shown as "not run". A survivor
that the golden runs kill (``tests/mutation/golden.py``, run after mutmut: mutmut cannot select
the golden tests) counts as killed, and the "by golden" column says how many of them.
Mutants mutmut has not run take the result of ``tests/mutation/screen.py`` where it has one
(killed by the screen's tests; one that survived the screen counts as a survivor, so the score
of a screened module is a lower bound), and the "screened" column says how many.

mutmut numbers mutants within their function, so when a function changes its numbers shift and
an entry of ``equivalent.toml`` may name another mutation. ``equivalent-hashes.json`` keeps the
hash of each function as it was when its entries were read; an entry of a function whose hash
differs now is not counted as equivalent (it takes its run's result) and is reported, until it
is read again and the hash recorded::

    python tests/mutation/score.py --record-hashes "sim.tasks.x_save_stream"
"""

from __future__ import annotations

import json
import sys
import tomllib
from collections import Counter
from pathlib import Path

KILLED, SURVIVED = {1, 3}, {0}
TIMEOUT = {24, -24, 36, 152, 255}
HERE = Path(__file__).parent


def equivalent() -> dict[str, str]:
    """Mutant name -> why it cannot be killed."""
    with open(HERE / "equivalent.toml", "rb") as f:
        return tomllib.load(f)["equivalent"]


HASHES = HERE / "equivalent-hashes.json"


def function_of(name: str) -> str:
    """``sim.tasks.x_save_stream__mutmut_7`` -> ``sim.tasks.x_save_stream``."""
    return name.rsplit("__mutmut_", 1)[0]


def reviewed(equiv: dict[str, str], hashes: dict[str, str]) -> tuple[dict[str, str], list[str]]:
    """The entries of ``equiv`` whose function is as it was when they were read, and a line
    for each function that changed since (its entries are left out until read again)."""
    recorded = json.loads(HASHES.read_text()) if HASHES.exists() else {}
    keep, changed = {}, Counter()
    for name, why in equiv.items():
        fn = function_of(name)
        now = hashes.get(fn)
        if now is not None and recorded.get(fn) != now:
            changed[fn] += 1
        else:
            keep[name] = why
    lines = [
        f"function changed since its {n} entries were read (not counted): {fn}"
        for fn, n in sorted(changed.items())
    ]
    return keep, lines


def record_hashes(patterns: list[str], root: Path = Path("mutants")) -> int:
    """Record the current hash of the functions matching ``patterns`` (after reading their
    entries in ``equivalent.toml`` again)."""
    import fnmatch

    hashes = function_hashes(root)
    recorded = json.loads(HASHES.read_text()) if HASHES.exists() else {}
    fns = {function_of(n) for n in equivalent()}
    done = sorted(
        fn for fn in fns if fn in hashes and any(fnmatch.fnmatch(fn, p) for p in patterns)
    )
    for fn in done:
        recorded[fn] = hashes[fn]
    HASHES.write_text(json.dumps(dict(sorted(recorded.items())), indent=1) + "\n")
    print(f"recorded {len(done)} function hashes")
    return 0


def results(root: Path = Path("mutants")) -> dict[str, dict[str, int | None]]:
    """Module path -> {mutant name: exit code (None = not run)}."""
    out = {}
    for meta in sorted(root.rglob("*.py.meta")):
        codes = json.loads(meta.read_text())["exit_code_by_key"]
        out[str(meta.relative_to(root)).removesuffix(".meta")] = codes
    return out


def golden_kills(root: Path = Path("mutants")) -> set[str]:
    """Survivors that the golden runs kill (``tests/mutation/golden.py``: mutmut cannot select
    those tests, which run their cases in a child Python), or whose run they crash; only
    results for the function as mutmut last generated it (its hash unchanged)."""
    path = root / "golden-kills.json"
    if not path.exists():
        return set()
    hashes = function_hashes(root)
    rows = json.loads(path.read_text())
    return {
        name
        for name, row in rows.items()
        if row["result"] in ("killed", "crashed")
        and hashes.get(name.rsplit("__mutmut_", 1)[0]) == row["hash"]
    }


SCREEN_CODES = {"killed": 1, "survived": 0, "timeout": 24, "crashed": -6}  # SIGABRT: other


def screened(root: Path = Path("mutants")) -> dict[str, int]:
    """Mutant name -> exit code as the screen found it (``tests/mutation/screen.py``), for
    results of the function as mutmut last generated it (its hash unchanged)."""
    path = root / "screen.json"
    if not path.exists():
        return {}
    hashes = function_hashes(root)
    return {
        name: SCREEN_CODES[row["result"]]
        for name, row in json.loads(path.read_text()).items()
        if hashes.get(name.rsplit("__mutmut_", 1)[0]) == row["hash"]
    }


def function_hashes(root: Path) -> dict[str, str]:
    """Mangled function name (module.function) -> the hash mutmut recorded for it."""
    hashes = {}
    for meta in root.rglob("*.py.meta"):
        doc = json.loads(meta.read_text())
        module = str(meta.relative_to(root)).removesuffix(".py.meta").replace("/", ".")
        for fn, digest in doc.get("hash_by_function_name", {}).items():
            hashes[f"{module}.{fn}"] = digest
    return hashes


def with_screen(codes: dict[str, int | None], screen: dict[str, int]) -> dict[str, int | None]:
    """``codes`` with the screen's result for each mutant mutmut has not run."""
    return {n: screen.get(n) if c is None else c for n, c in codes.items()}


def tally(codes: dict[str, int | None], equiv: dict[str, str], golden=frozenset()) -> Counter:
    c = Counter()
    for name, code in codes.items():
        if name in equiv:
            c["equivalent"] += 1
        elif code in KILLED:
            c["killed"] += 1
        elif code in SURVIVED and name in golden:
            c["killed"] += 1
            c["by golden"] += 1
        elif code in SURVIVED:
            c["survived"] += 1
        elif code in TIMEOUT:
            c["timeout"] += 1
        elif code is None:
            c["not run"] += 1
        else:
            c["other"] += 1
    return c


def stale(runs: dict[str, dict[str, int | None]], equiv: dict[str, str]) -> list[str]:
    """Entries of ``equivalent.toml`` that are wrong now: a mutant a test (or the screen)
    killed, so it is not equivalent, or a name that no mutated module has any more (mutant
    names are numbered within their function and shift when it changes) -- only for modules
    that were run."""
    out = []
    for codes in runs.values():
        if not any(code is not None for code in codes.values()):
            continue
        prefix = next(iter(codes)).split(".x", 1)[0] + ".x" if codes else ""
        for name in equiv:
            if name in codes and codes[name] in KILLED:
                out.append(f"killed, yet listed as equivalent: {name}")
            elif name.startswith(prefix) and name not in codes:
                out.append(f"no such mutant any more: {name}")
    return out


def main(argv: list[str]) -> int:
    if argv[:1] == ["--record-hashes"]:
        return record_hashes(argv[1:] or ["*"])
    golden, screen = golden_kills(), screened()
    equiv, changed = reviewed(equivalent(), function_hashes(Path("mutants")))
    cols = ("killed", "by golden", "survived", "equivalent", "timeout", "not run", "other")
    print(f"{'module':30s} " + " ".join(f"{c:>10s}" for c in cols) + "      score   screened")
    for module, mutmut_codes in results().items():
        codes = with_screen(mutmut_codes, screen)
        n_screened = sum(c is None and n in screen for n, c in mutmut_codes.items())
        c = tally(codes, equiv, golden)
        decided = c["killed"] + c["survived"]
        score = f"{100 * c['killed'] / decided:6.1f}%" if decided else "     -"
        counts = " ".join(f"{c[k]:10d}" for k in cols)
        print(f"{module:30s} {counts}    {score} {n_screened:10d}")
        if "--survivors" in argv:
            for name, code in codes.items():
                if code in SURVIVED and name not in equiv and name not in golden:
                    print(f"    survived: {name}")
    runs = {m: with_screen(codes, screen) for m, codes in results().items()}
    for line in changed + stale(runs, equiv):
        print(f"equivalent.toml: {line}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
