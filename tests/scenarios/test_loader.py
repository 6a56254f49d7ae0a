"""The scenario loader (``scenarios.loader``): bundled names and paths, and every check of a
scenario document with the one line it gives.

Also the keys added after the first mutation run: robot headings, the history limit, the
avoidance word, and how a name or path is located. Values on a bound are accepted, the first
beyond it is refused with one line naming the key path. ``mrta validate`` and the CLI's error
contract are in ``tests/cli/test_errors.py``."""

from __future__ import annotations

import datetime
import hashlib
import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

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
from tests.worlds import variant

PAPER = load_scenario("paper").source


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


def test_bundled_files_are_listed_per_folder():
    assert bundled_names() == [
        "depot",
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
        "bias_meetings",
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
        "traffic_paper",
        "traffic_warehouse",
        "wall_lines",
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
        "(bundled: depot, large, paper, paper_spatial, scale1000, warehouse, warehouse_pickface,"
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


def doc(name: str = "paper_spatial") -> dict:
    text = (resources.files("scenarios") / "data" / f"{name}.toml").read_text()
    return tomllib.loads(text)


def fails(d: dict) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(d, source="x.toml")
    return str(info.value)


@pytest.mark.parametrize(("value", "kept"), [(-360, -360.0), (360, 360.0), (-90.5, -90.5)])
def test_headings_on_the_bounds_are_kept_as_floats(value, kept):
    d = doc()
    d["robots"][2]["heading_deg"] = value
    sc = parse_scenario(d)
    assert sc.robots[2].heading_deg == kept
    assert type(sc.robots[2].heading_deg) is float
    assert [r.heading_deg for r in sc.robots[:2]] == [0.0, 0.0]


@pytest.mark.parametrize(
    ("value", "line"),
    [
        (-360.5, "robots[1].heading_deg: must be in [-360, 360] deg, got -360.5"),
        (360.5, "robots[1].heading_deg: must be in [-360, 360] deg, got 360.5"),
        ("north", "robots[1].heading_deg: must be a number, got string 'north'"),
    ],
)
def test_headings_beyond_a_full_turn_are_refused(value, line):
    d = doc()
    d["robots"][1]["heading_deg"] = value
    assert fails(d) == f"x.toml: {line}"


def one_type_doc(history: int) -> dict:
    """Every robot can do T1 only: the Q-table has one entry whatever the history."""
    d = doc("paper")
    for r in d["robots"]:
        r["capabilities"], r["cost"] = ["T1"], {"T1": 5}
    d["scenario"]["task_types"], d["scenario"]["exec_time_s"] = ["T1"], [30.0]
    d["learning"]["history"] = history
    return d


def test_history_up_to_the_limit_is_accepted_and_one_more_is_refused():
    assert parse_scenario(one_type_doc(1000)).learning.history == 1000
    assert fails(one_type_doc(1001)) == "x.toml: learning.history: must be in [1, 1000], got 1001"


def test_avoidance_words_are_kept():
    for word in ("orca", "none"):
        d = doc()
        d["spatial"]["avoidance"] = word
        assert parse_scenario(d).spatial.avoidance == word
    d = doc()
    d["spatial"].pop("avoidance", None)
    assert parse_scenario(d).spatial.avoidance == "orca"  # on unless a scenario says "none"


def test_look_ahead_is_on_unless_a_scenario_turns_it_off():
    d = doc()
    assert parse_scenario(d).spatial.look_ahead == "on"
    d["spatial"]["look_ahead"] = "off"
    assert parse_scenario(d).spatial.look_ahead == "off"
    d["spatial"]["look_ahead"] = True
    assert fails(d) == "x.toml: spatial.look_ahead: must be a string, got boolean true"


def test_locate_prefers_an_existing_file_then_the_bundle_then_a_path_shape(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    Path("notes").write_text("")
    assert locate("notes") == Path("notes")  # an existing file, however it is named
    Path("paper").mkdir()  # a folder of a bundled name does not shadow the bundle
    assert locate("paper") == Path(load_scenario("paper").source)
    Path("sweeps").mkdir()  # a name with '/' is never looked up in the bundle
    assert locate("sweeps/delta_u") == Path("sweeps/delta_u")
    assert locate("delta_u") is None  # bundled only in the sweeps folder
    Path("empty_dir").mkdir()  # an existing folder is given back as a path
    assert locate("empty_dir") == Path("empty_dir")


def test_a_grid_of_exactly_the_cell_limit_is_accepted():
    d = doc()
    d["spatial"].update(width_m=1000.0, height_m=1000.0, grid_res_m=0.5)  # 4,000,000 cells
    assert parse_scenario(d).spatial.grid_res_m == 0.5
    d["spatial"]["grid_res_m"] = 0.4999
    assert fails(d) == ("x.toml: spatial.grid_res_m: the grid would have more than 4,000,000 cells")


@pytest.mark.parametrize("x", [0.25 + 0.1, 20.0 - (0.25 + 0.1)])
def test_a_site_exactly_robot_radius_plus_clearance_from_a_wall_is_accepted(x):
    d = doc()  # paper_spatial: 20 m wide, robot radius 0.25 m, clearance 0.1 m
    d["spatial"]["sites"]["T1"][0] = [x, 10.0]
    assert parse_scenario(d).spatial.sites[0][0] == (x, 10.0)


def test_faults_by_robot_and_the_words_for_never():
    d = doc("paper")
    d["faults"] = {"mttf_s": "inf", "mttf_by_robot": {"R2": 500, "R7": "inf"}, "p_permanent": 1.0}
    sc = parse_scenario(d)
    assert sc.faults.mttf_s == float("inf")
    assert sc.faults.mttf_by_robot == (("R2", 500.0), ("R7", float("inf")))
    names = [r.name for r in sc.robots]
    per = sc.faults.mttf_per_robot(names)
    assert per[names.index("R2")] == 500.0 and np.isinf(np.delete(per, names.index("R2"))).all()
    assert sc.faults.p_permanent == 1.0  # the upper bound is allowed: every failure for good
    d["faults"] = {"mttf_s": float("inf")}
    assert parse_scenario(d).faults.mttf_s == float("inf")


@pytest.mark.parametrize(
    ("value", "part"),
    [
        (-0.1, "faults.p_permanent: must be in [0, 1], got -0.1"),
        (1.5, "faults.p_permanent: must be in [0, 1], got 1.5"),
        ("often", "faults.p_permanent"),
    ],
)
def test_faults_p_permanent_is_named_when_refused(value, part):
    d = doc("paper")
    d["faults"] = {"mttf_s": 600, "p_permanent": value}
    assert part in fails(d)


ROOT = Path(__file__).resolve().parents[2]


def test_heading_key_is_read_and_checked(tmp_path):
    src = (
        (ROOT / "scenarios/data/paper_spatial.toml")
        .read_text()
        .replace('name = "R1"\n', 'name = "R1"\nheading_deg = 45.0\n', 1)
    )
    path = tmp_path / "h.toml"
    path.write_text(src)
    sc = load_scenario(path)
    assert sc.robots[0].heading_deg == 45.0
    assert sc.robots[1].heading_deg == 0.0
    path.write_text(src.replace("heading_deg = 45.0", "heading_deg = 400.0"))
    with pytest.raises(ScenarioError, match=r"robots\[0\].heading_deg"):
        load_scenario(path)
