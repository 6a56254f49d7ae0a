"""Write your own allocator and compare it with the built-ins on the same seeded task streams.

What it shows
    ``KeepGeneralists`` below is a complete allocator in about 30 lines: a subclass of
    ``allocation.base.BaseAllocator`` whose ``allocate`` builds a bid matrix and lets the
    package's exact priority auction (``allocation.auction.solve_priority_assignment``) pick
    the winners. Its rule: high-priority tasks are auctioned as in the market (every free robot
    bids its cost); for low-priority tasks a robot adds a surcharge per task type it can do, so
    specialists take them first, and generalists stop bidding for them altogether when few
    robots are free: they stay available for the next high-priority tasks.
    ``KeepMoreGeneralists`` shows the usual way to vary a parameter: a subclass.

    The allocators run on the abstract ``paper`` scenario (10 robots, 8 task types, costs from
    a table) for a few seeds; a seed fixes the task stream, so every allocator of a seed sees
    the very same tasks. The script prints mean completion per allocator over the seeds and
    writes one row per run to ``custom_allocator.csv`` (in the current folder, or ``--out``).

How your class reaches the runner
    ``RunSpec.allocator`` is a *name*: a built-in (``market``, ``ql``, ``expt``, ``greedy``,
    ``cbba``), an installed entry point, or ``module:Class``. There is no way to pass the class
    object itself (``learning.registry.allocator_class`` takes a string), so ``module`` must be
    importable. This script puts its own folder on ``sys.path`` and names the classes
    ``02_custom_allocator:KeepGeneralists``: the runner then imports this file a second time,
    as the module ``02_custom_allocator`` (only the definitions run; ``main`` is guarded by
    ``if __name__ == "__main__"``). The same names work in worker processes and with the CLI:
    ``PYTHONPATH=/path/to/examples mrta compare paper --cost abstract --allocators
    market,02_custom_allocator:KeepGeneralists``. In your own project, put the class in a
    module of its own (``my_alloc.py``) and see docs/allocators.md.

Run
    cd "$(mktemp -d)" && python /path/to/examples/02_custom_allocator.py
        the paper's whole protocol (45 sets, the last 30 tested), 5 seeds: about 20 s;
    ... --quick     6 sets (4 learning, last 2 tested), 2 seeds: a few seconds;
    ... --seeds 10  the ten seeds of ``mrta reproduce``.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

from allocation.auction import solve_priority_assignment
from allocation.base import BaseAllocator
from scenarios.protocol import RunSpec, run_many

SCENARIO = "paper"
BUILT_INS = ("market", "greedy", "cbba", "ql", "expt")
QUICK = (("stream.n_sets", 6), ("stream.learn_sets", 4), ("stream.test_sets", 2))


class KeepGeneralists(BaseAllocator):
    """Market auction; low-priority tasks go to specialists first, generalists keep free."""

    name = "keep_generalists"
    surcharge = 1.0  # added to a low-priority bid per task type the robot can do (cost units)
    generalist = 4  # robots that can do this many types or more are generalists
    reserve = 3  # generalists skip low-priority tasks while at most this many robots are free

    def __init__(self, scenario) -> None:
        super().__init__(scenario)
        self.versatility = self.capable.sum(axis=1)  # (m,) task types each robot can do

    def allocate(self, state, batch, costs):
        bids = self.bids(state, costs)  # (m, k): cost for free robots, inf otherwise
        low = ~batch.high
        bids[:, low] += self.surcharge * self.versatility[:, None]
        if state.free.sum() <= self.reserve:
            bids[np.ix_(self.versatility >= self.generalist, low)] = np.inf
        return solve_priority_assignment(bids, batch.high), bids


class KeepMoreGeneralists(KeepGeneralists):
    """The same rule with a larger reserve."""

    name = "keep_more_generalists"
    reserve = 5


def plugin_names() -> list[str]:
    """``module:Class`` names of this file's allocators, with this folder made importable."""
    here = Path(__file__).resolve()
    if str(here.parent) not in sys.path:
        sys.path.insert(0, str(here.parent))
    return [f"{here.stem}:{cls.__name__}" for cls in (KeepGeneralists, KeepMoreGeneralists)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="6 sets, 2 seeds")
    parser.add_argument("--seeds", type=int, default=None, help="seeds 0..N-1 (default 5)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1)")
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    overrides = QUICK if args.quick else ()
    n_seeds = args.seeds if args.seeds is not None else 2 if args.quick else 5
    names = [*BUILT_INS, *plugin_names()]
    specs = [
        RunSpec(SCENARIO, name, seed=seed, overrides=overrides)
        for seed in range(n_seeds)
        for name in names
    ]
    summaries = run_many(specs, workers=args.workers, progress=False)

    rows = []
    for spec, summary in zip(specs, summaries, strict=True):
        overall = summary["completion"]["overall"]
        rows.append(
            {
                "allocator": spec.allocator,
                "seed": spec.seed,
                "completion_low": overall["low"],
                "completion_high": overall["high"],
                "completion_all": overall["all"],
                "announced": summary["tasks"]["announced"],
                "allocated": summary["tasks"]["allocated"],
            }
        )
    path = args.out / "custom_allocator.csv"
    with path.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)

    print(f"{SCENARIO}: test-phase completion, mean over {n_seeds} seeds")
    print(f"| {'allocator':<40} | {'low':>6} | {'high':>6} | {'all':>6} |")
    print(f"|{'-' * 42}|{'-' * 8}|{'-' * 8}|{'-' * 8}|")
    for name in names:
        mine = [r for r in rows if r["allocator"] == name]
        means = [np.mean([r[f"completion_{p}"] for r in mine]) for p in ("low", "high", "all")]
        print(f"| {name:<40} | " + " | ".join(f"{v:>6.3f}" for v in means) + " |")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
