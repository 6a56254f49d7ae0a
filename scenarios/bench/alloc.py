"""Allocation time per announcement round against the number of robots (``mrta bench``).

Every size gets a synthetic heterogeneous team drawn like ``scenarios/data/scale1000.toml``
(50 task types, 2-8 capabilities per robot, integer costs 2-10) and the same seeded batches of
``tasks`` tasks. Every robot is free in every round, so all capable robots bid: the worst case
for the auction. Timings are wall-clock means over ``rounds`` rounds after a short warm-up,
memory is the tracemalloc peak of building the allocator and playing a few rounds.
"""

from __future__ import annotations

import time
import tracemalloc
from collections.abc import Mapping, Sequence

import numpy as np

from allocation.auction import (
    MarketAllocator,
    solve_priority_assignment,
    solve_priority_assignment_dense,
)
from allocation.costs import AbstractCost
from sim.scenario import RobotSpec, Scenario, StreamSpec
from sim.tasks import Batch
from sim.world import WorldState

WARMUP_ROUNDS = 5
MEMORY_ROUNDS = 5


def synthetic_scenario(
    n_robots: int,
    n_types: int,
    rng: np.random.Generator,
    types_per_robot: tuple[int, int] = (2, 8),
    cost_range: tuple[int, int] = (2, 10),
    exec_time_s_range: tuple[float, float] = (30.0, 30.0),
    stream: StreamSpec | None = None,
    name: str = "synthetic",
) -> Scenario:
    """A heterogeneous team: each robot can do U{types_per_robot} types drawn without replacement.

    Args:
        n_robots: robots R1..Rm.
        n_types: task types T1..Tn.
        rng: the only source of randomness.
        types_per_robot: inclusive range of capabilities per robot (capped at ``n_types``).
        cost_range: inclusive range of the integer abstract costs.
        exec_time_s_range: execution time per type, s, rounded to whole seconds.
        stream: stream parameters (default StreamSpec()).
        name: scenario name.
    """
    lo, hi = min(types_per_robot[0], n_types), min(types_per_robot[1], n_types)
    robots, costs = [], []
    for j in range(n_robots):
        caps = np.sort(rng.choice(n_types, size=int(rng.integers(lo, hi + 1)), replace=False))
        row = np.full(n_types, np.inf)
        row[caps] = rng.integers(cost_range[0], cost_range[1] + 1, size=caps.size)
        robots.append(RobotSpec(f"R{j + 1}", tuple(int(i) for i in caps)))
        costs.append(tuple(float(c) for c in row))
    for i in sorted(set(range(n_types)) - {c for r in robots for c in r.capabilities}):
        j = i % n_robots  # a type no robot drew goes to one robot, at the dearest cost
        robots[j] = RobotSpec(robots[j].name, tuple(sorted((*robots[j].capabilities, i))))
        costs[j] = tuple(float(cost_range[1]) if k == i else c for k, c in enumerate(costs[j]))
    exec_time = np.round(rng.uniform(*exec_time_s_range, size=n_types))
    return Scenario(
        name=name,
        task_types=tuple(f"T{i + 1}" for i in range(n_types)),
        robots=tuple(robots),
        cost=tuple(costs),
        exec_time_s=tuple(float(t) for t in exec_time),
        stream=stream or StreamSpec(),
    )


def _batches(n_types: int, tasks: int, rounds: int, rng: np.random.Generator) -> list[Batch]:
    out = []
    for r in range(rounds):
        ids = np.arange(r * tasks, (r + 1) * tasks)
        types = rng.integers(0, n_types, size=tasks)
        high = rng.random(tasks) < 0.35
        out.append(Batch(0, r, ids, types, high, np.full((tasks, 2), np.nan)))
    return out


def _time_rounds(allocator, state: WorldState, cost: AbstractCost, batches) -> np.ndarray:
    """Seconds per round of cost lookup + allocate, after a warm-up."""
    for batch in batches[:WARMUP_ROUNDS]:
        allocator.allocate(state, batch, cost.costs(state, batch))
    out = np.empty(len(batches))
    for r, batch in enumerate(batches):
        t0 = time.perf_counter()
        allocator.allocate(state, batch, cost.costs(state, batch))
        out[r] = time.perf_counter() - t0
    return out


def _build(cls: type, scenario: Scenario, rng: np.random.Generator):
    allocator = cls(scenario)
    allocator.reset(rng)
    allocator.begin_set(0, learning=True)
    return allocator


def _peak_mib(cls: type, scenario: Scenario, seed, state: WorldState, cost, batches) -> float:
    """tracemalloc peak (MiB) of building an allocator and playing a few rounds."""
    tracemalloc.start()
    try:
        allocator = _build(cls, scenario, np.random.default_rng(seed))
        for batch in batches[:MEMORY_ROUNDS]:
            allocator.allocate(state, batch, cost.costs(state, batch))
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def _auction_only(state: WorldState, cost: AbstractCost, batches, solve) -> float:
    bids = [np.where(state.free[:, None], cost.costs(state, b), np.inf) for b in batches]
    for b, batch in zip(bids[:WARMUP_ROUNDS], batches, strict=False):
        solve(b, batch.high)
    t0 = time.perf_counter()
    for b, batch in zip(bids, batches, strict=True):
        solve(b, batch.high)
    return (time.perf_counter() - t0) / len(batches) * 1e3


