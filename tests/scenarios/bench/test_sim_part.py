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

    def fake_sim(allocator=None, avoidance="none", traffic="on"):
        return {str(n): row(avoidance, traffic, 2.0) for n in (10, 100)}

    monkeypatch.setattr(loop, "bench_sim", fake_sim)
    monkeypatch.setattr(run, "bench_paper_loop", lambda avoidance, traffic: row(avoidance, traffic))
    lines = []
    out = run.bench_sim_part(lines.append)
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
