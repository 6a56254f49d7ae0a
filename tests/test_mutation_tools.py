"""The mutation-testing scripts (``tests/mutation/score.py``, ``tests/mutation/golden.py``) on a
hand-made ``mutants/`` folder: which survivors the golden check takes, and how the score
counts what it found."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

HERE = Path(__file__).parent / "mutation"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"mutation_{name}", HERE / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def fake_mutants(root: Path) -> None:
    meta = root / "sim" / "control" / "orca.py.meta"
    meta.parent.mkdir(parents=True)
    codes = {
        "sim.control.orca.x_solve__mutmut_1": 1,  # killed
        "sim.control.orca.x_solve__mutmut_2": 0,  # survived
        "sim.control.orca.x_solve__mutmut_3": 0,  # survived
        "sim.control.orca.x_command__mutmut_1": 0,  # survived
        "sim.control.orca.x_command__mutmut_2": None,  # not run
    }
    hashes = {"x_solve": "aaa", "x_command": "bbb"}
    meta.write_text(json.dumps({"exit_code_by_key": codes, "hash_by_function_name": hashes}))


def test_golden_check_takes_the_survivors_matching_with_their_function_s_hash(
    tmp_path, monkeypatch
):
    golden = load("golden")
    fake_mutants(tmp_path / "mutants")
    monkeypatch.chdir(tmp_path)
    assert golden.survivors(["*"]) == {
        "sim.control.orca.x_solve__mutmut_2": "aaa",
        "sim.control.orca.x_solve__mutmut_3": "aaa",
        "sim.control.orca.x_command__mutmut_1": "bbb",
    }
    assert golden.survivors(["sim.control.orca.x_command*"]) == {
        "sim.control.orca.x_command__mutmut_1": "bbb"
    }
    assert golden.survivors(["sim.contacts.*"]) == {}


def test_the_score_counts_survivors_the_golden_runs_kill_as_killed(tmp_path, monkeypatch):
    score = load("score")
    fake_mutants(tmp_path / "mutants")
    (tmp_path / "mutants" / "golden-kills.json").write_text(
        json.dumps(
            {
                "sim.control.orca.x_solve__mutmut_2": {"result": "killed", "hash": "aaa"},
                "sim.control.orca.x_solve__mutmut_3": {"result": "survived", "hash": "aaa"},
                "sim.control.orca.x_command__mutmut_1": {"result": "crashed", "hash": "bbb"},
            }
        )
    )
    monkeypatch.chdir(tmp_path)
    golden = score.golden_kills()
    assert golden == {"sim.control.orca.x_solve__mutmut_2", "sim.control.orca.x_command__mutmut_1"}
    kills = json.loads((tmp_path / "mutants" / "golden-kills.json").read_text())
    kills["sim.control.orca.x_command__mutmut_1"]["hash"] = "old"  # the function changed since
    (tmp_path / "mutants" / "golden-kills.json").write_text(json.dumps(kills))
    assert score.golden_kills() == {"sim.control.orca.x_solve__mutmut_2"}
    (codes,) = score.results().values()
    c = score.tally(codes, {}, golden)
    assert (c["killed"], c["by golden"], c["survived"], c["not run"]) == (3, 2, 1, 1)
    c = score.tally(codes, {"sim.control.orca.x_solve__mutmut_3": "why"}, golden)
    assert (c["killed"], c["survived"], c["equivalent"]) == (3, 0, 1)


def test_the_screen_fills_in_mutants_mutmut_has_not_run_and_its_survivors_go_to_golden(
    tmp_path, monkeypatch
):
    """``screen.py`` takes only the mutants mutmut has not run; ``score.py`` counts the screen's
    results for those (a screen survivor as a survivor) and ``golden.py`` takes its survivors,
    each only while the function's hash is the one the screen saw."""
    screen, score, golden = load("screen"), load("score"), load("golden")
    fake_mutants(tmp_path / "mutants")
    monkeypatch.chdir(tmp_path)
    assert screen.not_run(["*"]) == {"sim.control.orca.x_command__mutmut_2": "bbb"}
    assert screen.not_run(["sim.control.orca.x_solve*"]) == {}
    path = tmp_path / "mutants" / "screen.json"
    row = {"result": "survived", "hash": "bbb"}
    path.write_text(json.dumps({"sim.control.orca.x_command__mutmut_2": row}))
    assert score.screened() == {"sim.control.orca.x_command__mutmut_2": 0}
    assert "sim.control.orca.x_command__mutmut_2" in golden.survivors(["*"])
    (codes,) = score.results().values()
    c = score.tally(score.with_screen(codes, score.screened()), {})
    assert (c["killed"], c["survived"], c["not run"]) == (1, 4, 0)
    row["result"] = "killed"
    path.write_text(json.dumps({"sim.control.orca.x_command__mutmut_2": row}))
    c = score.tally(score.with_screen(codes, score.screened()), {})
    assert (c["killed"], c["survived"], c["not run"]) == (2, 3, 0)
    assert "sim.control.orca.x_command__mutmut_2" not in golden.survivors(["*"])
    row["hash"] = "old"  # the function changed since the screen: not run again
    path.write_text(json.dumps({"sim.control.orca.x_command__mutmut_2": row}))
    assert score.screened() == {}
    assert score.tally(score.with_screen(codes, score.screened()), {})["not run"] == 1


