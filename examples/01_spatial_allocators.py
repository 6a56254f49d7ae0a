"""Compare allocators in the pymunk world: per-task rows, a CSV and a plot.

What it shows
    The spatial scenario ``paper_spatial`` (10 differential-drive robots in a 20 m x 20 m hall)
    is played from Python for the market auction, QL-MRTA and ExpT-MRTA, all bidding the
    planned path length (``cost="distance"``), over a few seeds. Every seed gives every
    allocator the very same task stream. ``execute(spec, task_table=True)`` adds one row per
    test-phase task that was *allocated* (task, type, high, robot, bid, distance_m,
    time_to_start_s, time_to_finish_s, ok, reason); lost tasks are not in it, so the
    completion ratios come from the run summary (``summary["completion"]["overall"]``).

Outputs (in the current folder, or ``--out``)
    ``spatial_tasks.csv``       one row per allocated test-phase task, with allocator and seed;
    ``spatial_completion.csv``  one row per run: completion (low, high, all), tasks, metres;
    ``spatial_allocators.png``  distance per task (box plot) and completion per allocator.

With pandas installed (it is not a dependency of expt-mrta) the task rows are also turned into
a DataFrame and summarised with ``groupby``; without it the script uses numpy and ``csv``.

Run
    cd "$(mktemp -d)" && python /path/to/examples/01_spatial_allocators.py
        6 task sets (4 learning, last 2 tested), 3 seeds: about 30 s in one process;
    ... --quick     3 sets (2 learning, 1 tested), 2 seeds: about 10 s;
    ... --full      the paper's whole protocol (45 sets): about 30 s per run, so 9 runs take
                    about 5 min on one core (``--workers 2``: two processes; ``--seeds 5``).
"""

from __future__ import annotations

import argparse
import csv
import time
from concurrent.futures import ProcessPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np

from scenarios.protocol import RunSpec, execute

ALLOCATORS = ("market", "ql", "expt")
SCENARIO = "paper_spatial"
COST = "distance"  # planned path length, m; "time" bids the seconds to finish instead
SHORT = (("stream.n_sets", 6), ("stream.learn_sets", 4), ("stream.test_sets", 2))
QUICK = (("stream.n_sets", 3), ("stream.learn_sets", 2), ("stream.test_sets", 1))
TASK_COLUMNS = (
    "allocator",
    "seed",
    "task",
    "type",
    "high",
    "robot",
    "bid",
    "distance_m",
    "time_to_start_s",
    "time_to_finish_s",
    "ok",
)
RUN_COLUMNS = (
    "allocator",
    "seed",
    "completion_low",
    "completion_high",
    "completion_all",
    "announced",
    "allocated",
    "distance_per_task_m",
)


def run_all(specs: list[RunSpec], workers: int) -> list[dict]:
    """``execute`` every spec with its task table; in ``workers`` processes if more than one.

    ``scenarios.protocol.run_many`` runs specs in parallel too, but it has no ``task_table``
    switch, so we hand ``execute`` to a process pool ourselves.
    """
    run = partial(execute, task_table=True)
    if workers <= 1:
        return [run(spec) for spec in specs]
    with ProcessPoolExecutor(max_workers=workers) as pool:
        return list(pool.map(run, specs))


def task_rows(summary: dict) -> list[dict]:
    """The run's task table (a dict of columns) as a list of row dicts, tagged with the run."""
    spec, table = summary["spec"], summary["task_table"]
    n = len(table["task"])
    return [
        {
            "allocator": spec["allocator"],
            "seed": spec["seed"],
            **{k: table[k][i] for k in TASK_COLUMNS[2:]},
        }
        for i in range(n)
    ]


def run_row(summary: dict) -> dict:
    overall = summary["completion"]["overall"]
    return {
        "allocator": summary["spec"]["allocator"],
        "seed": summary["spec"]["seed"],
        "completion_low": overall["low"],
        "completion_high": overall["high"],
        "completion_all": overall["all"],
        "announced": summary["tasks"]["announced"],
        "allocated": summary["tasks"]["allocated"],
        "distance_per_task_m": summary["spatial"]["distance_per_task_m"],
    }


