"""Every door into a scenario gives the same one-line error a scenario file gives.

A scenario built in Python, a run's overrides, an environment's keyword arguments and a sweep's
grid all go through the specs' own checks (``sim.scenario``). :data:`CASES` holds the problems a
file cannot express (a scenario built in Python with the wrong types) and the other doors; the
last test counts these lines with the corpus files' (``tests/scenarios/corpus/``) when it asks
that every check of the specs has a case."""

from __future__ import annotations

import ast
import dataclasses
import os
import re
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import pytest

import learning  # noqa: F401  (registers mrta/Allocation-v0)
from scenarios import loader
from scenarios.loader import load_scenario
from scenarios.protocol import RunSpec, execute
from sim import make_world
from sim.scenario import (
    LearningSpec,
    RobotSpec,
    Scenario,
    ScenarioError,
    SpatialSpec,
    StreamSpec,
    core,
    schema,
    spatial,
)
from sim.scenario import maps as scenario_maps
from sim.scenario.overrides import apply_overrides
from sim.spatial import layout


def tiny(**changes) -> Scenario:
    """Two robots, two types, built in Python."""
    base = dict(
        name="tiny",
        task_types=("A", "B"),
        robots=(RobotSpec("R1", (0,)), RobotSpec("R2", (0, 1))),
        cost=((1.0, float("inf")), (2.0, 2.0)),
        exec_time_s=(15.0, 15.0),
    )
    return Scenario(**{**base, **changes})


def arena(**changes) -> SpatialSpec:
    return SpatialSpec(**{"width_m": 10.0, "height_m": 8.0, **changes})


def spatial_tiny(**changes) -> Scenario:
    robots = (RobotSpec("R1", (0,), (2.0, 2.0)), RobotSpec("R2", (0, 1), (4.0, 2.0)))
    sites = (((6.0, 6.0),), ((8.0, 4.0),))
    obstacles = (((4.5, 4.5), (5.5, 4.5), (5.5, 5.5), (4.5, 5.5)),)
    spatial = arena(**{"obstacles": obstacles, "sites": sites, **changes.pop("spatial", {})})
    return tiny(robots=robots, spatial=spatial, **changes)


TB3 = Path(__file__).parents[2] / "scenarios" / "data" / "maps" / "tb3_sandbox.yaml"


def sweep_grid(tmp_path, grid: str) -> None:
    from scenarios.sweep.spec import load_sweep

    path = tmp_path / "s.toml"
    path.write_text(
        '[sweep]\nscenarios = ["paper_spatial"]\nallocators = ["market"]\nseeds = 1\n'
        f'costs = ["distance"]\n[grid]\n{grid}\n'
    )
    load_sweep(path)