def test_a_mutant_that_kills_the_screen_s_python_counts_as_killed_and_the_rest_still_run():
    """A child Python that dies (a mutant aborting inside numpy's or scipy's C code) reports
    no more lines: the mutant it died on is reported crashed (``score.py``: "other", neither
    killed nor survived) and a new child screens the rest; every mutant is reported once."""
    screen = load("screen")
    dies_on = {"m3", "m4"}  # m4 right after m3: the new child dies at once too
    spawned = []

    class Child:
        def __init__(self, part):
            spawned.append(list(part))
            out = []
            for name in part:
                if name in dies_on:
                    break
                out.append(json.dumps([name, "survived" if name == "m2" else "killed"]))
            self.stdout = iter(out)

        def wait(self):
            return 0

    reported = []
    names = [f"m{k}" for k in range(1, 8)]
    screen.screen_all(names, 1, Child, lambda *row: reported.append(row))
    assert reported == [
        ("m1", "killed", False),
        ("m2", "survived", False),
        ("m3", "crashed", True),
        ("m4", "crashed", True),
        ("m5", "killed", False),
        ("m6", "killed", False),
        ("m7", "killed", False),
    ]
    assert spawned == [names, names[3:], names[4:]]
    reported.clear()
    screen.screen_all(names, 2, Child, lambda *row: reported.append(row))
    assert sorted(r[0] for r in reported) == names  # two children: each mutant once
    assert {r[0] for r in reported if r[2]} == dies_on
    assert screen.screen_all([], 2, Child, lambda *row: reported.append(row)) is None
    score = load("score")
    assert score.tally({"m3": score.SCREEN_CODES["crashed"]}, {})["other"] == 1


def test_two_screens_at_once_keep_each_other_s_results(tmp_path):
    """Each result is added to ``screen.json`` as the file is now, so a screen of another
    module that saved meanwhile keeps its results (each process used to write back the whole
    file as it had read it at its start)."""
    screen = load("screen")
    screen.save("a.x_f__mutmut_1", {"result": "killed", "hash": "h"}, tmp_path)
    screen.save("b.x_g__mutmut_1", {"result": "survived", "hash": "k"}, tmp_path)
    screen.save("a.x_f__mutmut_1", {"result": "survived", "hash": "h2"}, tmp_path)
    assert screen.load(tmp_path) == {
        "a.x_f__mutmut_1": {"result": "survived", "hash": "h2"},
        "b.x_g__mutmut_1": {"result": "survived", "hash": "k"},
    }
    assert sorted(p.name for p in tmp_path.iterdir()) == ["screen.json", "screen.lock"]


