"""Allocators from outside the package: module:Class names, entry points, clear errors."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from learning.registry import allocator_class, available
from scenarios.experiments.compare import compare

DOC = Path(__file__).resolve().parents[2] / "docs" / "allocators.md"


SHORT = (("stream.n_sets", 6), ("stream.learn_sets", 4), ("stream.test_sets", 3))


@pytest.fixture()
def user_module(tmp_path, monkeypatch):
    """The worked example of docs/allocators.md, as the user's own module on sys.path."""
    code = re.search(r"```python\n(\"\"\"An allocator of my own.*?)```", DOC.read_text(), re.S)
    assert code, "docs/allocators.md lost its worked example"
    (tmp_path / "my_alloc.py").write_text(code.group(1))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield tmp_path
    sys.modules.pop("my_alloc", None)


def test_the_documented_example_runs_through_compare(user_module, tmp_path):
    names = ["market", "greedy", "cbba", "my_alloc:Budget"]
    doc = compare("paper", ["abstract"], names, [0, 1], tmp_path / "out", workers=1,
                  progress=False, overrides=SHORT)  # fmt: skip
    rows = {r["allocator"]: r for r in doc["rows"].values()}
    assert set(rows) == set(names)
    budget = allocator_class("my_alloc:Budget")
    assert budget.name == "budget"
    # dropping every bid over 6 can only lose tasks against the market on the same streams
    assert rows["my_alloc:Budget"]["all"] <= rows["market"]["all"]
    written = json.loads((tmp_path / "out" / "compare.json").read_text())
    assert "my_alloc:Budget" in {r["allocator"] for r in written["rows"].values()}


def test_budget_allocator_never_gives_a_task_over_budget(user_module, paper):
    from sim.tasks import Batch
    from sim.world import WorldState

    alloc = allocator_class("my_alloc:Budget")(paper)
    alloc.reset(np.random.default_rng(0))
    costs = np.array([[3.0, 7.0]] + [[np.inf, np.inf]] * (paper.n_robots - 1))
    state = WorldState(0.0, np.ones(paper.n_robots, bool), np.zeros(paper.n_robots))
    batch = Batch(0, 0, np.arange(2), np.array([0, 0]), np.array([False, True]), np.zeros((2, 2)))
    assignment, _ = alloc.allocate(state, batch, costs)
    assert assignment.tolist() == [0, -1] and alloc.skipped_ == 1


def test_an_installed_entry_point_is_found_by_name(user_module, monkeypatch):
    dist = user_module / "my_alloc_pkg-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: my-alloc-pkg\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text("[expt_mrta.allocators]\nbudget = my_alloc:Budget\n")
    assert "budget" in available()
    assert allocator_class("budget").__name__ == "Budget"


def test_the_builtins_are_registered_as_entry_points():
    from learning.registry import BUILTIN_ALLOCATORS, installed

    eps = installed()
    for name, cls in BUILTIN_ALLOCATORS.items():
        assert eps.get(name) == f"{cls.__module__}:{cls.__name__}"