CASES: list[tuple[str, Callable[..., object], str]] = [
    # -- a scenario built in Python ----------------------------------------------------------
    (
        "stream",
        lambda: StreamSpec(batch_min=-3),
        "stream.batch_min: must be in [1, 10,000], got -3",
    ),
    ("history", lambda: LearningSpec(history=0), "learning.history: must be in [1, 1000], got 0"),
    (
        "avoidance_word",
        lambda: arena(avoidance="orca-ish"),
        "spatial.avoidance: must be \"orca\" or \"none\"; got 'orca-ish' (did you mean 'orca'?)",
    ),
    ("type_of_int", lambda: StreamSpec(n_sets=2.5), "stream.n_sets: must be an integer, got 2.5"),
    ("name", lambda: tiny(name=""), "scenario.name: must be a non-empty string, got string ''"),
    ("no_types", lambda: tiny(task_types=()), "scenario.task_types: needs 1 to 200 entries, got 0"),
    (
        "spatial_type",
        lambda: tiny(spatial="hall"),
        "spatial: must be a SpatialSpec or None, got string 'hall'",
    ),
    ("robot_type", lambda: tiny(robots=("R1",)), "robots[0]: must be a RobotSpec, got string 'R1'"),
    (
        "capability_names",
        lambda: tiny(robots=(RobotSpec("R1", ("A",)), RobotSpec("R2", (0, 1)))),
        "robots[0].capabilities: must be a list of task type indices",
    ),
    (
        "capability_index",
        lambda: tiny(robots=(RobotSpec("R1", (5,)), RobotSpec("R2", (0, 1)))),
        "robots[0].capabilities: task type index 5 outside 0..1",
    ),
    ("cost_rows", lambda: tiny(cost=((1.0, 2.0),)), "robots: cost must have one row per robot (2)"),
    (
        "cost_row",
        lambda: tiny(cost=((1.0,), (2.0, 2.0))),
        "robots[0].cost: must have one entry per task type (2)",
    ),
    (
        "site_lists",
        lambda: spatial_tiny(spatial={"sites": (((6.0, 6.0),),)}),
        "spatial.sites: needs one list of points per task type (2)",
    ),
    (
        "sub_table",
        lambda: arena(orca="fast"),
        "spatial.orca: must be a OrcaSpec, got string 'fast'",
    ),
    (
        "layout_in_the_world",
        lambda: make_world(spatial_tiny(spatial={"sites": (((5.0, 5.0),), ((8.0, 4.0),))})),
        "spatial.sites.A[0]: (5, 5) is inside spatial.obstacles[0]",
    ),
    (
        "map_other_arena",
        lambda: SpatialSpec(width_m=19.2, height_m=19.2, map=str(TB3)),
        "spatial.map: tb3_sandbox.yaml is 19.200000000000003 x 19.200000000000003 m but the "
        "arena is 19.2 x 19.2 m: build it with SpatialSpec.on_map(path, ...)",
    ),
    (
        "map_without_its_cells",
        lambda: dataclasses.replace(SpatialSpec.on_map(TB3), obstacles=()),
        "spatial.map: the obstacles do not end with the 57 of tb3_sandbox.yaml: build it with "
        "SpatialSpec.on_map(path, ...)",
    ),
    (
        "map_with_width",
        lambda: SpatialSpec.on_map(TB3, width_m=10.0),
        "spatial.width_m: not allowed beside spatial.map: the map sets the arena",
    ),
    # -- overrides: a run, an environment, a sweep's grid ------------------------------------
    (
        "run_override",
        lambda: execute(RunSpec("paper", "expt", overrides=(("experience.delta_u", 7.5),))),
        "override: experience.delta_u: must be in [0, 2] (TEM lies in (0, 2)), got 7.5",
    ),
    (
        "override_history",
        lambda: execute(RunSpec("paper", "ql", overrides=(("learning.history", 0),))),
        "override: learning.history: must be in [1, 1000], got 0",
    ),
    (
        "override_unknown",
        lambda: apply_overrides(load_scenario("paper"), (("experience.delta_w", 0.1),)),
        "override: experience.delta_w: not a setting that can be overridden "
        "(did you mean 'experience.delta_v'?)",
    ),
    (
        "override_no_spatial",
        lambda: apply_overrides(load_scenario("paper"), (("spatial.orca.tau_s", 2.0),)),
        "override: spatial.orca.tau_s: 'paper' has no [spatial] table",
    ),
    (
        "override_spatial",
        lambda: apply_overrides(load_scenario("paper_spatial"), (("spatial.orca.tau_s", 0),)),
        "override: spatial.orca.tau_s: must be in [0.01, 60] s, got 0.0",
    ),
    (
        "env_keyword",
        lambda: gym.make("mrta/Allocation-v0", overrides=(("stream.batch_min", -3),)),
        "override: stream.batch_min: must be in [1, 10,000], got -3",
    ),
    (
        "sweep_grid",
        lambda tmp_path: sweep_grid(tmp_path, "spatial.orca.tau_s = [1.0, 0.0]"),
        "grid.spatial.orca.tau_s: must be in [0.01, 60] s, got 0.0 (scenario 'paper_spatial')",
    ),
]


def door_lines(tmp_path) -> list[str]:
    """The message of every case (for the corpus test's count of checks)."""
    out = []
    for _, thunk, _ in CASES:
        with pytest.raises(ScenarioError) as info:
            thunk(tmp_path) if thunk.__code__.co_argcount else thunk()
        out.append(str(info.value))
    return out


