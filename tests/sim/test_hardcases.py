"""The classic hard cases (``sim.hardcases``) and ``mrta hardcase``: numbers against the
IR-SIM reference, the comparison without avoidance, the GIF, and one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from scenarios.cli.app import main
from sim.hardcases import CASES, circle, run_case


def test_circle_swap_of_ten_beats_the_reference_without_a_contact():
    out = run_case("circle", 10, control="array")
    assert out["time_s"] <= 17.8  # IR-SIM 2.12 RVO example, 10 robots
    assert out["robot_touch"] == out["robot_impact"] == 0
    assert out["closest_m"] >= 0.5  # two radii: they never touched
    assert out["failed"] == 0 and out["still_driving"] == 0


def test_without_avoidance_the_circle_swap_touches():
    out = run_case("circle", 10, avoidance="none")
    assert out["robot_touch"] + out["robot_impact"] > 0
    assert out["closest_m"] < 0.5


def test_every_case_builds_with_its_default_count_and_the_recording_ends_at_the_goals():
    out = run_case("junction", recorder=True)
    traj = out["trajectory"]
    assert out["time_s"] <= 20.0 and out["robot_touch"] + out["robot_impact"] == 0
    starts, last = traj.positions[0], traj.positions[-1]
    assert np.abs(last - (2 * np.array([6.0, 6.0]) - starts)).max() <= 0.1 + 1e-6
    assert {c.robots for c in CASES.values()} == {20, 4, 2, 11, 30}


def test_circle_points_are_antipodal():
    starts, goals = circle(6, 2.0, (3.0, 4.0))
    assert np.allclose(np.linalg.norm(starts - (3.0, 4.0), axis=1), 2.0)
    assert np.allclose(starts + goals, 2 * np.array([3.0, 4.0]))


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["circl"], "hard case 'circl' unknown (did you mean 'circle'?)"),
        (["junction", "--robots", "5"], "hard case junction takes exactly 4 robots, got 5"),
        (["circle", "--robots", "51"], "hard case circle takes 2 to 50 robots, got 51"),
        (["circle", "--robots", "0"], "must be at least 1, got 0"),
        (["circle", "--limit-s", "-1"], "must be a finite number > 0, got -1"),
        (["circle", "--gif", "/nonexistent/dir/x.gif"], "/nonexistent/dir: output folder"),
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


def test_the_corridor_jam_is_broken_at_pass_s_not_at_the_stuck_timeout(monkeypatch):
    """Two robots meet head-on in the 0.75 m corridor: with the jam rule (``Jams.break_jams``)
    one backs out 2 s after they stop; with it off (``PASS_S`` out of reach) only after the
    20 s stuck timeout. Both finish without a contact; the rule saves the wait, less the 2 s
    and a margin of 2 s for the turns."""
    import dataclasses

    import sim.jams
    from sim.scenario import SpatialSpec

    stuck_s = {f.name: f.default for f in dataclasses.fields(SpatialSpec)}["stuck_timeout_s"]
    pass_s = sim.jams.PASS_S
    on = run_case("corridor")
    monkeypatch.setattr(sim.jams, "PASS_S", 1e9)
    off = run_case("corridor")
    for out in (on, off):
        assert out["failed"] == 0 and out["still_driving"] == 0
        assert out["robot_touch"] + out["robot_impact"] == 0
    assert off["time_s"] - on["time_s"] >= stuck_s - pass_s - 2.0
