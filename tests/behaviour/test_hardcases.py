"""The classic hard cases (``scenarios.experiments.hardcases``) and ``mrta hardcase``: numbers
against the IR-SIM reference, the comparison without avoidance, the GIF, and one-line errors."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_the_corridor_jam_is_broken_at_pass_s_not_at_the_stuck_timeout():
    """Two robots meet head-on in the 0.75 m corridor: with the jam rule (``Jams.break_jams``)
    one backs out 2 s after they stop; with it off (``pass_s`` out of reach) only after the
    20 s stuck timeout. Both finish without a contact; the rule saves the wait, less the 2 s
    and a margin of 2 s for the turns. The traffic rules are off: they keep the two from
    meeting (tests/behaviour/test_traffic.py)."""
    import dataclasses

    from sim.scenario import JamSpec, SpatialSpec
    from sim.scenario.spatial import TrafficSpec

    stuck_s = {f.name: f.default for f in dataclasses.fields(SpatialSpec)}["stuck_timeout_s"]
    pass_s = JamSpec().pass_s
    no_rules = TrafficSpec(rules="off")
    on = run_case("corridor", settings={"traffic": no_rules})
    off = run_case("corridor", settings={"jams": JamSpec(pass_s=3600.0), "traffic": no_rules})
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


def test_with_look_ahead_the_robot_passing_parked_robots_plans_a_wider_berth():
    """The ten parked robots are at work (1000 s): with ``look_ahead = "on"`` the passing
    robot plans its way round them, each grown by ``AHEAD_GROW_M``, at its task's start, and
    so passes farther from them than ORCA alone takes it; both arrive without a contact. The
    other hard cases do not change their arrival times (README)."""
    off = run_case("parked", look_ahead="off")
    on = run_case("parked", look_ahead="on")
    assert off["look_ahead"] == "off" and on["look_ahead"] == "on"
    for r in (off, on):
        assert np.isfinite(r["time_s"]) and r["robot_touch"] + r["robot_impact"] == 0
    assert on["closest_m"] > off["closest_m"] + 0.05
    corridor = run_case("corridor", look_ahead="on")  # beside a robot at work: pass_workers
    assert corridor["time_s"] == run_case("corridor", look_ahead="off")["time_s"]
