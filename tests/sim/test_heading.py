"""Initial headings: ``[[robots]] heading_deg`` (default 0, facing +x)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenarios.loader import ScenarioError, load_scenario
from sim.scenario import RobotSpec, Scenario, SpatialSpec
from sim.spatial.world import PymunkWorld

ROOT = Path(__file__).resolve().parents[2]


def world_with(headings) -> PymunkWorld:
    starts = [(2.0 + 2.0 * k, 2.0) for k in range(len(headings))]
    sp = SpatialSpec(10.0, 5.0, (), (tuple(starts),))
    robots = tuple(
        RobotSpec(f"R{k}", (0,), xy, h)
        for k, (xy, h) in enumerate(zip(starts, headings, strict=True))
    )
    sc = Scenario("h", ("A",), robots, ((1.0,),) * len(robots), (1.0,), spatial=sp)
    return PymunkWorld(sc)


def test_robots_start_at_their_stated_headings_and_keep_them_while_standing():
    world = world_with([0.0, 90.0, -135.0])
    _, th = world.poses()
    np.testing.assert_allclose(th, np.radians([0.0, 90.0, -135.0]))
    np.testing.assert_allclose(world.fleet.last_th_rad, th)
    world.advance(2.0)
    np.testing.assert_allclose(world.poses()[1], th, atol=1e-12)


def test_heading_key_is_read_and_checked(tmp_path):
    src = (
        (ROOT / "scenarios/data/paper_spatial.toml")
        .read_text()
        .replace('name = "R1"\n', 'name = "R1"\nheading_deg = 45.0\n', 1)
    )
    path = tmp_path / "h.toml"
    path.write_text(src)
    sc = load_scenario(path)
    assert sc.robots[0].heading_deg == 45.0
    assert sc.robots[1].heading_deg == 0.0
    path.write_text(src.replace("heading_deg = 45.0", "heading_deg = 400.0"))
    with pytest.raises(ScenarioError, match=r"robots\[0\].heading_deg"):
        load_scenario(path)
