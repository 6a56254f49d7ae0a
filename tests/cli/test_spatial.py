"""Spatial commands on the command line: ``mrta render`` and its one-line errors, and the
``--avoidance`` and ``--look-ahead`` options of every spatial command."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from scenarios.cli import main


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