def bench_alloc(
    sizes: Sequence[int] = (10, 100, 1000),
    n_types: int = 50,
    tasks: int = 7,
    rounds: int = 100,
    seed: int = 0,
    allocators: Mapping[str, type] | None = None,
) -> dict[str, dict[str, float]]:
    """Allocation time per round and memory against the number of robots.

    Args:
        sizes: team sizes to measure.
        n_types: task types of the synthetic teams.
        tasks: tasks announced per round (7 = the largest batch of the paper's stream).
        rounds: timed rounds per size and allocator.
        seed: seeds the teams and the batches.
        allocators: name -> allocator class; default only ``market``. The ``mrta`` command
            passes ``learning.ALLOCATORS`` to add ``ql`` and ``expt`` (this package does not
            import ``learning``).

    Returns:
        ``{"1000": {"ms_per_round": ..., ...}, ...}``: ``ms_per_round`` and ``p95_ms`` are the
        market's (cost lookup + auction), ``auction_ms`` / ``auction_dense_ms`` the priority
        auction alone with and without bidder reduction, ``peak_mib`` the market's memory
        peak; other allocators add ``<name>_ms_per_round``, ``<name>_p95_ms`` and
        ``<name>_peak_mib``.
    """
    allocators = dict(allocators or {"market": MarketAllocator})
    allocators.setdefault("market", MarketAllocator)
    out: dict[str, dict[str, float]] = {}
    for m in sizes:
        rng = np.random.default_rng([seed, m])
        sc = synthetic_scenario(int(m), n_types, rng)
        state = WorldState(0.0, np.ones(m, dtype=bool), np.zeros(m))
        cost = AbstractCost(sc)
        batches = _batches(n_types, tasks, rounds, rng)
        row: dict[str, float] = {"robots": int(m), "task_types": n_types, "tasks_per_round": tasks}
        for name, cls in allocators.items():
            alloc = _build(cls, sc, np.random.default_rng([seed, m, 1]))
            secs = _time_rounds(alloc, state, cost, batches)
            prefix = "" if name == "market" else f"{name}_"
            row[f"{prefix}ms_per_round"] = float(secs.mean() * 1e3)
            row[f"{prefix}p95_ms"] = float(np.percentile(secs, 95) * 1e3)
            row[f"{prefix}peak_mib"] = _peak_mib(cls, sc, [seed, m, 2], state, cost, batches)
        row["auction_ms"] = _auction_only(state, cost, batches, solve_priority_assignment)
        row["auction_dense_ms"] = _auction_only(
            state, cost, batches, solve_priority_assignment_dense
        )
        out[str(m)] = row
    return out


SPATIAL_SIZES = (10, 100, 1000)
SPATIAL_ROUNDS = {10: 100, 100: 30, 1000: 100}  # the exact query at 100 robots is the slow one


