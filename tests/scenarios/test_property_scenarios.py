"""Property test: random scenarios either load and run, or fail with a clean ScenarioError."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from allocation.costs import make_cost_model
from learning import ALLOCATORS
from learning.episode import run_protocol
from scenarios.loader import ScenarioError, parse_scenario
from sim.tasks import generate_stream
from sim.world import AbstractWorld


@st.composite
def valid_docs(draw):
    n = draw(st.integers(1, 5))
    types = [f"T{i + 1}" for i in range(n)]
    m = draw(st.integers(1, 6))
    robots = []
    for j in range(m):
        caps = draw(st.lists(st.sampled_from(types), min_size=1, max_size=n, unique=True))
        robots.append(
            {
                "name": f"R{j + 1}",
                "capabilities": caps,
                "cost": {t: draw(st.floats(0, 20, allow_nan=False)) for t in caps},
            }
        )
    covered = {t for r in robots for t in r["capabilities"]}
    for t in types:  # make every type doable
        if t not in covered:
            robots[0]["capabilities"].append(t)
            robots[0]["cost"][t] = 1.0
    batch_min = draw(st.integers(1, 4))
    return {
        "scenario": {
            "name": "prop",
            "task_types": types,
            "exec_time_s": [draw(st.floats(0, 50)) for _ in types],
        },
        "robots": robots,
        "stream": {
            "batch_min": batch_min,
            "batch_max": batch_min + draw(st.integers(0, 3)),
            "p_high": draw(st.floats(0, 1)),
            "n_sets": 3,
            "rounds_per_set": 3,
            "learn_sets": 2,
            "test_sets": 2,
            "announce_interval_s": draw(st.floats(0.5, 20)),
        },
        "learning": {"history": draw(st.integers(1, 3)), "alpha": draw(st.floats(0.01, 1))},
        "experience": {
            "delta_u": draw(st.floats(0, 2)),
            "n_min": draw(st.integers(1, 5)),
            "coverage_k": draw(st.integers(1, 3)),
        },
    }


BAD_VALUES = [None, "text", True, -1, 0, -0.5, math.nan, math.inf, 10**12, [], {}, [1, 2], {"x": 1}]


def paths(doc, prefix=()):
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield (*prefix, k)
            yield from paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield (*prefix, i)
            yield from paths(v, (*prefix, i))


@st.composite
def mutated_docs(draw):
    doc = copy.deepcopy(draw(valid_docs()))
    all_paths = list(paths(doc))
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(all_paths))
        parent = doc
        try:
            for key in path[:-1]:
                parent = parent[key]
            action = draw(st.sampled_from(["set", "delete", "unknown"]))
            if action == "set":
                parent[path[-1]] = draw(st.sampled_from(BAD_VALUES))
            elif action == "delete" and isinstance(parent, dict):
                del parent[path[-1]]
            elif isinstance(parent, dict):
                parent[f"{path[-1]}x"] = 1
        except (KeyError, IndexError, TypeError):
            continue
    return doc


def run_briefly(scenario):
    for name, cls in ALLOCATORS.items():
        stream = generate_stream(scenario, np.random.default_rng(0))
        alloc = cls(scenario)
        alloc.reset(np.random.default_rng(1))
        rec = run_protocol(
            scenario,
            stream,
            alloc,
            AbstractWorld(scenario),
            make_cost_model("abstract", scenario),
            np.random.default_rng(2),
        )
        ids, _ = rec.test.arrays()
        tested = list(scenario.test_set_indices())
        assert ids.size == int(np.isin(stream.set_index, tested).sum()), name


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(valid_docs())
def test_valid_scenarios_load_and_run(doc):
    run_briefly(parse_scenario(doc))


@pytest.mark.slow
@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_docs())
def test_mutated_scenarios_load_and_run_or_fail_cleanly(doc):
    try:
        scenario = parse_scenario(doc, source="prop.toml")
    except ScenarioError as exc:
        message = str(exc)
        assert message.startswith("prop.toml: ") and "\n" not in message
        return
    run_briefly(scenario)
