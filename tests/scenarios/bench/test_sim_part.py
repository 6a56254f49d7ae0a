"""``mrta bench``'s ``sim`` part: the three loops it times (no avoidance, ORCA with the traffic
rules, ORCA alone) and the prices of avoidance it reports from them."""

from __future__ import annotations

import numpy as np
import pytest

from scenarios.bench import loop, run
from scenarios.bench.arena import bench_scenario
from sim.spatial.world import PymunkWorld


@pytest.mark.parametrize("traffic", ["on", "off"])
def test_the_bench_arena_has_the_traffic_rules_asked_for(traffic):
    sc = bench_scenario(20, np.random.default_rng(0), avoidance="orca", traffic=traffic)
    assert sc.spatial.traffic.rules == traffic
    w = PymunkWorld(sc)
    w.reset(np.random.default_rng(0))
    assert (w.jobs.traffic is not None) == (traffic == "on")


def test_the_sim_part_prices_avoidance_with_and_without_the_rules(monkeypatch):
    """Wall time per simulated second with over without avoidance, for ORCA with the rules and
    ORCA alone, from the loops of one process (fakes here: 2 s, 3 s and 2.5 s per 100 s)."""
    wall = {("none", "on"): 2.0, ("orca", "on"): 3.0, ("orca", "off"): 2.5}
    seen = []

    def row(avoidance, traffic, scale=1.0):
        seen.append((avoidance, traffic))
        return {
            "wall_s": scale * wall[avoidance, traffic], "sim_s": 100.0, "rtf": 1.0,
            "s_per_robot_h": 1.0, "calib_ratio": 1.0, "calib_step_us": 1.0,
            "control_calib_ratio": 1.0, "bare_ratio": 1.0,
        }  # fmt: skip

    def fake_sim(sizes, allocator=None, avoidance="none", traffic="on", timed=True, clock=None):
        assert not timed  # the price comes from loops as users run them
        return {str(n): row(avoidance, traffic, 2.0) for n in sizes}

    def fake_paper(avoidance, traffic, timed=True, clock=None):
        assert not timed
        return row(avoidance, traffic)

    monkeypatch.setattr(loop, "bench_sim", fake_sim)
    monkeypatch.setattr(run, "bench_paper_loop", fake_paper)
    lines = []
    out = run.bench_sim_part(lines.append, sizes=(10, 100))
    assert set(seen) == set(wall)
    assert out["avoidance_price"]["10"] == {
        "price": pytest.approx(1.5),
        "orca_alone_price": pytest.approx(1.25),
        "busy_price": pytest.approx(1.5),
        "busy_orca_alone_price": pytest.approx(1.25),
    }
    assert out["avoidance_price"]["100"] == {
        "price": pytest.approx(1.5),
        "orca_alone_price": pytest.approx(1.25),
    }
    text = "\n".join(lines)
    assert "price of avoidance 1.50, ORCA alone (traffic rules off) 1.25" in text


