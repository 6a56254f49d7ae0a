"""Figures drawn from the data (``scenarios.experiments.figures``): the robot trace, the task
table of a spatial run, the places robots stood longest."""

from __future__ import annotations

import numpy as np
import pytest

from scenarios.experiments.figures import fig_robot_trace
from scenarios.protocol import RunSpec, run_many


def test_fig2_lines_are_the_trace():
    run = run_many([RunSpec("paper", "expt", seed=0, trace_robot="R5")], workers=1, progress=False)[
        0
    ]
    trace = run["trace"]
    fig = fig_robot_trace(trace)
    lines = {ln.get_gid(): ln for ax in fig.axes for ln in ax.get_lines() if ln.get_gid()}
    assert set(trace["capabilities"]) == {"T2", "T5", "T7", "T8"}
    tem = np.array(trace["tem"])
    for t in trace["capabilities"]:
        i = trace["task_types"].index(t)
        assert np.allclose(lines[f"tem|{t}"].get_ydata(), tem[:, i])
    assert np.array_equal(lines["space"].get_ydata(), trace["space"])
    assert trace["space"][0] == 512
    assert set(trace["space"]) <= {512, 162, 32, 2}  # 2 * n**4 for n = 4, 3, 2, 1


SHORT = (("stream.n_sets", 2), ("stream.learn_sets", 1), ("stream.test_sets", 1))


def test_run_figure_is_the_task_table():
    from scenarios.experiments.figures import fig_run_spatial
    from scenarios.protocol import RunSpec, execute

    out = execute(RunSpec("paper_spatial", "market", "distance", 0, SHORT), task_table=True)
    table = out["task_table"]
    assert len(table["task"]) == out["tasks"]["allocated"]
    fig = fig_run_spatial(table, out["spatial"], "distance")
    scatter = next(c for ax in fig.axes for c in ax.collections if c.get_gid() == "estimate")
    ok = np.asarray(table["ok"])
    assert np.allclose(
        scatter.get_offsets(), np.column_stack([table["bid"], table["distance_m"]])[ok]
    )
    bars = {
        p.get_x() + p.get_width() / 2: p.get_height()
        for ax in fig.axes
        for p in ax.patches
        if p.get_gid() == "distance"
    }
    assert sum(bars.values()) == pytest.approx(sum(table["distance_m"]))
    assert sum(table["distance_m"]) == pytest.approx(out["spatial"]["distance_m"])


def test_stall_places_are_the_longest_cells_and_the_panels_their_groups():
    """``stall_places`` against brute force over a random map (ties by row, then column;
    empty cells never named); each panel of ``fig_stall_map`` draws the sum of its causes."""
    from scenarios.experiments.figures import STALL_GROUPS, fig_stall_map, stall_places
    from sim.spatial.stalls import CAUSES

    rng = np.random.default_rng(7)
    seconds = rng.integers(0, 4, size=(len(CAUSES), 6, 9)).astype(float) * 0.5
    seconds[:, 2, 3] = seconds[:, 4, 1] = 0.0
    seconds[0, 2, 3] = seconds[0, 4, 1] = 99.0  # a tie: row 2 comes first
    cells = sorted(
        ((-seconds[:, r, c].sum(), r, c) for r in range(6) for c in range(9)),
    )
    got = stall_places(seconds, 0.5, k=5)
    assert [(p["y_m"], p["x_m"]) for p in got] == [(r * 0.5, c * 0.5) for _, r, c in cells[:5]]
    assert got[0]["seconds"] == 99.0 and got[0]["cause"] == CAUSES[0]
    assert (got[0]["y_m"], got[0]["x_m"]) == (1.0, 1.5)
    one = np.zeros((len(CAUSES), 6, 9))
    one[3, 5, 8] = 1.0
    assert [p["x_m"] for p in stall_places(one, 0.5, k=3)] == [4.0]  # empty cells are not named
    fig = fig_stall_map(seconds, 0.5, (4.5, 3.0), [((1.0, 1.0), (2.0, 1.0), (2.0, 2.0))])
    drawn = {im.get_gid(): im.get_array() for ax in fig.axes for im in ax.get_images()}
    for title, causes in STALL_GROUPS:
        want = seconds[[CAUSES.index(c) for c in causes]].sum(axis=0)
        assert np.array_equal(np.ma.filled(drawn[title], 0.0), want), title
