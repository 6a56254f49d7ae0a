"""Scenario validation and the CLI's error contract: one line, exit code 2, no traceback."""

from __future__ import annotations

import datetime
import hashlib
import tomllib
from pathlib import Path

import pytest

from scenarios.cli import main
from scenarios.loader import (
    ScenarioError,
    bundled_names,
    bundled_toml,
    did_you_mean,
    load_scenario,
    locate,
    parse_scenario,
    read_toml,
    resolve,
)

PAPER = load_scenario("paper").source


def variant(tmp_path, old: str, new: str, name: str = "bad.toml"):
    text = open(PAPER).read()
    assert old in text, old
    path = tmp_path / name
    path.write_text(text.replace(old, new, 1))
    return path


def run_cli(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


BAD = [
    ("p_high = 0.35", "p_hihg = 0.35", "stream.p_hihg: unknown key (did you mean 'p_high'?)"),
    ("p_high = 0.35", "p_high = 1.35", "stream.p_high: must be in [0, 1], got 1.35"),
    ("p_high = 0.35", "p_high = -0.1", "stream.p_high: must be in [0, 1], got -0.1"),
    ("n_sets = 45", 'n_sets = "45"', "stream.n_sets: must be a number, got string '45'"),
    ("n_sets = 45", "n_sets = -3", "stream.n_sets: must be in [1, 100,000], got -3"),
    ("alpha = 0.1", "alpha = nan", "learning.alpha: must be finite"),
    (
        'capabilities = ["T4", "T8"]',
        "capabilities = []",
        "robots[3].capabilities: needs 1 to 8 entries",
    ),
    ('name = "R4"', 'name = "R3"', "robots[3].name: duplicate robot name 'R3'"),
    (
        "cost = { T4 = 3, T8 = 9 }",
        "cost = { T4 = 3 }",
        "robots[3].cost: missing cost for capability 'T8'",
    ),
]


@pytest.mark.parametrize(("old", "new", "message"), BAD)
def test_bad_scenarios_one_line_exit_2(tmp_path, capsys, old, new, message):
    path = variant(tmp_path, old, new)
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"mrta: error: {path}: ")
    assert message in err


def test_type_no_robot_can_do(tmp_path):
    path = variant(tmp_path, '"T7", "T8"]\nexec_time_s', '"T7", "T8", "T9"]\nexec_time_s')
    text = path.read_text().replace("exec_time_s = [30.0,", "exec_time_s = [30.0, 30.0,", 1)
    path.write_text(text)
    with pytest.raises(ScenarioError, match="'T9' cannot be done by any robot"):
        load_scenario(path)


def test_unknown_capability_did_you_mean(tmp_path):
    path = variant(tmp_path, 'capabilities = ["T4", "T8"]', 'capabilities = ["T4", "t8"]')
    with pytest.raises(
        ScenarioError,
        match=r"robots\[3\].capabilities: unknown task type 't8' \(did you mean 'T8'\?\)",
    ):
        load_scenario(path)


def test_syntax_error(tmp_path, capsys):
    path = tmp_path / "broken.toml"
    path.write_text("[scenario\nname = 1\n")
    code, _, err = run_cli(capsys, "validate", str(path))
    assert code == 2 and "TOML syntax error" in err and err.count("\n") == 1


def test_missing_file(capsys, tmp_path):
    code, _, err = run_cli(capsys, "validate", str(tmp_path / "nope.toml"))
    assert code == 2 and "nope.toml: file not found" in err


def test_validate_checks_sweep_files_by_name_and_by_path(capsys):
    """10 seeds x 3 scenarios x 3 allocators x 1 cost x 2 avoidance settings; by path the
    same file as the bundled name, and a scenario beside it still reads as a scenario."""
    code, out, _ = run_cli(capsys, "validate", "avoidance_layouts")
    assert code == 0
    assert out.endswith(": ok: sweep 'avoidance_layouts', 180 runs (18 combinations x 10 seeds)\n")
    path = locate("avoidance", "sweeps")
    code, out, _ = run_cli(capsys, "validate", str(path), "warehouse")
    first, second = out.splitlines()
    assert code == 0
    assert first == f"{path}: ok: sweep 'avoidance', 60 runs (12 combinations x 5 seeds)"
    described = "ok: 'warehouse', 10 robots, 4 task types, 30 sets x 18 rounds, spatial"
    assert second.endswith(f": {described}")


def test_validate_names_a_bad_sweep_file_s_problem_in_one_line(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text('[sweep]\nscenarios = ["warehouse"]\nallocators = ["markt"]\nseeds = 2\n')
    code, out, err = run_cli(capsys, "validate", str(path))
    assert code == 2 and out == "" and err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"mrta: error: {path}: sweep.allocators[0]: unknown allocator 'markt'")