def test_repeated_rounds_take_each_loops_quickest_round_and_the_median_rounds_price(monkeypatch):
    """Three rounds, each running each arena's three loops side by side (the fakes one after
    the other, as they never pass the turn); fake wall times per round. Each loop's
    figures are its quickest round's (2.0 s without, 2.4 s with the rules, from different
    rounds: their ratio 1.2 is no round's price). The price is the median round's: rounds
    1.09, 1.5 and 1.0 give round 1's, with its ORCA-alone price (3.0 / 2.2); the busy arena's
    rounds 1.5, 1.0 and 1.82 give its round 1 too. Every round's own price is kept."""
    walls = {
        ("none", "on"): [2.2, 2.0, 2.6],
        ("orca", "on"): [2.4, 3.0, 2.6],
        ("orca", "off"): [3.0, 2.5, 2.5],
    }
    busy = {("none", "on"): [4.0, 5.0, 4.4], ("orca", "on"): [6.0, 5.0, 8.0]}
    busy[("orca", "off")] = [7.0, 7.0, 6.0]
    seen = []

    def row(wall, extra=None):
        return {
            "wall_s": wall, "sim_s": 100.0, "rtf": 100.0 / wall, "s_per_robot_h": 1.0,
            "calib_ratio": 1.0, "calib_step_us": 1.0, "control_calib_ratio": 1.0,
            "bare_ratio": 1.0, **(extra or {}),
        }  # fmt: skip

    def fake_sim(sizes, allocator=None, avoidance="none", traffic="on", timed=True, clock=None):
        (n,) = sizes  # one arena at a time, its three loops side by side
        k = sum(1 for s in seen if s == (f"sim{n}", avoidance, traffic))
        seen.append((f"sim{n}", avoidance, traffic))
        return {str(n): row((busy if n == 10 else walls)[avoidance, traffic][k])}

    def fake_paper(avoidance, traffic, timed=True, clock=None):
        k = sum(1 for s in seen if s == ("paper", avoidance, traffic))
        seen.append(("paper", avoidance, traffic))
        return row(walls[avoidance, traffic][k], {"round": k})

    monkeypatch.setattr(loop, "bench_sim", fake_sim)
    monkeypatch.setattr(run, "bench_paper_loop", fake_paper)
    lines = []
    out = run.bench_sim_part(lines.append, repeat=3, sizes=(10, 100))
    assert [s[1:] for s in seen] == [("none", "on"), ("orca", "on"), ("orca", "off")] * 9
    assert [s[0] for s in seen[::3]] == ["sim10", "sim100", "paper"] * 3
    p10 = out["avoidance_price"]["10"]
    assert p10["price"] == pytest.approx(2.4 / 2.2)
    assert p10["orca_alone_price"] == pytest.approx(3.0 / 2.2)
    assert p10["price_rounds"] == pytest.approx([2.4 / 2.2, 3.0 / 2.0, 2.6 / 2.6])
    assert p10["busy_price"] == pytest.approx(6.0 / 4.0)
    assert p10["busy_orca_alone_price"] == pytest.approx(7.0 / 4.0)
    assert out["sim"]["10"]["round"] == 1 and out["sim_orca"]["10"]["round"] == 0
    assert out["sim"]["10"]["busy_wall_s"] == 4.0 and out["sim"]["10"]["wall_s"] == 2.0
    assert out["avoidance_price"]["100"]["price"] == pytest.approx(2.4 / 2.2)
    text = "\n".join(lines)
    assert "price of avoidance 1.09 (median of 3 rounds: 1.00 to 1.50), ORCA alone" in text
    assert "round 3 of 3" in text


def test_the_price_is_split_into_the_parts_of_the_control_period(monkeypatch):
    """With ``split``, one round more times the loops part by part (the rounds before it
    untimed). Each part's wall time per simulated second with avoidance less without, over the
    loop's without: in the timed round the loop without takes 2 s per 100 s, with the rules
    3 s per 50 s, so its price is 3; the parts' shares and the rest add up to 2. The price
    itself is the untimed round's: 2.4 s per 50 s against 2 s per 100 s, 2.4."""
    parts = {
        ("none", "on"): {"control": 1.0, "traffic": 0.0, "jams": 0.0, "sites": 0.0, "physics": 0.6},
        ("orca", "on"): {
            "control": 1.0,
            "traffic": 0.5,
            "jams": 0.25,
            "sites": 0.1,
            "physics": 0.2,
        },
        ("orca", "off"): {
            "control": 0.8,
            "traffic": 0.0,
            "jams": 0.2,
            "sites": 0.1,
            "physics": 0.2,
        },
    }
    wall = {("none", "on"): (2.0, 100.0), ("orca", "on"): (3.0, 50.0), ("orca", "off"): (2.0, 50.0)}
    untimed = {("none", "on"): 2.0, ("orca", "on"): 2.4, ("orca", "off"): 2.0}
    seen = []

    def row(avoidance, traffic, timed=True):
        seen.append(timed)
        w, sim = wall[avoidance, traffic]
        if not timed:
            return {
                "wall_s": untimed[avoidance, traffic], "sim_s": sim, "rtf": 1.0,
                "s_per_robot_h": 1.0, "calib_ratio": 1.0, "calib_step_us": 1.0, "bare_ratio": 1.0,
            }  # fmt: skip
        return {
            "wall_s": w, "sim_s": sim, "rtf": sim / w, "s_per_robot_h": 1.0, "calib_ratio": 1.0,
            "calib_step_us": 1.0, "control_calib_ratio": 0.7, "physics_calib_ratio": 0.3,
            "bare_ratio": 1.0,
            "parts_s": dict(parts[avoidance, traffic]),
        }  # fmt: skip

    def fake_sim(sizes, allocator=None, avoidance="none", traffic="on", timed=True, clock=None):
        return {"10": row(avoidance, traffic, timed)}

    def fake_paper(avoidance, traffic, timed=True, clock=None):
        return row(avoidance, traffic, timed)

    monkeypatch.setattr(loop, "bench_sim", fake_sim)
    monkeypatch.setattr(run, "bench_paper_loop", fake_paper)
    lines = []
    out = run.bench_sim_part(lines.append, split=True, sizes=(10,))
    assert seen == [False] * 6 + [True] * 6  # the untimed round, then the timed one
    p10 = out["avoidance_price"]["10"]
    assert p10["price"] == pytest.approx(2.4)
    assert p10["timed_price"] == pytest.approx(3.0)
    # per simulated second: control 0.02 with and 0.01 without, traffic 0.01, jams 0.005,
    # sites 0.002, physics 0.004 with and 0.006 without (fewer contacts); over the 0.02 s per
    # simulated second of the loop without
    want = {
        "control": 0.5, "traffic": 0.5, "jams": 0.25, "sites": 0.1, "physics": -0.1, "rest": 0.75
    }  # fmt: skip
    assert p10["price_parts"] == pytest.approx(want)
    assert sum(p10["price_parts"].values()) == pytest.approx(p10["timed_price"] - 1.0)
    assert out["sim_orca"]["10"]["control_calib_ratio"] == 0.7
    assert out["sim_orca"]["10"]["physics_calib_ratio"] == 0.3
    assert out["sim_orca"]["10"]["wall_s"] == 2.4  # the figures: the untimed round's
    text = "\n".join(lines)
    assert (
        "split, from the timed round (its price 3.00), in loops without avoidance: control "
        "period +0.50, traffic rules +0.50, look-ahead and jam rules +0.25, site work +0.10, "
        "physics steps -0.10, the rest +0.75"
    ) in text
    assert "of it the control period, the physics steps" in text
    assert "0.70, 0.30" in text  # each loop's control period and physics steps


