"""Where robots stand still in a whole run (``sim.spatial.stalls``): a head-on in a single lane is
counted as head-on; a robot alone never stands for a robot. The counting rules are in
``tests/sim/spatial/test_stalls.py``."""

from __future__ import annotations

import numpy as np
import pytest

from sim.scenario.spatial import TrafficSpec
from sim.spatial.stalls import CAUSES
from tests.worlds import swap_world, time_to_all_arrive


def test_head_on_in_a_single_lane_is_counted_as_head_on():
    """Two robots swap ends of a corridor 0.75 m wide (one passes at a time): the one that
    waits stands still facing the other (the traffic rules off: they would hold it before the
    corridor); a robot alone in an open arena never stands for a robot."""
    world = swap_world(
        [(3.5, 3.0), (8.5, 3.0)],
        [(9.5, 3.0), (2.5, 3.0)],
        (12.0, 6.0),
        obstacles=(
            ((4.0, 0.0), (8.0, 0.0), (8.0, 2.625), (4.0, 2.625)),
            ((4.0, 3.375), (8.0, 3.375), (8.0, 6.0), (4.0, 6.0)),
        ),
        headings_deg=[0.0, 180.0],
        settings={"traffic": TrafficSpec(rules="off")},
    )
    assert np.isfinite(time_to_all_arrive(world, 120.0))
    out = world.summary()
    assert out["still_s_robot_head_on"] >= 1.0
    assert out["driving_s"] > out["still_s_robot_head_on"]
    assert sum(out[f"still_s_{c}"] for c in CAUSES) == pytest.approx(
        out["still_share"] * out["driving_s"]
    )
    alone = swap_world([(1.0, 1.0)], [(9.0, 5.0)], (10.0, 6.0))
    assert np.isfinite(time_to_all_arrive(alone, 60.0))
    solo = alone.summary()
    robots = [c for c in CAUSES if c.startswith("robot_") or c == "queue"]
    assert all(solo[f"still_s_{c}"] == 0.0 for c in robots)
    assert solo["driving_s"] > 5.0
