"""Scenario keys added after the first mutation run: robot headings, the history limit, the
avoidance word, and how a name or path is located. Values on a bound are accepted, the first
beyond it is refused with one line naming the key path."""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from scenarios.loader import ScenarioError, load_scenario, locate, parse_scenario


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


def test_look_ahead_is_off_unless_a_scenario_turns_it_on():
    d = doc()
    assert parse_scenario(d).spatial.look_ahead == "off"
    d["spatial"]["look_ahead"] = "on"
    assert parse_scenario(d).spatial.look_ahead == "on"
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