def test_of_two_middle_rounds_the_lower_price_is_taken(monkeypatch):
    """Four rounds with prices 1.6, 1.2, 2.0 and 1.4 (the loop with the rules 3.2, 2.4, 4.0 and
    2.8 s against 2 s without): the price is 1.4, the lower of the two middle ones."""
    with_rules = iter([3.2, 2.4, 4.0, 2.8])

    def row(avoidance, traffic, timed=True, wall=2.0, clock=None):
        if (avoidance, traffic) == ("orca", "on"):
            wall = next(with_rules)
        return {
            "wall_s": wall, "sim_s": 100.0, "rtf": 1.0, "s_per_robot_h": 1.0,
            "calib_ratio": 1.0, "calib_step_us": 1.0, "control_calib_ratio": 1.0, "bare_ratio": 1.0,
        }  # fmt: skip

    def fake_sim(sizes, allocator=None, avoidance="none", traffic="on", timed=True, clock=None):
        return {"10": row("none", "on")}  # busy arena: 1.0

    monkeypatch.setattr(loop, "bench_sim", fake_sim)
    monkeypatch.setattr(run, "bench_paper_loop", row)
    out = run.bench_sim_part(lambda line: None, repeat=4, sizes=(10,))
    p10 = out["avoidance_price"]["10"]
    assert p10["price_rounds"] == pytest.approx([1.6, 1.2, 2.0, 1.4])
    assert p10["price"] == pytest.approx(1.4)


def test_one_round_reports_no_round_prices(monkeypatch):
    row = {"wall_s": 1.0, "sim_s": 10.0, "rtf": 10.0, "s_per_robot_h": 1.0, "calib_ratio": 1.0,
           "calib_step_us": 1.0, "control_calib_ratio": 1.0, "bare_ratio": 1.0}  # fmt: skip
    monkeypatch.setattr(loop, "bench_sim", lambda **kw: {"10": dict(row)})
    monkeypatch.setattr(run, "bench_paper_loop", lambda **kw: dict(row))
    lines = []
    out = run.bench_sim_part(lines.append, sizes=(10,))
    assert "price_rounds" not in out["avoidance_price"]["10"]
    assert "price_parts" not in out["avoidance_price"]["10"]
    assert not any("round" in line or "best of" in line or "split" in line for line in lines)
    assert not any("of it the control period" in line for line in lines)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--only", "sim", "--repeat", "0"], "must be at least 1, got 0"),
        (["--only", "sim", "--repeat", "-2"], "must be at least 1, got -2"),
        (["--only", "sim", "--repeat", "two"], "--repeat"),
        (["--only", "gif", "--repeat", "3"], "--repeat 3 repeats the sim part: add sim to --only"),
        (["--only", "gif", "--split"], "--split splits the sim part's price: add sim to --only"),
    ],
)
def test_a_bad_repeat_is_one_line_and_exit_2(args, message, monkeypatch, capsys):
    import scenarios.bench as bench
    from scenarios.cli.app import main

    monkeypatch.setattr(bench, "run_bench", lambda *a, **k: pytest.fail("the bench ran"))
    try:
        code = main(["bench", *args])
    except SystemExit as exc:  # argparse's own errors
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and "Traceback" not in err


