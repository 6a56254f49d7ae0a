"""mrta reproduce end to end (small), its files, and figures drawn from metrics.json."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.experiments.figures import fig_completion


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper")
    code = main(["reproduce", "--seeds", "3", "--out", str(out), "--workers", "2", "--no-progress"])
    assert code == 0
    return out, json.loads((out / "metrics.json").read_text())


@pytest.mark.slow
def test_writes_every_file(reproduced):
    out, _ = reproduced
    for name in ("metrics.json", "fig1_completion.png", "fig2_r5.png", "table2.md", "tradeoff.png"):
        assert (out / name).stat().st_size > 1000 or name == "table2.md"
    table = (out / "table2.md").read_text()
    assert "| R5 |" in table and "Paper Table 2" in table and "550" in table


@pytest.mark.slow
def test_metrics_schema_and_exact_spaces(reproduced, paper):
    _, m = reproduced
    assert m["scenario"] == "paper" and m["cost_model"] == "abstract" and m["seeds"] == [0, 1, 2]
    assert set(m["allocators"]) == {"market", "ql", "expt"}
    for agg in m["allocators"].values():
        comp = agg["completion"]
        assert set(comp["overall"]) == {"low", "high", "all"}
        assert set(comp["by_type"]) == set(paper.task_types)
        assert len(comp["per_seed"]["overall"]["all"]) == 3
        assert comp["overall"]["all"] == pytest.approx(np.mean(comp["per_seed"]["overall"]["all"]))
        assert comp["ci95"]["overall"]["all"] > 0
        assert agg["tasks"]["allocated"] <= agg["tasks"]["announced"]
    ql = m["allocators"]["ql"]["learning_space"]
    assert ql["initial"] == 3498 and ql["final"] == 3498
    assert ql["per_robot_initial"]["R5"] == 512 and ql["per_robot_initial"]["R2"] == 1250
    assert 23.0 < ql["joint_log10"] < 23.2
    expt = m["allocators"]["expt"]
    assert expt["learning_space"]["final"] < 3498
    assert set(expt["experienced_tasks"]) == {r.name for r in paper.robots}
    assert len(m["tradeoff"]["points"]) >= 2


@pytest.mark.slow
def test_fig1_bars_are_metrics(reproduced):
    _, m = reproduced
    fig = fig_completion(m)
    bars = [p for ax in fig.axes for p in ax.patches if p.get_gid()]
    assert len(bars) == 3 * 8 * 2
    for bar in bars:
        name, t, prio = bar.get_gid().split("|")
        assert bar.get_height() == pytest.approx(
            m["allocators"][name]["completion"]["by_type"][t][prio]
        )


@pytest.mark.slow
def test_tradeoff_points_are_drawn_from_the_data(reproduced):
    from scenarios.experiments.figures import fig_tradeoff
    from scenarios.experiments.reproduce import tradeoff_point

    _, m = reproduced
    points = m["tradeoff"]["points"]
    refs = {a: tradeoff_point(None, m["allocators"][a]) for a in ("market", "ql")}
    fig = fig_tradeoff(points, refs)
    line = next(ln for ln in fig.axes[0].get_lines() if ln.get_gid() == "expt")
    assert np.allclose(line.get_xdata(), [p["space"] for p in points])
    assert np.allclose(line.get_ydata(), [p["all"] for p in points])
    du = sorted(p["delta_u"] for p in points)
    assert du == [p["delta_u"] for p in points]  # sorted by the threshold
    default = next(p for p in points if p["delta_u"] == 0.08)
    assert default["all"] == m["allocators"]["expt"]["completion"]["overall"]["all"]


def test_stream_file_replays_the_same_tasks(tmp_path, capsys):
    stream = tmp_path / "stream.csv"
    assert main(["stream", "paper", "--seed", "3", "--out", str(stream)]) == 0
    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["run", "paper", "--allocator", "market", "--seed", "3", "--out", str(a)]) == 0
    assert (
        main(["run", "paper", "--allocator", "market", "--stream", str(stream), "--out", str(b)])
        == 0
    )
    ma = json.loads((a / "metrics.json").read_text())["allocators"]["market"]
    mb = json.loads((b / "metrics.json").read_text())["allocators"]["market"]
    assert ma["completion"] == mb["completion"] and ma["tasks"] == mb["tasks"]
