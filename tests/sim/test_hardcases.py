"""The classic hard cases (``scenarios.experiments.hardcases``) and ``mrta hardcase``: numbers
against the IR-SIM reference, the comparison without avoidance, the GIF, and one-line errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from scenarios.cli.app import main
from scenarios.experiments.hardcases import CASES, circle, run_case


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


def test_the_corridor_jam_is_broken_at_pass_s_not_at_the_stuck_timeout():
    """Two robots meet head-on in the 0.75 m corridor: with the jam rule (``Jams.break_jams``)
    one backs out 2 s after they stop; with it off (``pass_s`` out of reach) only after the
    20 s stuck timeout. Both finish without a contact; the rule saves the wait, less the 2 s
    and a margin of 2 s for the turns."""
    import dataclasses

    from sim.scenario import JamSpec, SpatialSpec

    stuck_s = {f.name: f.default for f in dataclasses.fields(SpatialSpec)}["stuck_timeout_s"]
    pass_s = JamSpec().pass_s
    on = run_case("corridor")
    off = run_case("corridor", settings={"jams": JamSpec(pass_s=3600.0)})
    for out in (on, off):
        assert out["failed"] == 0 and out["still_driving"] == 0
        assert out["robot_touch"] + out["robot_impact"] == 0
    assert off["time_s"] - on["time_s"] >= stuck_s - pass_s - 2.0


def test_jitter_moves_the_starts_by_the_seeded_draw_and_repeats_bit_for_bit():
    """``jitter_m`` moves each start by ``default_rng(seed).normal(0, jitter_m)``: the recorded
    first positions are the exact starts plus that draw (as the recording's float32 holds them),
    the same seed gives the same run bit for bit, and 0 gives the exact geometry."""
    c = np.array([6.0, 6.0])
    exact = c + np.array([[4.0, 0.0], [0.0, 4.0], [-4.0, 0.0], [0.0, -4.0]])
    a = run_case("junction", jitter_m=0.05, seed=7, recorder=True)
    b = run_case("junction", jitter_m=0.05, seed=7, recorder=True)
    draw = np.random.default_rng(7).normal(0.0, 0.05, exact.shape)
    assert np.abs(a["trajectory"].positions[0] - (exact + draw)).max() < 1e-5
    assert np.array_equal(a["trajectory"].positions, b["trajectory"].positions)
    assert a["time_s"] == b["time_s"] and (a["jitter_m"], a["seed"]) == (0.05, 7)
    still = run_case("junction", recorder=True)
    assert np.abs(still["trajectory"].positions[0] - exact).max() < 1e-5
    with pytest.raises(ValueError, match="jitter must be a finite number >= 0 m"):
        run_case("junction", jitter_m=-0.1)


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


def test_with_look_ahead_the_robot_passing_parked_robots_plans_a_wider_berth():
    """The ten parked robots are at work (1000 s): with ``look_ahead = "on"`` the passing
    robot plans its way round them, each grown by ``AHEAD_GROW_M``, at its task's start, and
    so passes farther from them than ORCA alone takes it; both arrive without a contact. The
    other hard cases do not change their arrival times (README)."""
    off = run_case("parked")
    on = run_case("parked", look_ahead="on")
    assert off["look_ahead"] == "off" and on["look_ahead"] == "on"
    for r in (off, on):
        assert np.isfinite(r["time_s"]) and r["robot_touch"] + r["robot_impact"] == 0
    assert on["closest_m"] > off["closest_m"] + 0.05
    corridor = run_case("corridor", look_ahead="on")  # beside a robot at work: pass_workers
    assert corridor["time_s"] == run_case("corridor")["time_s"]