def test_the_cli_passes_repeat_and_split_to_the_bench(monkeypatch, capsys):
    import json

    import scenarios.bench as bench
    from scenarios.cli.app import main

    asked = []

    def fake(parts, progress, repeat, split):
        asked.append((parts, repeat, split))
        return {}

    monkeypatch.setattr(bench, "run_bench", fake)
    assert main(["bench", "--only", "sim", "--repeat", "3", "--json"]) == 0
    assert main(["bench", "--only", "sim", "--split", "--json"]) == 0
    assert asked == [(["sim"], 3, False), (["sim"], 1, True)]
    assert [json.loads(part) for part in capsys.readouterr().out.split()] == [{}, {}]


def test_an_untimed_loop_has_no_timer_in_it_and_reports_none_of_their_figures(monkeypatch):
    """``timed=False`` runs the loop as users run it: the classes the timers wrap keep their
    own methods meanwhile, and the row has the loop's figures without the timers' ones."""
    from sim.spatial.control.compiled import CompiledControl
    from sim.spatial.traffic.rules import Traffic

    own = (CompiledControl.__dict__["period"], Traffic.__dict__["period"])
    seen = []
    real_run = loop._run

    def spy(*args, **kwargs):
        seen.append((CompiledControl.__dict__["period"], Traffic.__dict__["period"]))
        return real_run(*args, **kwargs)

    timer_keys = {"avoid_share", "sites_share", "control_share", "control_calib_ratio", "parts_s"}
    timer_keys.add("physics_calib_ratio")
    monkeypatch.setattr(loop, "_run", spy)
    off = loop.bench_sim(sizes=(10,), sim_seconds=3.0, avoidance="orca", timed=False)["10"]
    on = loop.bench_sim(sizes=(10,), sim_seconds=3.0, avoidance="orca", timed=True)["10"]
    assert seen[1] == own and seen[3] != own  # (each size: a warm-up run, then the timed one)
    assert not timer_keys & set(off) and timer_keys <= set(on)
    assert {"wall_s", "sim_s", "rtf", "calib_ratio", "bare_ratio"} <= set(off)


def test_untimed_rounds_run_each_arenas_loops_in_turns_and_the_timed_round_one_by_one(
    monkeypatch,
):
    """The rounds the prices come from run an arena's three loops through a relay (each timed
    by the relay's clock, the world's control period passing the turn), beside the
    calibration space of as many robots, whose step (2 µs here) becomes the loops' yardstick;
    the timed round runs them one after the other on the plain clock, the world's control
    period its own, against the quickest of their own calibration steps (1 µs)."""
    import time

    from scenarios.bench import calibration
    from scenarios.bench.relay import Relay
    from sim.spatial.world import PymunkWorld

    own = PymunkWorld.__dict__["_control"]
    row = {"wall_s": 1.0, "sim_s": 10.0, "rtf": 10.0, "s_per_robot_h": 1.0, "calib_ratio": 1.0,
           "calib_step_us": 1.0, "control_calib_ratio": 1.0, "physics_calib_ratio": 1.0,
           "bare_ratio": 1.0, "parts_s": dict.fromkeys(loop.TIMED_PARTS, 0.0)}  # fmt: skip
    calls = []

    def record(timed, clock):
        relay = getattr(clock, "__self__", None)
        calls.append((timed, isinstance(relay, Relay), PymunkWorld.__dict__["_control"] is own))
        if clock is not time.perf_counter:
            assert relay is not None and clock == relay.clock
        return dict(row)

    def fake_sim(sizes, allocator=None, avoidance="none", traffic="on", timed=True, clock=None):
        return {str(n): record(timed, clock) for n in sizes}

    yardsticks = []

    def fake_calibration(robots, more, tick, clock):
        yardsticks.append((robots, more(), clock == tick.__self__.clock))
        return 2e-6

    monkeypatch.setattr(loop, "bench_sim", fake_sim)
    monkeypatch.setattr(run, "bench_paper_loop", lambda timed, clock, **kw: record(timed, clock))
    monkeypatch.setattr(calibration, "calibration_while", fake_calibration)
    out = run.bench_sim_part(lambda line: None, split=True, sizes=(10, 100))
    assert calls == [(False, True, False)] * 9 + [(True, False, True)] * 9
    assert PymunkWorld.__dict__["_control"] is own
    # the fake loops never pass the turn: each ends before the calibration job's first turn
    assert yardsticks == [(10, False, True), (100, False, True), (10, False, True)]
    assert out["sim"]["100"]["calib_step_us"] == pytest.approx(2.0)
    assert out["sim"]["100"]["calib_ratio"] == pytest.approx(0.5)
    assert out["sim_orca"]["10"]["busy_calib_step_us"] == pytest.approx(2.0)


