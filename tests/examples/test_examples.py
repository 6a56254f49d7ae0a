"""The scripts in examples/ run from an empty folder with --quick and write what they promise.

Each example runs in a subprocess (this interpreter: the package is installed in it) with a
fresh ``tmp_path`` as working directory. A new example must be added to ``OUTPUTS`` (the files
it writes) so that the test knows what to check. About 25 s in all on two cores.
"""

from __future__ import annotations

import ast
import csv
import importlib.util
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
SCRIPTS = sorted(EXAMPLES.glob("[0-9][0-9]_*.py"))
HAS_PETTINGZOO = importlib.util.find_spec("pettingzoo") is not None
TIMEOUT_S = 180  # each --quick run takes seconds; this only stops a hang

OUTPUTS = {  # example -> files it writes into the working directory
    "01_spatial_allocators.py": (
        "spatial_tasks.csv",
        "spatial_completion.csv",
        "spatial_allocators.png",
    ),
    "02_custom_allocator.py": ("custom_allocator.csv",),
    "03_gymnasium_loop.py": ("gym_episode.csv", "gym_frame.png"),
    "04_render_gif.py": ("arena_12x8.toml", "arena_12x8.gif"),
    "05_pettingzoo.py": ("pettingzoo_team.csv", "pettingzoo_agents.csv") if HAS_PETTINGZOO else (),
}
MAGIC = {".png": b"\x89PNG\r\n\x1a\n", ".gif": b"GIF8"}


def run_example(script: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess:
    result = subprocess.run(
        [sys.executable, str(script), "--quick", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
    )
    assert result.returncode == 0, f"{script.name} exited {result.returncode}:\n{result.stderr}"
    return result


def read_csv(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert rows, f"{path.name} has no rows"
    return rows


def assert_ratios(rows: list[dict[str, str]], where: str) -> None:
    """Every ``completion_*`` column holds a ratio in [0, 1]."""
    keys = [k for k in rows[0] if k.startswith("completion_")]
    assert keys, f"{where}: no completion columns"
    for row in rows:
        for k in keys:
            v = float(row[k])
            assert math.isfinite(v) and 0.0 <= v <= 1.0, f"{where}: {k} = {row[k]}"


def check_01(cwd: Path, result: subprocess.CompletedProcess) -> None:
    runs = read_csv(cwd / "spatial_completion.csv")
    assert_ratios(runs, "spatial_completion.csv")
    assert {(r["allocator"], r["seed"]) for r in runs} == {
        (a, s) for a in ("market", "ql", "expt") for s in ("0", "1")
    }
    tasks = read_csv(cwd / "spatial_tasks.csv")
    assert all(float(t["distance_m"]) >= 0.0 for t in tasks if t["ok"] == "True")
    for r in runs:  # the task table holds every allocated test-phase task of the run
        mine = [t for t in tasks if (t["allocator"], t["seed"]) == (r["allocator"], r["seed"])]
        assert len(mine) == int(r["allocated"])


TABLE_ROW = re.compile(r"^\| (\S+) +\| +([\d.]+) \| +([\d.]+) \| +([\d.]+) \|$")


def check_02(cwd: Path, result: subprocess.CompletedProcess) -> None:
    assert_ratios(read_csv(cwd / "custom_allocator.csv"), "custom_allocator.csv")
    rows = [m.groups() for m in map(TABLE_ROW.match, result.stdout.splitlines()) if m]
    names = [r[0] for r in rows]
    assert {"market", "expt", "02_custom_allocator:KeepGeneralists"} <= set(names), names
    assert all(0.0 <= float(v) <= 1.0 for r in rows for v in r[1:])
    # the same seeds give the same table and file, run again in another folder
    again = cwd / "again"
    again.mkdir()
    second = run_example(EXAMPLES / "02_custom_allocator.py", again)
    assert second.stdout == result.stdout
    assert (again / "custom_allocator.csv").read_bytes() == (
        cwd / "custom_allocator.csv"
    ).read_bytes()


def check_03(cwd: Path, result: subprocess.CompletedProcess) -> None:
    rows = read_csv(cwd / "gym_episode.csv")
    assert_ratios(rows, "gym_episode.csv")
    assert {r["policy"] for r in rows} == {"always_bid", "keep_reserve", "random_bids"}
    assert len({r["steps"] for r in rows}) == 1 and int(rows[0]["steps"]) > 0  # one stream
    with Image.open(cwd / "gym_frame.png") as im:
        assert im.size[0] > 100 and im.size[1] > 100


def check_04(cwd: Path, result: subprocess.CompletedProcess) -> None:
    from scenarios.loader import load_scenario

    sc = load_scenario(cwd / "arena_12x8.toml")
    assert (sc.n_robots, sc.n_types, len(sc.spatial.obstacles)) == (4, 2, 1)
    assert (sc.spatial.width_m, sc.spatial.height_m) == (12.0, 8.0)
    assert "refused" in result.stdout  # the broken copy was rejected ...
    assert not (cwd / "arena_12x8_broken.toml").exists()  # ... and removed
    with Image.open(cwd / "arena_12x8.gif") as im:
        assert im.n_frames == 20


def check_05(cwd: Path, result: subprocess.CompletedProcess) -> None:
    if not HAS_PETTINGZOO:
        assert "skipped" in result.stdout
        return
    team = read_csv(cwd / "pettingzoo_team.csv")
    assert_ratios(team, "pettingzoo_team.csv")
    agents = read_csv(cwd / "pettingzoo_agents.csv")
    for t in team:  # team return = sum of the agents' returns
        mine = [float(a["return"]) for a in agents if a["policy"] == t["policy"]]
        assert len(mine) == 10
        assert math.isclose(sum(mine), float(t["team_return"]), abs_tol=1e-6)


CHECKS = {
    "01_spatial_allocators.py": check_01,
    "02_custom_allocator.py": check_02,
    "03_gymnasium_loop.py": check_03,
    "04_render_gif.py": check_04,
    "05_pettingzoo.py": check_05,
}


def test_examples_found():
    assert len(SCRIPTS) >= 4, f"examples missing in {EXAMPLES}"


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_example_runs_quick(script: Path, tmp_path: Path):
    assert script.name in OUTPUTS, f"add {script.name} and the files it writes to OUTPUTS"
    doc = ast.get_docstring(ast.parse(script.read_text()))
    assert doc and "--quick" in doc, f"{script.name}: the docstring must say how to run it"

    result = run_example(script, tmp_path)
    for name in OUTPUTS[script.name]:
        path = tmp_path / name
        assert path.is_file() and path.stat().st_size > 0, f"{script.name} did not write {name}"
        magic = MAGIC.get(path.suffix)
        if magic is not None:
            assert path.read_bytes().startswith(magic), f"{name} is not a {path.suffix} file"
    if script.name in CHECKS:
        CHECKS[script.name](tmp_path, result)


def test_pettingzoo_example_without_pettingzoo(tmp_path: Path):
    """Without the optional extra the PettingZoo example says so and exits 0, writing nothing."""
    script = EXAMPLES / "05_pettingzoo.py"
    if not script.exists():
        pytest.skip("no PettingZoo example")
    hide = (
        "import runpy, sys; sys.modules['pettingzoo'] = None; "  # import pettingzoo now fails
        f"sys.argv = [{str(script)!r}, '--quick']; "
        f"runpy.run_path({str(script)!r}, run_name='__main__')"
    )
    result = subprocess.run(
        [sys.executable, "-c", hide], cwd=tmp_path, capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    assert "pettingzoo" in result.stdout.lower()
    assert not any(tmp_path.iterdir())
