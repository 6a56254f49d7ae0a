"""``sim.spatial.traffic.network.PassageMap``: the passages a way is annotated with are the
same whether or not they are first narrowed to those near the way's box, also after robots
begin and end work (temporary passages come and go)."""

from __future__ import annotations

import dataclasses

import numpy as np

from scenarios.loader import load_scenario
from sim.spatial.navigation.planning import GridPlanner
from sim.spatial.traffic.annotate import crossings
from sim.spatial.traffic.network import PassageMap
from sim.spatial.traffic.passages import worker_passage


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


def test_temporary_passages_kept_up_to_date_equal_those_made_afresh():
    """After every round of robots beginning and ending work, the temporary passages
    ``update_workers`` keeps (only the robots near those that changed are made again) equal
    those made for every robot at work from scratch, one by one: a passage of its own body
    against the obstacles near it and the robots at work beside it."""
    spatial = load_scenario("warehouse").spatial
    planner = GridPlanner(spatial)
    pmap = PassageMap(spatial, spatial.drive.radius_m, planner)
    r = pmap.radius_m
    rng = np.random.default_rng(11)
    m = 30
    w, h = spatial.width_m, spatial.height_m
    free = []
    while len(free) < 300:  # in a corner of the aisles, where robots at work crowd each other
        x, y = rng.uniform(0, 0.4 * w), rng.uniform(0, 0.4 * h)
        if planner.free_one(x, y):
            free.append(complex(x, y))
    free = np.array(free)
    z, work = free[:m].copy(), np.zeros(m, dtype=bool)
    compared = beside = 0
    for _ in range(60):
        changed = rng.choice(m, 6, replace=False)
        begin = changed[~work[changed]]  # these come to a new place; the others end there
        z[begin] = free[rng.integers(0, len(free), len(begin))]
        work[changed] = ~work[changed]
        pmap.update_workers(changed, work, z)
        afresh = {}
        for k in work.nonzero()[0].tolist():
            d = pmap.passage_m + r
            near = [
                s
                for s in pmap.shapes
                if s.real.min() <= z[k].real + d
                and s.real.max() >= z[k].real - d
                and s.imag.min() <= z[k].imag + d
                and s.imag.max() >= z[k].imag - d
            ]
            gap = np.abs(z - z[k])
            counts_m = pmap.passage_m + 2.0 * r / np.cos(np.pi / 8) + 1e-9
            others = z[work & (gap < counts_m) & (gap > 1e-9)]
            p = worker_passage(k, complex(z[k]), r, near, others, pmap.passage_m, pmap.lane_m)
            if p is not None and len(others):
                alone = worker_passage(k, complex(z[k]), r, near, others[:0], pmap.passage_m, 0)
                p = dataclasses.replace(p, by_walls=alone is not None)
            if p is not None:
                afresh[pmap.n_static + k] = p
                beside += len(others) > 0
        kept = {k: p for k, p in pmap.passages.items() if k >= pmap.n_static}
        assert kept == afresh
        compared += len(afresh)
    assert compared > 100 and beside > 10
