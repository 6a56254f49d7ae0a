"""``mrta hardcase``: one-line errors with exit code 2, the JSON and the GIF, jittered starts over
seeds. The hard cases themselves are in ``tests/behaviour/test_hardcases.py``."""

from __future__ import annotations

import json

import pytest
from PIL import Image

from scenarios.cli.app import main


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["circl"], "hard case 'circl' unknown (did you mean 'circle'?)"),
        (["junction", "--robots", "5"], "hard case junction takes exactly 4 robots, got 5"),
        (["circle", "--robots", "51"], "hard case circle takes 2 to 50 robots, got 51"),
        (["circle", "--robots", "0"], "must be at least 1, got 0"),
        (["circle", "--limit-s", "-1"], "must be a finite number > 0, got -1"),
        (
            ["circle", "--gif", "/nonexistent/dir/x.gif"],
            "--gif /nonexistent/dir/x.gif: the folder /nonexistent/dir does not exist",
        ),
        (["circle", "--jitter", "-1"], "must be a finite number >= 0, got -1"),
        (["circle", "--jitter", "nan"], "must be a finite number >= 0, got nan"),
        (["circle", "--seeds", "3"], "--seeds 3 without --jitter would repeat one run"),
        (["circle", "--seeds", "0", "--jitter", "1e-4"], "must be at least 1, got 0"),
        (
            ["junction", "--jitter", "1e-4", "--seeds", "2", "--gif", "/tmp/x.gif"],
            "--gif draws one run: use it without --seeds",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args, message, capsys):
    try:
        code = main(["hardcase", *args, "--no-progress"])
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and "Traceback" not in err


def test_cli_json_and_gif(tmp_path, capsys):
    gif = tmp_path / "junction.gif"
    code = main(["hardcase", "junction", "--json", "--gif", str(gif), "--frames", "12"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    assert out["case"] == "junction" and out["robots"] == 4 and out["gif"] == str(gif)
    assert out["time_s"] <= 20.0 and out["robot_impact"] == 0
    with Image.open(gif) as im:
        assert im.n_frames == 12 and im.size[0] == 480


def test_cli_says_when_not_all_arrived(capsys):
    assert main(["hardcase", "corridor", "--limit-s", "5", "--no-progress"]) == 0
    line = capsys.readouterr().out.strip()
    assert "not all arrived within 5 s: 2 still driving" in line
    assert "avoidance orca, look ahead on, traffic rules on, " in line  # the defaults


def test_cli_says_when_the_traffic_rules_are_off(capsys):
    assert main(["hardcase", "junction", "--avoidance", "none", "--no-progress"]) == 0
    line = capsys.readouterr().out.strip()
    assert "avoidance none, " in line and "traffic rules" not in line


def test_cli_jitter_runs_seeds_one_to_n_and_the_summary_counts_them(capsys):
    code = main(["hardcase", "junction", "--jitter", "0.02", "--seeds", "3", "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    runs = doc["runs"]
    assert [r["seed"] for r in runs] == [1, 2, 3] and doc["n_runs"] == 3
    assert all(r["jitter_m"] == 0.02 for r in runs)
    contact = [r["robot_touch"] + r["robot_impact"] > 0 for r in runs]
    assert doc["runs_with_robot_contact"] == sum(contact)
    times = [r["time_s"] for r in runs if r["time_s"] is not None]
    assert doc["runs_not_arrived"] == 3 - len(times)
    assert doc["time_max_s"] == max(times) and doc["time_mean_s"] == pytest.approx(
        sum(times) / len(times)
    )
    assert doc["closest_m"] == min(r["closest_m"] for r in runs)
    assert len({r["time_s"] for r in runs} | {r["closest_m"] for r in runs}) > 2  # starts differ
    main(["hardcase", "junction", "--jitter", "0.02", "--seeds", "2", "--no-progress"])
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) == 3 and lines[0].startswith("seed 1, starts moved by N(0, 0.02 m)")
    assert lines[-1].startswith("2 runs: ")


def test_cli_jitter_when_no_run_arrives_is_strict_json_and_says_so(capsys):
    args = ["hardcase", "corridor", "--limit-s", "3", "--jitter", "1e-4", "--seeds", "2"]
    assert main([*args, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out, parse_constant=lambda c: pytest.fail(c))
    assert doc["runs_not_arrived"] == 2 and doc["time_mean_s"] is None is doc["time_max_s"]
    assert all(r["time_s"] is None for r in doc["runs"])
    assert main([*args, "--no-progress"]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert "all arrived in 0;" in last and "mean" not in last
