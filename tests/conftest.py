"""Shared fixtures: the paper scenario (whole and short), a tiny hand-built one, a synthetic
trajectory, a small sweep file; and the 'measured by the tests' lines printed after the summary.

The suite runs on every core (pytest-xdist, ``-n auto`` in pyproject.toml). Before the workers
start, the control kernel is compiled once (or loaded) in the controlling process, so that no
two workers compile it at once and a subprocess never meets a cache half written.

Small worlds and the helpers that act on them are in ``tests/worlds.py``; fixtures of one
folder in that folder's ``conftest.py`` (``tests/sim/render``, ``tests/allocation``).
"""

from __future__ import annotations

import dataclasses

import pytest

from scenarios.loader import load_scenario
from sim.scenario import RobotSpec, Scenario, StreamSpec

pytest_plugins = ["pytester"]  # tests/test_suite_setup.py runs a small suite of its own


@pytest.fixture(scope="session")
def paper() -> Scenario:
    return load_scenario("paper")


@pytest.fixture(scope="session")
def small_paper(paper) -> Scenario:
    """The paper scenario with a short stream: 6 sets (4 learn, last 3 test) of 6 rounds."""
    stream = dataclasses.replace(
        paper.stream, n_sets=6, rounds_per_set=6, learn_sets=4, test_sets=3
    )
    exp = dataclasses.replace(paper.experience, n_min=3, delta_u=0.5)
    return dataclasses.replace(paper, stream=stream, experience=exp)


@pytest.fixture(scope="module")
def synth():
    """A synthetic trajectory (``scenarios.bench.synthetic``): 10 robots, 60 s, 20 tasks."""
    import numpy as np

    from scenarios.bench.synthetic import synthetic_trajectory

    return synthetic_trajectory(np.random.default_rng(7), robots=10, seconds=60.0, tasks=20)


@pytest.fixture()
def tiny() -> Scenario:
    """Three robots, two types: R1 {A}, R2 {A, B}, R3 {B}."""
    return Scenario(
        name="tiny",
        task_types=("A", "B"),
        robots=(RobotSpec("R1", (0,)), RobotSpec("R2", (0, 1)), RobotSpec("R3", (1,))),
        cost=((1.0, float("inf")), (2.0, 2.0), (float("inf"), 1.0)),
        exec_time_s=(15.0, 15.0),
        stream=StreamSpec(
            n_sets=4, rounds_per_set=5, learn_sets=3, test_sets=2, batch_min=1, batch_max=3
        ),
    )


@pytest.fixture()
def abstract_file(tmp_path):
    """The small sweep file of the abstract world (``tests.worlds.ABSTRACT_SWEEP``), written."""
    from tests.worlds import ABSTRACT_SWEEP

    path = tmp_path / "abstract.toml"
    path.write_text(ABSTRACT_SWEEP)
    return path


MEASURED = "measured by the tests"  # the user property a report line travels in
REPORT_KEY = pytest.StashKey[list]()


def pytest_configure(config):
    """In the process that hands tests to xdist's workers: compile or load the kernel now."""
    if config.getoption("numprocesses", default=None) and not hasattr(config, "workerinput"):
        from sim.spatial.control.kernel.loading import ensure_compiled

        ensure_compiled()
    config.stash[REPORT_KEY] = []
    config.pluginmanager.register(ReportLines(config.stash[REPORT_KEY]), "report-lines")


@pytest.fixture()
def report_line(request):
    """Add a line to the 'measured by the tests' section printed after the test summary (it
    travels with the test's report, so a line written in an xdist worker is printed too)."""

    def add(text: str) -> None:
        request.node.user_properties.append((MEASURED, text))

    return add


class ReportLines:
    """Collects the report lines from the tests' last reports, in the order they end."""

    def __init__(self, lines: list[str]) -> None:
        self.lines = lines

    def pytest_runtest_logreport(self, report):
        if report.when == "teardown":
            self.lines += [text for key, text in report.user_properties if key == MEASURED]


def pytest_terminal_summary(terminalreporter, exitstatus, config):
    lines = config.stash.get(REPORT_KEY, [])
    if lines:
        terminalreporter.section(MEASURED)
        for line in lines:
            terminalreporter.write_line(line)
