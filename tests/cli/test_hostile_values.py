"""Hostile numbers in every numeric key of the bundled scenarios: refused in one line, or run.

Every numeric setting (each declared with a finite range in ``sim.scenario``) of every bundled
scenario gets zero, negative numbers, NaN, the infinities, 1e308, the smallest subnormal and
the integer types' edges. Each value must be refused with one line naming the key (exit 2 on
the command line), or be accepted and then run a short protocol to completion within a time
limit: never a traceback, never a hang.
"""

from __future__ import annotations

import math
import re
import signal
import tomllib
from contextlib import contextmanager
from importlib import resources
from pathlib import Path

import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from scenarios.cli import main
from scenarios.loader import bundled_names, parse_scenario
from sim.scenario import ScenarioError
from sim.scenario.schema import settings_of, tables_of, value_type
from sim.scenario.spatial import SpatialSpec

HOSTILE = (
    0,
    0.0,
    -1,
    -1e-9,
    math.nan,
    math.inf,
    -math.inf,
    1e308,
    5e-324,
    2**31 - 1,
    2**63 - 1,
    -(2**63),
)
SHORT = {"n_sets": 1, "learn_sets": 1, "test_sets": 1, "rounds_per_set": 2}
LIMIT_S = 60.0  # a short protocol that takes longer has hung


def raw(name: str) -> dict:
    return tomllib.loads((resources.files("scenarios") / "data" / f"{name}.toml").read_text())


def numeric_keys(doc: dict) -> list[str]:
    """Every numeric key a scenario file of this shape may hold, as a path into the document."""
    from scenarios.loader import SECTIONS

    keys = ["scenario.exec_time_s.0", "robots.0.heading_deg"]
    for section, cls in SECTIONS.items():
        keys += [f"{section}.{f.name}" for f, _ in settings_of(cls) if _numeric(f)]
    if "spatial" in doc:
        keys += [f"spatial.{f.name}" for f, _ in settings_of(SpatialSpec) if _numeric(f)]
        for t in tables_of(SpatialSpec):
            cls = t.default_factory
            keys += [f"spatial.{t.name}.{f.name}" for f, _ in settings_of(cls) if _numeric(f)]
    return keys


def _numeric(f) -> bool:
    return value_type(f) in (int, float)


def own_range_holds(key: str, value) -> bool:
    """True if ``value`` is a number of the key's type within its declared range (then a
    refusal may come from a rule between keys, naming another)."""
    from scenarios.loader import SECTIONS
    from sim.scenario import RobotSpec, Scenario
    from sim.scenario.schema import check_value

    parts = key.split(".")
    if parts[0] == "scenario":
        f = Scenario.__dataclass_fields__["exec_time_s"]
        kind = float
    elif parts[0] == "robots":
        f = RobotSpec.__dataclass_fields__["heading_deg"]
        kind = float
    else:
        cls = SECTIONS.get(parts[0], SpatialSpec)
        for name in parts[1:-1]:
            cls = cls.__dataclass_fields__[name].default_factory
        f = cls.__dataclass_fields__[parts[-1]]
        kind = value_type(f)
    try:
        check_value(value, kind, f.metadata["setting"], key)
    except ScenarioError:
        return False
    return True


def with_value(doc: dict, key: str, value) -> dict:
    """A deep copy of ``doc`` with ``key`` (dotted; list indices as numbers) set to ``value``."""
    out = tomllib.loads(tomli_w.dumps(doc))
    parts = key.split(".")
    node = out
    for part in parts[:-1]:
        node = node[int(part)] if isinstance(node, list) else node.setdefault(part, {})
    last = parts[-1]
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value
    return out


def short(doc: dict, key: str) -> dict:
    """The document with a short stream (unless ``key`` is one of the stream's counts), and
    its map (if any) named by its full path, so the document may be written anywhere."""
    stream = doc.setdefault("stream", {})
    if not key.startswith("stream."):
        stream.update(SHORT)
    spatial = doc.get("spatial", {})
    if "map" in spatial:
        spatial["map"] = str(resources.files("scenarios") / "data" / spatial["map"])
    return doc


@contextmanager
def time_limit(seconds: float):
    def hung(signum, frame):
        raise TimeoutError(f"no result within {seconds:g} s: a hang")

    old = signal.signal(signal.SIGALRM, hung)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("name", ["paper", "paper_spatial"])
def test_every_hostile_value_of_every_numeric_key_is_refused_in_one_line_or_taken(name):
    """Through the file door (``parse_scenario``): a refusal is a ScenarioError naming the key;
    anything else (a traceback) fails."""
    doc = raw(name)
    keys = numeric_keys(doc)
    assert len(keys) > (80 if name == "paper_spatial" else 25)
    taken = 0
    for key in keys:
        for value in HOSTILE:
            try:
                parse_scenario(with_value(doc, key, value), source="x.toml")
                taken += 1
            except ScenarioError as err:
                line = str(err)
                assert "\n" not in line and re.match(r"x\.toml: [\w.\[\]]+: \S", line), line
                shown = key.replace(".0.", "[0].").replace(".0", "[0]")
                if not own_range_holds(key, value):  # its own range refuses it: named
                    assert f": {shown}: " in line, (key, value, line)
    assert taken > 0  # some hostile values are fine (0 where 0 is allowed, say)


CASES = [
    (name, key, value)
    for name in bundled_names()
    for key in numeric_keys(raw(name))
    for value in HOSTILE
]


@pytest.mark.slow
@settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(case=st.sampled_from(CASES))
def test_a_hostile_value_runs_a_short_protocol_or_exits_2_with_one_line(case, tmp_path, capsys):
    name, key, value = case
    doc = short(with_value(raw(name), key, value), key)
    path = tmp_path / f"{name}.toml"
    path.write_text(tomli_w.dumps(doc))
    out = tmp_path / f"out_{abs(hash((key, repr(value))))}"
    with time_limit(LIMIT_S):
        code = main(["run", str(path), "--allocator", "market", "--out", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if code == 2:
        lines = [ln for ln in err.splitlines() if ln.startswith("mrta: error:")]
        assert len(lines) == 1, err
    else:
        assert code == 0, err
        assert (out / "metrics.json").is_file()


def test_the_time_limit_fires():
    """The limit the protocol test relies on does stop a loop that never ends."""
    with pytest.raises(TimeoutError), time_limit(0.2):
        while True:
            pass


def test_the_test_walks_nested_keys_and_list_entries():
    doc = {"scenario": {"exec_time_s": [1.0, 2.0]}, "spatial": {"orca": {"tau_s": 1.5}}}
    got = with_value(with_value(doc, "scenario.exec_time_s.0", 7.0), "spatial.orca.tau_s", 3.0)
    assert got == {"scenario": {"exec_time_s": [7.0, 2.0]}, "spatial": {"orca": {"tau_s": 3.0}}}
    assert doc["scenario"]["exec_time_s"][0] == 1.0  # a copy
    assert Path


def test_a_map_scenario_written_elsewhere_still_finds_its_map(tmp_path):
    """The depot's map is named relative to its file: the protocol test writes the document
    elsewhere, so ``short`` names the map by its full path (or every depot case would be
    refused as a missing map, and none would run)."""
    from scenarios.loader import load_scenario

    path = tmp_path / "depot.toml"
    path.write_text(tomli_w.dumps(short(raw("depot"), "scenario.exec_time_s.0")))
    assert Path(load_scenario(path).spatial.map).is_file()
