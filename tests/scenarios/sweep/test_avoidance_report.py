"""The before-and-after report of a sweep that varies collision avoidance (avoidance.md/json)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from scenarios.sweep.avoidance_report import (
    avoidance_rows,
    fig_avoidance,
    markdown,
    write_avoidance_report,
)

PARAMS = ("spatial.avoidance",)


def run(allocator, seed, avoidance, tasks, start, failed=0, touch=0.0, impact=0.0, wall=(0, 0)):
    return {
        "scenario": "warehouse",
        "allocator": allocator,
        "cost": "abstract",
        "seed": seed,
        "spatial.avoidance": avoidance,
        "tasks_allocated": tasks,
        "time_to_start_s": start,
        "failed_tasks": failed,
        "contacts_robot_touch_per_robot_h": touch,
        "contacts_robot_impact_per_robot_h": impact,
        "contacts_wall_touch_per_robot_h": wall[0],
        "contacts_wall_impact_per_robot_h": wall[1],
    }


@pytest.fixture
def records():
    """Market: three seeds on both sides and a fourth with avoidance only (not paired); the
    changes and counts are worked by hand in the test. QL: the same runs on both sides."""
    rs = [
        run("market", 0, "none", 100, 10.0, touch=60.0, impact=1.0, wall=(3.0, 0.0)),
        run("market", 1, "none", 110, 10.0, failed=1, touch=60.0, impact=1.0, wall=(3.0, 0.0)),
        run("market", 2, "none", 90, 10.0, touch=60.0, impact=1.0, wall=(3.0, 0.0)),
        run("market", 0, "orca", 98, 11.5, touch=0.5, wall=(0.2, 0.0)),
        run("market", 1, "orca", 105, 11.0, touch=0.5, impact=0.1, wall=(0.6, 0.0)),
        run("market", 2, "orca", 90, 11.0, failed=1, touch=0.5, wall=(0.1, 0.2)),
        run("market", 3, "orca", 10, 99.0, failed=9, touch=9.0, impact=9.0, wall=(9.0, 9.0)),
    ]
    rs += [run("ql", s, v, 100 + s, 10.0 + s) for s in range(2) for v in ("none", "orca")]
    return rs


def test_each_setting_is_compared_with_none_on_the_seeds_both_ran(records):
    rows = {r["allocator"]: r for r in avoidance_rows(records, PARAMS)}
    m = rows["market"]
    assert m["seeds"] == [0, 1, 2]  # seed 3 has no run without avoidance
    assert m["before"]["tasks_allocated"] == 100.0
    assert m["tasks_change"] == pytest.approx((98 + 105 + 90) / 300 - 1)
    # per-seed changes -2, -5, 0 points of the none mean (100): standard error 1.4530 points
    assert m["tasks_change_se"] == pytest.approx(0.014529663145135579)
    assert m["arrival_change"] == pytest.approx(33.5 / 30 - 1)  # +11.7 %
    assert m["before"]["failed_tasks"] == 1 and m["after"]["failed_tasks"] == 1
    assert m["after"]["seeds_without_impact"] == 2
    assert m["after"]["robot_impact_per_robot_h"] == pytest.approx(0.1 / 3)
    assert m["after"]["wall_per_robot_h"] == pytest.approx((0.2 + 0.6 + 0.3) / 3)
    assert m["after"]["wall_per_robot_h_max_seed"] == pytest.approx(0.6)
    assert m["targets"] == {
        "robot_contacts": True,  # 0.53 per robot-hour
        "impact_free": False,  # 2 of 3 seeds, below 80 %
        "wall_contacts": True,  # 0.37
        "tasks": True,  # -2.3 %
        "arrival": False,  # +11.7 %
        "failed": False,  # one failed task
    }
    q = rows["ql"]
    assert q["tasks_change"] == 0.0 and q["tasks_change_se"] == 0.0 and q["arrival_change"] == 0.0
    assert all(q["targets"].values())


def test_the_markdown_names_the_missed_targets(records):
    text = markdown(avoidance_rows(records, PARAMS))
    market = next(line for line in text.splitlines() if "| market |" in line)
    assert "| 100.0 / 97.7 | -2.3% (1.5) | 10.00 / 11.17 | +11.7% (" in market
    assert "| 1 / 1 |" in market and "| 2/3 |" in market and "| 0.37 (0.60) |" in market
    assert market.endswith(
        "| no robot-robot impact in >= 80% of seeds; time to arrival <= +10%; no failed task |"
    )
    ql = next(line for line in text.splitlines() if "| ql |" in line)
    assert ql.endswith("| none |")


def test_no_report_without_an_avoidance_baseline(records, tmp_path):
    assert avoidance_rows(records, ("experience.delta_u",)) == []
    only_orca = [r for r in records if r["spatial.avoidance"] == "orca"]
    assert avoidance_rows(only_orca, PARAMS) == []
    assert not write_avoidance_report(only_orca, PARAMS, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_runs_without_spatial_metrics_are_left_out(records):
    abstract = [dict(r, scenario="paper", time_to_start_s=None) for r in records]
    assert avoidance_rows(abstract, PARAMS) == []


def test_the_report_files_are_written_whole(records, tmp_path):
    assert write_avoidance_report(records, PARAMS, tmp_path)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["avoidance.json", "avoidance.md", "avoidance.png"]
    doc = json.loads((tmp_path / "avoidance.json").read_text())
    assert doc["baseline"] == "none" and len(doc["rows"]) == 2
    assert (tmp_path / "avoidance.md").read_text().count("| warehouse |") == 2


def test_another_swept_parameter_gets_its_own_column_and_rows(records):
    both = [dict(r, **{"stream.p_high": p}) for r in records for p in (0.2, 0.5)]
    params = ("stream.p_high", "spatial.avoidance")
    rows = avoidance_rows(both, params)
    assert sorted((r["allocator"], r["stream.p_high"]) for r in rows) == [
        ("market", 0.2),
        ("market", 0.5),
        ("ql", 0.2),
        ("ql", 0.5),
    ]
    header = markdown(rows, ["stream.p_high"]).splitlines()[3]
    assert header.startswith("| scenario | allocator | cost | stream.p_high | avoidance |")


def test_the_figure_draws_each_row_against_its_target(records):
    rows = {r["allocator"]: r for r in avoidance_rows(records, PARAMS)}
    fig = fig_avoidance(list(rows.values()))
    bars = {p.get_gid(): p.get_height() for ax in fig.axes for p in ax.patches}
    m = rows["market"]
    assert bars["tasks:warehouse:Market (MRTA)"] == pytest.approx(100 * m["tasks_change"])
    assert bars["arrival:warehouse:Market (MRTA)"] == pytest.approx(100 * m["arrival_change"])
    robot = m["after"]["robot_touch_per_robot_h"] + m["after"]["robot_impact_per_robot_h"]
    assert bars["robot:warehouse:Market (MRTA)"] == pytest.approx(robot)
    assert bars["wall:warehouse:Market (MRTA)"] == pytest.approx(m["after"]["wall_per_robot_h"])
    assert bars["tasks:warehouse:QL-MRTA"] == 0.0
    dashed = [
        line.get_ydata()[0] for ax in fig.axes for line in ax.lines if line.get_linestyle() == "--"
    ]
    assert dashed == pytest.approx([-3.0, 10.0, 1.0, 0.5])  # the targets, one per panel


def test_the_figure_puts_each_column_on_one_scale(records):
    """Rows of scenarios are compared column by column (``mrta sweep avoidance_layouts``): each
    panel of a column has the same y range, here one row losing half its tasks."""
    halved = [
        dict(r, scenario="warehouse_wide", tasks_allocated=r["tasks_allocated"] * 0.5)
        if r["spatial.avoidance"] != "none"
        else dict(r, scenario="warehouse_wide")
        for r in records
    ]
    fig = fig_avoidance(avoidance_rows(records + halved, PARAMS))
    axes = np.reshape(fig.axes, (2, 4))
    assert axes[1, 0].get_ylim()[0] < -40.0  # the halved row's bars
    for column in axes.T:
        assert column[0].get_ylim() == column[1].get_ylim()


def test_settings_that_act_only_with_avoidance_share_the_none_runs():
    """Points none+off, orca+off, orca+on (a sweep runs "none" once): the "on" runs are paired
    with the "none" runs of the "off" group; a parameter that also acts without avoidance
    (learning.history) is not bridged."""
    params = ("spatial.avoidance", "spatial.traffic.rules", "learning.history")

    def at(seed, avoidance, rules, tasks, history=4):
        return run("market", seed, avoidance, tasks, 10.0) | {
            "spatial.traffic.rules": rules,
            "learning.history": history,
        }

    records = [at(s, "none", "off", 100) for s in range(2)]
    records += [at(s, "orca", "off", 96) for s in range(2)]
    records += [at(s, "orca", "on", 99) for s in range(2)]
    records += [at(s, "orca", "on", 50, history=3) for s in range(2)]  # no none run of its own
    rows = avoidance_rows(records, params)
    found = {(r["spatial.traffic.rules"], r["learning.history"]): r for r in rows}
    assert set(found) == {("off", 4), ("on", 4)}
    assert found["off", 4]["tasks_change"] == pytest.approx(-0.04)
    assert found["on", 4]["tasks_change"] == pytest.approx(-0.01)
    assert found["on", 4]["before"]["tasks_allocated"] == 100.0