@pytest.mark.parametrize(("name", "thunk", "line"), CASES, ids=[c[0] for c in CASES])
def test_every_door_gives_the_file_s_one_line_error(name, thunk, line, tmp_path):
    with pytest.raises(ScenarioError) as info:
        thunk(tmp_path) if thunk.__code__.co_argcount else thunk()
    message = str(info.value)
    assert message.endswith(line), message
    assert "\n" not in message


def test_overrides_of_one_table_are_applied_together():
    """Three sets with two learning sets is one change, not 30 learning sets of 3."""
    sc = apply_overrides(
        load_scenario("paper"),
        (("stream.n_sets", 3), ("stream.learn_sets", 2), ("stream.test_sets", 1)),
    )
    assert (sc.stream.n_sets, sc.stream.learn_sets, sc.stream.test_sets) == (3, 2, 1)


def test_a_python_scenario_is_normalised_as_a_file_is():
    """Ints become floats where a float is meant; capabilities are kept sorted."""
    sc = tiny(exec_time_s=(15, 20), robots=(RobotSpec("R1", (0,)), RobotSpec("R2", (1, 0))))
    assert sc.exec_time_s == (15.0, 20.0) and type(sc.exec_time_s[0]) is float
    assert sc.robots[1].capabilities == (0, 1)
    stream = StreamSpec(announce_interval_s=10)
    assert type(stream.announce_interval_s) is float
    assert dataclasses.replace(stream, p_high=1).p_high == 1.0


def test_a_nested_setting_is_overridden_and_the_rest_kept():
    sc = load_scenario("paper_spatial")
    new = apply_overrides(sc, (("spatial.orca.tau_s", 2.0), ("spatial.avoidance", "none")))
    assert new.spatial.orca.tau_s == 2.0 and new.spatial.avoidance == "none"
    assert dataclasses.replace(new.spatial.orca, tau_s=sc.spatial.orca.tau_s) == sc.spatial.orca
    assert new.spatial.obstacles == sc.spatial.obstacles


CORPUS = sorted((Path(__file__).parent / "corpus").glob("*.toml"))


def pattern(node: ast.expr) -> str:
    """Regex for the text a message argument can produce: literal parts exact, the rest any."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return re.escape(node.value)
    if isinstance(node, ast.JoinedStr):
        return "".join(pattern(part) for part in node.values)
    return ".*?"


def loader_checks() -> list[tuple[str, str]]:
    """Every validation check of the loader: (where, regex of the line it gives).

    A check is a call of ``fail(key, problem)`` in the loader (``scenarios/loader.py``), the
    specs that check themselves (``sim/scenario/``) and the layout check
    (``sim/spatial/layout.py``).
    """
    out = []
    for module in (loader, schema, core, spatial, scenario_maps, layout):
        path = Path(module.__file__)
        for func in ast.walk(ast.parse(path.read_text())):
            if not isinstance(func, ast.FunctionDef):
                continue
            for call in ast.walk(func):
                if not (
                    isinstance(call, ast.Call)
                    and isinstance(call.func, ast.Name)
                    and call.func.id == "fail"
                ):
                    continue
                key, problem = call.args[:2]
                where = f"{path.name}:{call.lineno} ({func.name})"
                out.append((where, f": {pattern(key)}: {pattern(problem)}"))
    return out


def corpus_lines() -> list[str]:
    lines = []
    for path in CORPUS:
        with pytest.raises(ScenarioError) as info:
            loader.load_scenario(path)
        lines.append(str(info.value))
    return lines


@pytest.mark.skipif(
    "MUTANT_UNDER_TEST" in os.environ, reason="reads the loader's source, which mutmut rewrites"
)
def test_every_loader_check_has_a_corpus_file(tmp_path):
    """Every check is reached by a corpus file, or (a problem no file can express, a door other
    than a file) by a case of :data:`CASES` above."""
    checks = loader_checks()
    assert len(checks) >= 60  # the walk finds the checks (a refactor that hides them fails here)
    lines = corpus_lines() + [f"python: {line}" for line in door_lines(tmp_path)]
    missing = [w for w, rx in checks if not any(re.search(rx, line) for line in lines)]
    assert not missing, f"loader checks without a file in tests/scenarios/corpus/: {missing}"