def test_each_size_has_its_own_arena_whatever_ran_before(monkeypatch):
    """An arena's sites and first tasks come from a stream of its own size: the same with and
    without avoidance, run alone or after another size (the re-plan figures with avoidance,
    drawn from the shared stream, made the 100 and 1000 robot arenas differ)."""
    sites = []
    real = loop.bench_scenario

    def spy(n, rng, **kwargs):
        scenario = real(n, rng, **kwargs)
        sites.append((n, np.asarray(scenario.spatial.sites[0]).tobytes()))
        return scenario

    monkeypatch.setattr(loop, "bench_scenario", spy)
    loop.bench_sim(sizes=(10, 20), sim_seconds=1.0, avoidance="orca", timed=False)
    loop.bench_sim(sizes=(20,), sim_seconds=1.0, avoidance="none", timed=False)
    loop.bench_sim(sizes=(20,), sim_seconds=1.0, avoidance="none", timed=False, seed=1)
    assert [n for n, _ in sites] == [10, 20, 20, 20]
    after_ten, alone, other_seed = (layout for _, layout in sites[1:])
    assert after_ten == alone and alone != other_seed


def test_loops_taking_turns_simulate_what_they_simulate_alone(monkeypatch):
    """Two worlds stepping in turns (a turn ends after every control period) give the same
    simulation as each run alone: the same simulated time, contacts, and robot poses bit for
    bit at the end of the timed loop."""
    import functools
    import threading
    import time

    from scenarios.bench.relay import Relay
    from sim.spatial.world import PymunkWorld

    real_run = loop._run
    poses = threading.local()

    def spy(world, *args, **kwargs):
        out = real_run(world, *args, **kwargs)
        poses.last = world.fleet.last_z_m.tobytes() + world.fleet.last_th_rad.tobytes()
        return out

    monkeypatch.setattr(loop, "_run", spy)

    def job(avoidance, clock):
        out = loop.bench_sim(
            sizes=(20,), sim_seconds=4.0, avoidance=avoidance, timed=False, clock=clock
        )["20"]
        return out["sim_s"], out["contact_share"], poses.last

    alone = [job(avoidance, time.perf_counter) for avoidance in ("none", "orca")]
    relay = Relay(slice_s=0.0)
    with relay.ticking(PymunkWorld, "_control"):
        turns = relay.run([functools.partial(job, a, relay.clock) for a in ("none", "orca")])
    assert turns == alone
    assert alone[0][1] > 0.0 and alone[1][1] == 0.0  # (contacts only without avoidance)
    assert alone[0][2] != alone[1][2]  # (the poses tell the two runs apart)
    assert relay.turns[:6] == [0, 1, 0, 1, 0, 1] and len(relay.turns) > 100


def test_an_arenas_loops_share_the_quickest_calibration_step_of_theirs():
    """Three loops timed their own calibration steps at 2, 1 and 4 µs: all are given 1 µs and
    their figures in calibration steps grow by 2, 1 and 4, so that their ratios are those of
    the loops' wall time per step (the timers' figures, where present, alike)."""
    rows = [
        {"calib_step_us": 2.0, "calib_ratio": 3.0, "control_calib_ratio": 1.0},
        {"calib_step_us": 1.0, "calib_ratio": 5.0},
        {"calib_step_us": 4.0, "calib_ratio": 2.0, "physics_calib_ratio": 0.5, "wall_s": 9.0},
    ]
    assert run.one_yardstick(rows) is rows
    assert rows == [
        {"calib_step_us": 1.0, "calib_ratio": 6.0, "control_calib_ratio": 2.0},
        {"calib_step_us": 1.0, "calib_ratio": 5.0},
        {"calib_step_us": 1.0, "calib_ratio": 8.0, "physics_calib_ratio": 2.0, "wall_s": 9.0},
    ]