def write_csv(path: Path, rows: list[dict], columns: tuple[str, ...]) -> None:
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def summarise(tasks: list[dict], runs: list[dict]) -> None:
    """Print mean distance per task and completion per allocator (pandas if it is there)."""
    try:
        import pandas as pd
    except ImportError:
        pd = None
    if pd is not None:
        df = pd.DataFrame(tasks)
        print(df[df["ok"]].groupby("allocator")[["distance_m", "time_to_finish_s"]].mean())
        print(pd.DataFrame(runs).groupby("allocator")[["completion_high", "completion_all"]].mean())
        return
    print(f"{'allocator':<10} {'tasks':>6} {'m/task':>7} {'high':>6} {'all':>6}")
    for name in ALLOCATORS:
        dist = np.array([t["distance_m"] for t in tasks if t["allocator"] == name and t["ok"]])
        mine = [r for r in runs if r["allocator"] == name]
        high = np.mean([r["completion_high"] for r in mine])
        both = np.mean([r["completion_all"] for r in mine])
        mean_m = dist.mean() if dist.size else float("nan")
        print(f"{name:<10} {dist.size:>6} {mean_m:>7.2f} {high:>6.3f} {both:>6.3f}")


def plot(tasks: list[dict], runs: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")  # headless: no display needed
    import matplotlib.pyplot as plt

    fig, (ax_d, ax_c) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    dist = [[t["distance_m"] for t in tasks if t["allocator"] == a and t["ok"]] for a in ALLOCATORS]
    ax_d.boxplot(dist, tick_labels=ALLOCATORS, showfliers=False)
    ax_d.set_ylabel("distance driven per task (m)")
    ax_d.set_title("test-phase tasks, all seeds")

    x = np.arange(len(ALLOCATORS))
    for off, key, label in ((-0.2, "completion_high", "high"), (0.2, "completion_all", "all")):
        per = [[r[key] for r in runs if r["allocator"] == a] for a in ALLOCATORS]
        ax_c.bar(x + off, [np.mean(v) for v in per], width=0.38, label=label, alpha=0.7)
        for i, vals in enumerate(per):  # one dot per seed
            ax_c.plot(np.full(len(vals), x[i] + off), vals, "k.", ms=4)
    ax_c.set_xticks(x, ALLOCATORS)
    ax_c.set_ylim(0, 1)
    ax_c.set_ylabel("share of test-phase tasks allocated")
    ax_c.legend(title="priority", loc="lower right")
    fig.suptitle(f"{SCENARIO}, {COST} bids")
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 sets, 2 seeds (about 10 s)")
    parser.add_argument("--full", action="store_true", help="the whole protocol (45 sets)")
    parser.add_argument("--seeds", type=int, default=None, help="seeds 0..N-1 (default 3)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    overrides = () if args.full else QUICK if args.quick else SHORT
    n_seeds = args.seeds if args.seeds is not None else 2 if args.quick else 3
    specs = [
        RunSpec(SCENARIO, alloc, cost=COST, seed=seed, overrides=overrides)
        for seed in range(n_seeds)
        for alloc in ALLOCATORS
    ]
    t0 = time.perf_counter()
    summaries = run_all(specs, args.workers)
    print(f"{len(specs)} runs in {time.perf_counter() - t0:.1f} s")

    tasks = [row for s in summaries for row in task_rows(s)]
    runs = [run_row(s) for s in summaries]
    write_csv(args.out / "spatial_tasks.csv", tasks, TASK_COLUMNS)
    write_csv(args.out / "spatial_completion.csv", runs, RUN_COLUMNS)
    summarise(tasks, runs)
    plot(tasks, runs, args.out / "spatial_allocators.png")
    for name in ("spatial_tasks.csv", "spatial_completion.csv", "spatial_allocators.png"):
        print(f"wrote {args.out / name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