def bench_costs(
    sizes: Sequence[int] = SPATIAL_SIZES,
    tasks: int = 7,
    rounds: Mapping[int, int] | None = None,
    seed: int = 0,
) -> dict[str, dict[str, float]]:
    """Allocation time per round under each cost model, in the arena of ``mrta bench``.

    For each size the synthetic arena of ``scenarios.bench.arena`` (1000 robots: 115 m, 97 boxes,
    500 sites) with the robots at random free points, all free; rounds of ``tasks`` tasks at
    random sites; the market auction. A round is the cost model's bids plus the auction.

    Returns:
        ``{"1000": {"abstract_ms", "straight_ms", "distance_ms", "time_ms", ...}, ...}``: mean
        ms per round under the scenario's cost table, straight lines, planned distances and
        planned times; where the planner builds its distance field (from
        ``sim.spatial.navigation.planning.FIELD_MIN_ROBOTS`` robots), ``field_build_s``,
        ``field_mib`` (held) and ``field_peak_mib`` (tracemalloc peak while building), measured
        apart from the rounds.
    """
    from allocation.costs import DistanceCost, StraightLineCost, TimeCost
    from scenarios.bench.arena import bench_scenario
    from sim.spatial.navigation.distfield import SHARED, DistanceField
    from sim.spatial.navigation.planning import FIELD_MIN_ROBOTS, GridPlanner

    rounds = {**SPATIAL_ROUNDS, **(rounds or {})}
    out: dict[str, dict[str, float]] = {}
    for m in sizes:
        rng = np.random.default_rng([seed, m])
        sc = bench_scenario(int(m), rng)
        planner = GridPlanner(sc.spatial)
        row: dict[str, float] = {"robots": int(m), "tasks_per_round": tasks}
        if m >= FIELD_MIN_ROBOTS:
            sites = planner.site_points()
            tracemalloc.start()
            try:
                t0 = time.perf_counter()
                field = DistanceField.build(planner, sites)
                row["field_build_s"] = time.perf_counter() - t0
                row["field_peak_mib"] = tracemalloc.get_traced_memory()[1] / 2**20
            finally:
                tracemalloc.stop()
            row["field_mib"] = field.nbytes / 2**20
            planner.field_ = SHARED.get(planner.field_key(), lambda f=field: f)
        cand = rng.uniform(0.0, sc.spatial.width_m, size=(4 * m, 2))
        xy = cand[planner.free(cand)][:m]
        state = WorldState(0.0, np.ones(m, dtype=bool), np.zeros(m), xy)
        site_pts = planner.site_points()
        batches = []
        n_rounds = rounds.get(int(m), 30)
        for r in range(n_rounds):
            pick = site_pts[rng.integers(0, len(site_pts), size=tasks)]
            high = rng.random(tasks) < 0.35
            ids = np.arange(r * tasks, (r + 1) * tasks)
            batches.append(Batch(0, r, ids, np.zeros(tasks, dtype=int), high, pick))
        models = {
            "abstract": AbstractCost(sc),
            "straight": StraightLineCost(sc),
            "distance": DistanceCost(sc, planner),
            "time": TimeCost(sc, planner),
        }
        for name, cost in models.items():
            market = _build(MarketAllocator, sc, np.random.default_rng([seed, m, 1]))
            secs = _time_rounds(market, state, cost, batches)
            row[f"{name}_ms"] = float(secs.mean() * 1e3)
        out[str(m)] = row
    return out


def bench_assignment(
    sizes: Sequence[int] = (100, 750, 1000, 2000), seed: int = 0, repeat: int = 3
) -> dict[str, dict[str, float]]:
    """scipy's ``linear_sum_assignment`` against LAPJV (``lapx``'s ``lap.lapjv``) on the
    matrices of ``mrta bench``'s spatial rounds.

    n robots at random free points of the 1000-robot arena bid planned distances for n tasks
    at random sites (a busy round: as many tasks as free robots), folded into one assignment
    problem as :func:`allocation.auction.solve_priority_assignment_dense` does (35 % high
    priority). ``dense``: every robot bids; ``sparse``: each robot is capable of a task with
    probability 0.1 (a team like ``scale1000``: 50 types, 2-8 each). Best of ``repeat``.

    Returns:
        ``{"1000": {"scipy_dense_ms", "lapjv_dense_ms", "ratio_dense", "same_dense", ...}}``;
        the ``lapjv`` entries only if ``lapx`` is installed (it is not a dependency).
        ``ratio`` is scipy's time over LAPJV's (> 1: LAPJV faster), ``same`` 1.0 if both
        optima have the same objective (to 1e-13 relative) and 0.0 if not.
    """
    from scipy.optimize import linear_sum_assignment

    from allocation.auction import priority_cost_matrix
    from scenarios.bench.arena import bench_scenario
    from sim.spatial.navigation.planning import GridPlanner

    try:
        import lap
    except ImportError:
        lap = None
    rng = np.random.default_rng([seed, 1000])
    sc = bench_scenario(1000, rng)
    planner = GridPlanner(sc.spatial)
    sites = planner.site_points()

    def best(fn, times: int):
        secs = []
        for _ in range(times):
            t0 = time.perf_counter()
            result = fn()
            secs.append(time.perf_counter() - t0)
        return 1e3 * min(secs), result

    out: dict[str, dict[str, float]] = {}
    for n in sizes:
        cand = rng.uniform(0.0, sc.spatial.width_m, size=(4 * n, 2))
        xy = cand[planner.free(cand)][:n]
        dist = planner.distances(xy, sites[rng.integers(0, len(sites), size=n)])
        high = rng.random(n) < 0.35
        row: dict[str, float] = {"bidders": int(n)}
        for kind in ("dense", "sparse"):
            bids = dist if kind == "dense" else np.where(rng.random((n, n)) < 0.1, dist, np.inf)
            cost = priority_cost_matrix(bids, high)[0]
            ms, (r, c) = best(lambda cost=cost: linear_sum_assignment(cost), repeat)
            row[f"scipy_{kind}_ms"] = ms
            if lap is not None:
                ms_l, (_, x, _) = best(
                    lambda cost=cost: lap.lapjv(cost, extend_cost=True), 1 if n > 1000 else repeat
                )
                taken = x >= 0
                ours = cost[np.flatnonzero(taken), x[taken]].sum()
                row[f"lapjv_{kind}_ms"] = ms_l
                row[f"ratio_{kind}"] = ms / ms_l
                row[f"same_{kind}"] = float(np.isclose(ours, cost[r, c].sum(), rtol=1e-13, atol=0))
        out[str(n)] = row
    return out
