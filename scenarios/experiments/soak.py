"""``mrta soak``: a long spatial run that must stay healthy (memory, overlaps, stuck robots).

The run plays as many task sets as it takes to announce ``tasks`` tasks, keeping only counts
(``run_protocol(keep=False)``), so memory must stay flat after warm-up. It reports the peak
resident set size at 10 % and at 100 % of the rounds, the deepest robot-robot or robot-wall
overlap the world saw, failed (unreachable or stuck) tasks, and the wall time. Every round's
and every set's invariants are checked as in any run; a violation stops the soak.
"""

from __future__ import annotations

import math
import resource
import time

from learning.episode import run_protocol
from scenarios.experiments.protocol import RunSpec, UserError, build_run, load_named


def peak_rss_mib() -> float:
    """Peak resident set size of this process so far (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def soak(
    scenario: str = "large",
    tasks: int = 100_000,
    allocator: str = "market",
    cost: str = "distance",
    seed: int = 0,
    progress: bool = True,
) -> dict:
    """Run the soak and return its figures (JSON-able)."""
    from scenarios.experiments.progress import progress_bar

    sc = load_named(scenario)
    if sc.spatial is None:
        raise UserError(f"{scenario}: soak needs a spatial scenario")
    if tasks < 1:
        raise UserError(f"--tasks must be at least 1, got {tasks}")
    s = sc.stream
    per_set = s.rounds_per_set * (s.batch_min + s.batch_max) / 2
    n_sets = max(1, math.ceil(tasks / per_set))
    overrides = (("stream.n_sets", n_sets), ("stream.learn_sets", n_sets), ("stream.test_sets", 1))
    spec = RunSpec(scenario, allocator, cost, seed, overrides)
    scen, stream, world, cost_model, alloc, rng = build_run(spec)
    rounds_total = n_sets * s.rounds_per_set
    marks = {
        max(1, rounds_total // 10): "rss_peak_mib_at_10pct",
        rounds_total: "rss_peak_mib_at_100pct",
    }
    out: dict = {
        "scenario": scen.name,
        "robots": scen.n_robots,
        "allocator": allocator,
        "cost": cost,
        "seed": seed,
        "sets": n_sets,
        "rounds": rounds_total,
    }
    bar = progress_bar(rounds_total, f"soak {scen.name}", "round", progress)
    count = {"rounds": 0}

    def on_round() -> None:
        count["rounds"] += 1
        bar.update()
        key = marks.get(count["rounds"])
        if key:
            out[key] = peak_rss_mib()

    t0 = time.perf_counter()
    try:
        record = run_protocol(
            scen,
            stream,
            alloc,
            world,
            cost_model,
            rng,
            phases=(("learn", list(range(n_sets))),),
            trace=False,
            on_round=on_round,
            keep=False,
        )
    finally:
        bar.close()
    wall = time.perf_counter() - t0
    phase = record.learn
    physics = world.summary()
    out.update(
        tasks_announced=phase.announced,
        tasks_allocated=phase.allocated,
        tasks_failed=phase.failed,
        wall_s=wall,
        sim_s=physics["sim_time_s"],
        rtf=physics["sim_time_s"] / wall,
        max_overlap_m=physics["max_overlap_m"],
        collisions_robot=physics["collisions_robot"],
        collisions_wall=physics["collisions_wall"],
        invariants="held (checked every round and every set)",
    )
    out["rss_growth_mib"] = out["rss_peak_mib_at_100pct"] - out["rss_peak_mib_at_10pct"]
    return out


__all__ = ["peak_rss_mib", "soak"]