def test_the_screen_refuses_tests_that_fail_with_no_mutant_on(tmp_path, monkeypatch, capsys):
    """A wrong test id, or tests that fail on the unmutated code, would count every mutant
    killed: the screen runs its tests once with no mutant on first, and stops with exit code
    2 and one line if they do not pass, writing nothing."""
    screen = load("screen")
    fake_mutants(tmp_path / "mutants")
    monkeypatch.chdir(tmp_path)
    tests = tmp_path / "mutants" / "tests"
    tests.mkdir()
    (tests / "test_fine.py").write_text("def test_fine():\n    assert True\n")
    (tests / "test_broken.py").write_text("def test_broken():\n    assert False\n")
    for bad in (["tests/test_broken.py"], ["tests/test_missing.py"]):
        assert screen.main(["--tests", *bad, "*"]) == 2
        err = capsys.readouterr().err
        assert "do not pass with no mutant on" in err and len(err.strip().splitlines()) == 1
        assert not (tmp_path / "mutants" / "screen.json").exists()
    assert screen.main(["--tests", "tests/test_fine.py", "--jobs", "1", "*"]) == 0
    assert screen.load() == {  # the one mutant not run by mutmut, screened end to end
        "sim.control.orca.x_command__mutmut_2": {"result": "survived", "hash": "bbb"}
    }


def test_equivalents_of_a_changed_function_are_not_counted_until_read_again(
    tmp_path, monkeypatch, capsys
):
    """mutmut renumbers a changed function's mutants, so an entry of ``equivalent.toml`` may
    then name another mutation: entries count only while their function's hash is the one
    recorded when they were read, and ``--record-hashes`` records it again."""
    score = load("score")
    fake_mutants(tmp_path / "mutants")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(score, "HASHES", tmp_path / "hashes.json")
    equiv = {
        "sim.control.orca.x_solve__mutmut_2": "why",
        "sim.control.orca.x_command__mutmut_1": "why",
        "sim.other.x_gone__mutmut_1": "a module not generated here: kept",
    }
    (tmp_path / "hashes.json").write_text(json.dumps({"sim.control.orca.x_solve": "aaa"}))
    hashes = score.function_hashes(Path("mutants"))
    keep, lines = score.reviewed(equiv, hashes)
    assert set(keep) == {"sim.control.orca.x_solve__mutmut_2", "sim.other.x_gone__mutmut_1"}
    assert lines == [
        "function changed since its 1 entries were read (not counted): sim.control.orca.x_command"
    ]
    (tmp_path / "hashes.json").write_text(json.dumps({"sim.control.orca.x_solve": "old"}))
    keep, lines = score.reviewed(equiv, hashes)
    assert set(keep) == {"sim.other.x_gone__mutmut_1"} and len(lines) == 2
    monkeypatch.setattr(score, "equivalent", lambda: equiv)
    assert score.record_hashes(["*x_command"]) == 0
    recorded = json.loads((tmp_path / "hashes.json").read_text())
    assert recorded == {"sim.control.orca.x_solve": "old", "sim.control.orca.x_command": "bbb"}
    assert "recorded 1 function hashes" in capsys.readouterr().out


def test_the_score_reports_an_equivalent_the_screen_killed(tmp_path, monkeypatch):
    score = load("score")
    fake_mutants(tmp_path / "mutants")
    monkeypatch.chdir(tmp_path)
    runs = {"m": {"sim.control.orca.x_command__mutmut_2": score.SCREEN_CODES["killed"]}}
    assert score.stale(runs, {"sim.control.orca.x_command__mutmut_2": "why"}) == [
        "killed, yet listed as equivalent: sim.control.orca.x_command__mutmut_2"
    ]
