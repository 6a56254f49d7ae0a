"""``mrta soak``: a long spatial run that must stay healthy (memory, overlaps, stuck robots).

The run plays as many task sets as it takes to announce ``tasks`` tasks, keeping only counts
(``run_protocol(keep=False)``), so memory must stay flat after warm-up. It reports the peak
resident set size at 10 % and at 100 % of the rounds, the deepest robot-robot or robot-wall
overlap the world saw, failed (unreachable or stuck) tasks, and the wall time. Every round's
and every set's invariants are checked as in any run; a violation stops the soak.

With robot faults (``faults``: overrides of the ``[faults]`` table, ``mrta soak --faults``) it
also reports the tasks' fates (``learning.fates``: the ledger checks every set that each
announced task ended exactly once, so ``tasks_unaccounted`` is 0 or the soak stopped), the
abandonments, the robots' availability, and the longest time a driving robot went without
progress when a round was announced (``max_no_progress_s``; past the stuck timeout a robot
recovers or fails with a reason, so this stays below the timeout plus a control period and
the announcement interval's sampling).
"""

from __future__ import annotations

import math
import resource
import time

import numpy as np

from learning.episode import run_protocol
from learning.fates import ABANDON_ENDS, FATES
from scenarios.experiments.protocol import RunSpec, UserError, build_run, load_named
from sim.states import DRIVING


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
    faults: tuple = (),
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
    overrides += tuple(faults)
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
    count = {"rounds": 0, "no_progress_s": 0.0}
    spatial = scen.spatial is not None  # a world with space is a PymunkWorld, with a fleet

    def on_round() -> None:
        count["rounds"] += 1
        f = world.fleet if spatial else None
        if f is not None:
            drv = (f.state == DRIVING) & np.isfinite(f.t_progress_s)
            if drv.any():
                worst = world.time_s - float(f.t_progress_s[drv].min())
                count["no_progress_s"] = max(count["no_progress_s"], worst)
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
    out["max_no_progress_s"] = count["no_progress_s"]
    out["stuck_timeout_s"] = scen.spatial.stuck_timeout_s
    if scen.has_faults:
        fates = dict(zip(FATES, phase.fates.tolist(), strict=True))
        ends = dict(zip(ABANDON_ENDS, phase.abandon_ends.tolist(), strict=True))
        out.update(
            faults=", ".join(f"{k}={v}" for k, v in faults) or "scenario's [faults] table",
            **{f"fate_{k}": v for k, v in fates.items()},
            tasks_unaccounted=phase.announced - phase.abandon_ends[0] - sum(fates.values()),
            **{f"abandon_{k}": v for k, v in ends.items()},
            robot_failures=int(record.failures.sum()),
            availability_mean=float(record.availability.mean()),
            availability_min=float(record.availability.min()),
        )
    return out


__all__ = ["peak_rss_mib", "soak"]
