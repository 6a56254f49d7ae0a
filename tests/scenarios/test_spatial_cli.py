"""Spatial commands end to end on short runs: render, compare, soak."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from scenarios.cli import main
from scenarios.experiments.compare import compare, fig_compare
from scenarios.experiments.output import strict_json
from scenarios.experiments.soak import soak

SHORT = (("stream.n_sets", 2), ("stream.learn_sets", 1), ("stream.test_sets", 1))


def test_render_cli_writes_a_gif(tmp_path, capsys):
    gif = tmp_path / "run.gif"
    code = main(
        [
            "render",
            "paper_spatial",
            "--sets",
            "1",
            "--frames",
            "12",
            "--size",
            "240x240",
            "--from",
            "10",
            "--to",
            "120",
            "--gif",
            str(gif),
            "--trajectory",
            str(tmp_path / "t.npz"),
        ]
    )
    assert code == 0, capsys.readouterr().err
    with Image.open(gif) as im:
        assert im.n_frames == 12 and im.size == (240, 240)
        frames = []
        for k in (0, 11):
            im.seek(k)
            frames.append(np.asarray(im.convert("RGB")))
    assert not np.array_equal(frames[0], frames[1])
    assert (tmp_path / "t.npz").stat().st_size > 0


def test_render_cli_bad_window_is_one_line(tmp_path, capsys):
    code = main(
        [
            "render",
            "paper_spatial",
            "--sets",
            "1",
            "--from",
            "500",
            "--to",
            "100",
            "--gif",
            str(tmp_path / "x.gif"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 2 and "--from" in err and err.count("\n") == 1
    assert not (tmp_path / "x.gif").exists()


def test_render_needs_spatial_scenario(tmp_path, capsys):
    code = main(["render", "paper", "--gif", str(tmp_path / "x.gif")])
    assert code == 2 and "needs a spatial scenario" in capsys.readouterr().err


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    out = tmp_path_factory.mktemp("compare")
    doc = compare(
        "paper_spatial",
        ["abstract", "distance"],
        ["market", "expt"],
        [0, 1],
        out,
        workers=2,
        progress=False,
        overrides=SHORT,
    )
    return out, doc


def test_compare_writes_table_and_plot(compared):
    out, doc = compared
    assert json.loads((out / "compare.json").read_text()) == strict_json(doc)  # NaN -> null
    assert set(doc["rows"]) == {
        "abstract/market",
        "abstract/expt",
        "distance/market",
        "distance/expt",
    }
    for row in doc["rows"].values():
        assert 0 < row["all"] <= 1 and row["distance_m"] > 0 and row["high_wait_s"] > 0
    assert np.isnan(doc["rows"]["abstract/market"]["space"])
    assert doc["rows"]["distance/expt"]["space"] <= 3498
    assert "| distance | market |" in (out / "compare.md").read_text()


def test_distance_bids_drive_less_than_abstract_bids(compared):
    _, doc = compared
    rows = doc["rows"]
    assert rows["distance/market"]["distance_m"] < rows["abstract/market"]["distance_m"]


def test_compare_figure_is_the_data(compared):
    _, doc = compared
    fig = fig_compare(doc)
    bars = [p for ax in fig.axes for p in ax.patches if p.get_gid()]
    assert len(bars) == 6 * 4
    for bar in bars:
        key, cost, alloc = bar.get_gid().split("|")
        value = doc["rows"][f"{cost}/{alloc}"][key]
        if not np.isnan(value):
            assert bar.get_height() == pytest.approx(value)


def test_soak_short():
    result = soak("large", tasks=400, progress=False)
    assert result["tasks_announced"] >= 400
    assert result["tasks_allocated"] <= result["tasks_announced"]
    assert result["tasks_failed"] == 0
    assert result["max_overlap_m"] <= 0.01
    assert result["rss_growth_mib"] < 50


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


def test_avoidance_is_on_by_default_and_the_option_switches_it_off(capsys):
    """`--avoidance none` gives the proximity law alone (robots touching every minute or so);
    without the option a spatial run steers with ORCA."""
    seen = {}
    for extra in ([], ["--avoidance", "none"], ["--avoidance", "orca"]):
        argv = ["soak", "--scenario", "paper_spatial", "--tasks", "90", "--cost", "abstract"]
        assert main([*argv, *extra, "--json"]) == 0
        seen[tuple(extra)] = json.loads(capsys.readouterr().out)
    default, none, orca = seen.values()
    machine = ("wall_s", "rtf", "rss_growth_mib", "rss_peak_mib_at_10pct", "rss_peak_mib_at_100pct")
    assert default == {**orca, **{k: default[k] for k in machine}}  # the same run
    assert (
        none["collisions_robot"] >= 20 and orca["collisions_robot"] * 10 < none["collisions_robot"]
    )


@pytest.mark.parametrize("command", ["run", "compare", "reproduce", "soak", "render"])
def test_every_spatial_command_takes_avoidance(command):
    from scenarios.cli.commands import avoidance_overrides
    from scenarios.cli.parser import build_parser

    head = {"run": ["run", "paper_spatial"], "compare": ["compare", "paper_spatial"]}
    head.update(render=["render", "paper_spatial", "--gif", "x.gif"], reproduce=["reproduce"])
    argv = head.get(command, [command])
    parser = build_parser()
    assert avoidance_overrides(parser.parse_args(argv)) == ()
    args = parser.parse_args([*argv, "--avoidance", "none"])
    assert avoidance_overrides(args) == (("spatial.avoidance", "none"),)
    with pytest.raises(SystemExit):
        parser.parse_args([*argv, "--avoidance", "rvo"])
    args = parser.parse_args([*argv, "--look-ahead", "on", "--avoidance", "orca"])
    want = (("spatial.avoidance", "orca"), ("spatial.look_ahead", "on"))
    assert avoidance_overrides(args) == want
    with pytest.raises(SystemExit):
        parser.parse_args([*argv, "--look-ahead", "yes"])


def test_avoidance_on_a_scenario_without_space_is_one_line(tmp_path, capsys):
    out = tmp_path / "run"
    code = main(["run", "paper", "--avoidance", "none", "--no-progress", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and not out.exists()
    assert "override: spatial.avoidance: 'paper' has no [spatial] table" in err
    code = main(["run", "paper", "--look-ahead", "on", "--no-progress", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and not out.exists()
    assert "override: spatial.look_ahead: 'paper' has no [spatial] table" in err


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
