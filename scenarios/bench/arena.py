"""The synthetic arena of ``mrta bench``: a square for n robots, box obstacles, task sites.

About 13 m^2 per robot, robots on a start grid, one box (half the grid pitch wide) between the
start points of every tenth robot, filling the first rows, and n / 2 task sites (at least 20)
drawn uniformly in the free space. With 1000 robots: a 115 m square, 97 boxes, 500 sites.
Pure numpy (no pymunk), so the allocation benchmark can use it too.
"""

from __future__ import annotations

import numpy as np

from sim.scenario import DriveSpec, RobotSpec, Scenario, SpatialSpec
from sim.scenario.spatial import TrafficSpec
from sim.spatial.navigation.planning import GridPlanner


def bench_scenario(
    n: int,
    rng: np.random.Generator,
    dt_s: float = 1.0 / 60.0,
    control_hz: float = 10.0,
    avoidance: str = "none",
    traffic: str = "on",
) -> Scenario:
    """A square arena for ``n`` robots on a start grid, with box obstacles and task sites
    (``avoidance``: the ``[spatial] avoidance`` of the arena; ``traffic``: its
    ``[spatial.traffic] rules``, which act only with avoidance on)."""
    side = max(20.0, float(np.ceil(np.sqrt(13.0 * n))))
    cols = int(np.ceil(np.sqrt(n)))
    pitch = side / (cols + 1)
    starts = [((k % cols + 1) * pitch, (k // cols + 1) * pitch) for k in range(n)]
    obstacles = []
    for k in range(max(1, n // 10)):
        cx, cy = (k % cols + 1.5) * pitch, (k // cols + 1.5) * pitch
        if cx < side - pitch and cy < side - pitch:
            h = 0.25 * pitch
            obstacles.append(
                ((cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h))
            )
    spatial = SpatialSpec(
        side, side, tuple(obstacles), ((),), DriveSpec(), dt_s=dt_s, control_hz=control_hz
    )
    planner = GridPlanner(spatial)
    cand = rng.uniform(1.0, side - 1.0, size=(4 * max(20, n // 2), 2))
    sites = cand[planner.free(cand)][: max(20, n // 2)]
    spatial = SpatialSpec(
        side,
        side,
        tuple(obstacles),
        (tuple(map(tuple, sites.tolist())),),
        DriveSpec(),
        dt_s=dt_s,
        control_hz=control_hz,
        avoidance=avoidance,
        traffic=TrafficSpec(rules=traffic),
    )
    robots = tuple(RobotSpec(f"R{k + 1}", (0,), starts[k]) for k in range(n))
    return Scenario(f"bench{n}", ("T",), robots, ((1.0,),) * n, (2.0,), spatial=spatial)
