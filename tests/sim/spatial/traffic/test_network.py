"""``sim.spatial.traffic.network.PassageMap``: the passages a way is annotated with are the
same whether or not they are first narrowed to those near the way's box, also after robots
begin and end work (temporary passages come and go)."""

from __future__ import annotations

import numpy as np

from scenarios.loader import load_scenario
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.traffic.annotate import crossings
from sim.spatial.traffic.network import PassageMap


def near_box_slowly(passages: dict, way: np.ndarray) -> list[int]:
    """The keys :func:`crossings` does not skip at once for ``way``, one by one."""
    lo = complex(way.real.min(), way.imag.min())
    hi = complex(way.real.max(), way.imag.max())
    out = []
    for key, p in passages.items():
        reach = p.half_length_m + p.half_width_m
        c = p.centre
        if lo.real - reach <= c.real <= hi.real + reach and lo.imag - reach <= c.imag <= (
            hi.imag + reach
        ):
            out.append(key)
    return out


def test_ways_get_the_same_passages_with_the_box_first_as_robots_begin_and_end_work():
    spatial = load_scenario("warehouse").spatial
    planner = GridPlanner(spatial)
    pmap = PassageMap(spatial, spatial.drive.radius_m, planner)
    rng = np.random.default_rng(5)
    m = 12
    w, h = spatial.width_m, spatial.height_m
    free = []
    while len(free) < 400:  # points a robot centre may stand on
        x, y = rng.uniform(0, w), rng.uniform(0, h)
        if planner.free_one(x, y):
            free.append(complex(x, y))
    free = np.array(free)
    z = free[:m].copy()
    service = free[m : 2 * m].copy()
    service[: m // 2] = service[0]  # half of them share a site
    work = np.zeros(m, dtype=bool)
    seen_temporary = compared = found = 0
    for _ in range(30):
        changed = rng.choice(m, 3, replace=False)
        work[changed] = ~work[changed]
        z[changed] = free[rng.integers(0, len(free), 3)]
        pmap.update_workers(changed, work, z)
        seen_temporary += sum(k >= pmap.n_static for k in pmap.passages)
        for j in range(m):
            way = free[rng.integers(0, len(free), int(rng.integers(2, 6)))]
            end = complex(way[-1])
            narrowed = pmap.for_robot(j, end, service, way)
            whole = pmap.for_robot(j, end, service)
            assert list(narrowed) == [k for k in near_box_slowly(pmap.passages, way) if k in whole]
            assert crossings(way, narrowed) == crossings(way, whole)
            compared += 1
            found += len(crossings(way, whole))
    assert seen_temporary > 20 and compared == 360 and found > 50