def test_unknown_bundled_name(capsys):
    code, _, err = run_cli(capsys, "reproduce", "--scenario", "papr")
    assert code == 2 and "did you mean 'paper'?" in err


def test_bad_arguments_exit_2(capsys):
    with pytest.raises(SystemExit) as info:
        main(["reproduce", "--seeds", "-4"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "mrta: error:" in err and "(see 'mrta reproduce --help')" in err
    assert err.count("\n") == 1


def test_unknown_argument_points_at_the_help_that_exists(capsys):
    """argparse reports arguments no command knows from the top parser: the hint must not
    read 'mrta mrta --help'."""
    with pytest.raises(SystemExit) as info:
        main(["run", "paper", "--sets", "0"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "unrecognized arguments: --sets 0" in err and "(see 'mrta --help')" in err
    assert "mrta mrta" not in err and err.count("\n") == 1


def test_distance_cost_needs_spatial_scenario(capsys):
    code, _, err = run_cli(capsys, "run", "paper", "--cost", "distance")
    assert code == 2 and "needs a spatial scenario" in err


@pytest.mark.parametrize("name", bundled_names())
def test_every_bundled_scenario_validates(capsys, name):
    code, out, _ = run_cli(capsys, "validate", name)
    assert code == 0 and ": ok: " in out


def test_a_folder_named_like_a_bundled_scenario_does_not_shadow_it(tmp_path, monkeypatch):
    """After `mrta reproduce --out paper` a folder `paper` exists; `paper` still means the
    bundled scenario, while an existing TOML file of that name would be taken as given."""
    from scenarios.loader import load_scenario

    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper").mkdir()
    assert load_scenario("paper").name == "paper"
    assert main(["validate", "paper"]) == 0


def test_bundled_files_are_listed_per_folder():
    assert bundled_names() == [
        "large",
        "paper",
        "paper_spatial",
        "scale1000",
        "warehouse",
        "warehouse_pickface",
        "warehouse_wide",
    ]
    assert bundled_toml() == bundled_names()
    assert bundled_toml("sweeps") == [
        "avoidance",
        "avoidance_layouts",
        "avoidance_seeds5_9",
        "avoidance_warehouse30",
        "avoidance_wide",
        "delta_u",
        "experience",
        "faults",
        "history",
        "look_ahead",
        "look_ahead_seeds5_9",
        "refusal_frontier",
        "refusal_load",
        "refusal_spatial",
        "spatial_costs",
    ]
    assert bundled_toml("no_such_folder") == []


def test_locate_takes_paths_as_given_and_names_from_the_bundle(tmp_path):
    assert locate("some/dir/name") == Path("some/dir/name")
    assert locate("missing.toml") == Path("missing.toml")
    assert locate(tmp_path) == tmp_path
    assert locate("paper") == Path(PAPER)
    assert locate("delta_u", "sweeps") == Path(PAPER).parent / "sweeps" / "delta_u.toml"
    assert locate("no_such_name") is None


def test_unknown_names_list_the_bundle_and_suggest():
    bundled = (
        "(bundled: large, paper, paper_spatial, scale1000, warehouse, warehouse_pickface,"
        " warehouse_wide)"
    )
    with pytest.raises(ScenarioError) as info:
        resolve("nope")
    assert str(info.value) == f"nope: no such scenario file or bundled scenario {bundled}"
    with pytest.raises(ScenarioError) as info:
        resolve("papr")
    assert "bundled scenario (did you mean 'paper'?) (bundled: " in str(info.value)
    assert did_you_mean("ALPHA", ["alpha", "gamma"]) == " (did you mean 'alpha'?)"
    assert did_you_mean("zzz", ["alpha", "gamma"]) == ""


def test_unreadable_file_and_the_checksum_of_what_was_read(tmp_path):
    with pytest.raises(ScenarioError) as info:
        read_toml(tmp_path)
    assert str(info.value) == f"{tmp_path}: cannot read (Is a directory)"
    sc = load_scenario(PAPER)
    assert (sc.name, sc.source) == ("paper", PAPER)
    assert sc.source_sha256 == hashlib.sha256(Path(PAPER).read_bytes()).hexdigest()


@pytest.mark.parametrize(
    ("value", "kind"),
    [([1], "a list"), ({"a": 1}, "a table"), (datetime.date(2024, 1, 2), "date")],
)
def test_wrong_types_are_named(value, kind):
    doc = tomllib.loads(Path(PAPER).read_text())
    doc["scenario"]["name"] = value
    with pytest.raises(ScenarioError) as info:
        parse_scenario(doc, source="x.toml")
    assert str(info.value) == f"x.toml: scenario.name: must be a non-empty string, got {kind}"


def paper_doc() -> dict:
    return tomllib.loads(Path(PAPER).read_text())


def parse_fails(doc: dict) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(doc, source="x.toml")
    return str(info.value)


def test_missing_name_and_times_and_the_top_level():
    doc = paper_doc()
    del doc["scenario"]["name"]
    assert parse_fails(doc) == "x.toml: scenario.name: missing"
    doc = paper_doc()
    del doc["scenario"]["exec_time_s"]
    assert parse_fails(doc) == "x.toml: scenario.exec_time_s: missing"
    err = ScenarioError.at("", "empty document").located("x.toml")
    assert str(err) == "x.toml: <top level>: empty document"
    assert (err.path, err.problem) == ("", "empty document")


def test_numbers_become_floats_and_booleans_stay_booleans():
    doc = paper_doc()
    doc["experience"]["sticky_b1"] = False
    sc = parse_scenario(doc)
    assert sc.cost[0][0] == 5.0 and all(type(c) is float for row in sc.cost for c in row)
    assert all(type(t) is float for t in sc.exec_time_s)
    assert sc.experience.sticky_b1 is False
    doc["experience"]["sticky_b1"] = "yes"
    assert parse_fails(doc) == (
        "x.toml: experience.sticky_b1: must be true or false, got string 'yes'"
    )


@pytest.mark.parametrize(
    ("table", "changes"),
    [
        ("stream", {"p_high": 1.0}),
        ("stream", {"n_sets": 1, "learn_sets": 1, "test_sets": 1, "rounds_per_set": 1}),
        ("stream", {"n_sets": 30, "learn_sets": 30, "test_sets": 30}),
        ("stream", {"n_sets": 1000, "rounds_per_set": 1000, "batch_max": 5}),  # 5,000,000 tasks
        ("learning", {"alpha": 1.0, "gamma": 0.0, "epsilon_start": 1.0, "epsilon_end": 0.0}),
        ("learning", {"reward_high": 0.0, "reward_low": 0.5, "penalty_lost_high": 0.0}),
        ("learning", {"history": 11}),  # R2 has 5 types: 5**11 = 48,828,125 states, under 5e7
        ("experience", {"delta_v": 0.0, "delta_u": 0.0}),
        ("experience", {"delta_v": 1.0, "delta_u": 2.0}),
    ],
)
def test_values_at_their_limits_are_accepted(table, changes):
    doc = paper_doc()
    doc[table].update(changes)
    sc = parse_scenario(doc)
    assert all(getattr(getattr(sc, table), k) == v for k, v in changes.items())


@pytest.mark.parametrize(
    ("table", "key", "value", "line"),
    [
        ("learning", "alpha", 1.5, "learning.alpha: must be in (0, 1]"),
        (
            "learning",
            "history",
            12,
            "learning.history: a robot's Q-table would have about 10^9 entries",
        ),
        (
            "learning",
            "history",
            13,
            "learning.history: a robot's Q-table would have about 10^9 entries",
        ),
        (
            "experience",
            "delta_u",
            2.5,
            "experience.delta_u: must be in [0, 2] (TEM lies in (0, 2))",
        ),
        (
            "scenario",
            "description",
            5,
            "scenario.description: must be a non-empty string, got number 5",
        ),
        ("scenario", "nmae", "x", "scenario.nmae: unknown key (did you mean 'name'?)"),
    ],
)
def test_values_beyond_their_limits_name_the_key(table, key, value, line):
    doc = paper_doc()
    doc[table][key] = value
    assert parse_fails(doc).startswith(f"x.toml: {line}")


def test_missing_tables_and_lists_and_the_default_source():
    doc = paper_doc()
    doc["strem"] = {}
    assert parse_fails(doc) == "x.toml: strem: unknown key (did you mean 'stream'?)"
    doc = paper_doc()
    del doc["robots"][0]["cost"]
    assert parse_fails(doc) == "x.toml: robots[0].cost: missing"
    doc = paper_doc()
    del doc["scenario"]["task_types"]
    assert parse_fails(doc) == "x.toml: scenario.task_types: missing"
    doc = paper_doc()
    doc["robots"][0]["capabilities"] = 5
    assert parse_fails(doc) == (
        "x.toml: robots[0].capabilities: must be a list of strings, got number 5"
    )
    sc = parse_scenario(paper_doc())
    assert (sc.source, sc.source_sha256) == ("<scenario>", "")
    doc = paper_doc()
    doc["stream"]["n_sets"] = 0
    with pytest.raises(ScenarioError) as info:
        parse_scenario(doc)
    assert str(info.value) == "<scenario>: stream.n_sets: must be in [1, 100,000], got 0"


def test_five_thousand_robots_are_allowed():
    robots = [{"name": f"R{j}", "capabilities": ["A"], "cost": {"A": 1}} for j in range(5000)]
    doc = {"scenario": {"name": "many", "task_types": ["A"], "exec_time_s": [1.0]}}
    assert parse_scenario({**doc, "robots": robots}).n_robots == 5000
