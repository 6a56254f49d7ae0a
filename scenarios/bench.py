"""``mrta bench``: speed and memory, reported as ratios against baselines measured in the same run.

- ``sim``: the full spatial loop against a bare ``space.step`` loop on the same bodies. With 10
  robots it is the paper scenario itself (``paper_spatial``, market auction, distance bids):
  the task stream, bidding, allocation, physics, control, task bookkeeping and trajectory
  recording of ``mrta run``, timed over the first ``PAPER_SETS`` task sets (learning and test
  phase). Beside it, and for 100 and 1000 robots, a synthetic arena in which every robot is
  always busy (``sim.bench_sim``: every simulated second the free robots' tasks are auctioned,
  bids being straight-line distances; physics, control, task bookkeeping and recording as in a
  run); the 10-robot figures of that arena are reported as ``busy_*`` members of the ``"10"``
  row. ``bids_ms`` is the time the ``distance`` cost model takes to bid every robot on a
  paper-sized batch of 7 tasks (planned path lengths around the obstacles);
- ``gif``: a 200-frame 600x600 GIF of the 10-robot ``paper_spatial`` scenario (one task set,
  ExpT-MRTA, distance cost, seed 0) with our renderer against ``FuncAnimation`` +
  ``PillowWriter`` on the same frames (``sim.bench_render``);
- ``alloc``: allocation time per round against team size, 50 task types, 7 tasks a round
  (``allocation.bench_alloc``), market plus QL-MRTA and ExpT-MRTA.

Machines here are shared and noisy: compare the ratios, not the absolute times.
"""

from __future__ import annotations

import sys

PARTS = ("sim", "gif", "alloc")
PAPER_SETS = 8  # task sets of paper_spatial timed by the 10-robot figure (about 3,400 s simulated)


def market_on_straight_lines(scenario, world):
    """``allocate(batch)`` for ``sim.bench_sim``: the market auction among the free robots,
    each bidding its straight-line distance to each task (planned distances for hundreds of
    robots and tasks would measure the planner, which ``bids_ms`` reports on its own)."""
    import numpy as np

    from allocation.auction import solve_priority_assignment

    def allocate(batch):
        state = world.snapshot()
        free = np.flatnonzero(state.free)
        z = state.positions[free] @ np.array([1.0, 1j])
        costs = np.full((len(state.free), len(batch.ids)), np.inf)
        costs[free] = np.abs(z[:, None] - batch.sites @ np.array([1.0, 1j]))
        won = solve_priority_assignment(costs[free], batch.high)  # only free robots bid
        return np.where(won >= 0, free[np.maximum(won, 0)], -1), costs

    return allocate


def bench_paper_loop(sets: int = PAPER_SETS, seed: int = 0) -> dict[str, float]:
    """The 10-robot paper scenario through the whole loop of ``mrta run``, against bare
    ``space.step`` on the same bodies afterwards.

    Returns:
        ``{"steps_per_s", "rtf", "bare_ratio", "bare_steps_per_s", "sim_s", "wall_s"}``.
    """
    import time

    from learning.episode import run_protocol
    from scenarios.protocol import RunSpec, build_run
    from sim.bench_sim import _bare, timed_avoidance
    from sim.recording import TrajectoryRecorder

    part = (("stream.n_sets", sets), ("stream.learn_sets", sets), ("stream.test_sets", sets))
    spec = RunSpec("paper_spatial", "market", "distance", seed, part)
    scenario, stream, world, cost, allocator, rng = build_run(spec)
    recorder = TrajectoryRecorder.for_scenario(scenario)
    world.recorder = recorder
    steps0 = world.steps_
    t0 = time.perf_counter()
    with timed_avoidance() as avoid_s:
        run_protocol(scenario, stream, allocator, world, cost, rng, trace=False, recorder=recorder)
    wall = time.perf_counter() - t0
    steps = world.steps_ - steps0
    bare = _bare(world, max(60, steps // 4))
    return {
        "steps_per_s": steps / wall,
        "rtf": steps * world.dt_s / wall,
        "bare_ratio": (wall / steps) / bare,
        "bare_steps_per_s": 1.0 / bare,
        "sim_s": steps * world.dt_s,
        "wall_s": wall,
        "avoid_share": avoid_s[0] / wall,
        "avoid_bare_ratio": (avoid_s[0] / steps) / bare,
    }


def _paper_trajectory():
    from scenarios.protocol import RunSpec, _load, execute
    from sim.recording import TrajectoryRecorder

    sc = _load("paper_spatial")
    recorder = TrajectoryRecorder.for_scenario(sc)
    one_set = (("stream.n_sets", 1), ("stream.learn_sets", 1), ("stream.test_sets", 1))
    execute(RunSpec("paper_spatial", "expt", "distance", 0, one_set), recorder=recorder)
    return recorder.finish()


def run_bench(parts=PARTS, progress: bool = True) -> dict:
    """Run the chosen parts; print a readable table when ``progress`` is on."""
    out: dict = {}

    def say(text: str) -> None:
        if progress:
            print(text, file=sys.stdout, flush=True)

    if "sim" in parts:
        from sim.bench_sim import bench_sim

        say("sim: full loop vs bare space.step, physics at 60 Hz, control at 10 Hz ...")
        synthetic = bench_sim(allocator=market_on_straight_lines)
        paper = bench_paper_loop()
        paper.update({f"busy_{k}": v for k, v in synthetic.pop("10").items()})
        out["sim"] = {"10": paper, **synthetic}
        for n, r in out["sim"].items():
            what = "paper_spatial, whole run loop" if n == "10" else "busy synthetic arena"
            if n != "10":
                what += f"; planned-distance bids, all robots x 7 tasks: {r['bids_ms']:.1f} ms"
            say(
                f"  {n:>5} robots: {r['steps_per_s']:>9,.0f} steps/s  {r['rtf']:>7,.0f}x real time "
                f" loop/bare = {r['bare_ratio']:.2f}  avoidance/bare = {r['avoid_bare_ratio']:.2f}"
                f" ({r['avoid_share']:.0%} of the loop)  ({what})"
            )
        busy = out["sim"]["10"]
        say(
            f"     10 robots, busy synthetic arena: {busy['busy_rtf']:,.0f}x real time, "
            f"loop/bare = {busy['busy_bare_ratio']:.2f}"
        )
    if "gif" in parts:
        from sim.bench_render import bench_gif

        say("gif: 200 frames 600x600, paper_spatial, ours vs FuncAnimation + PillowWriter ...")
        out["gif"] = bench_gif(_paper_trajectory(), frames=200, size=(600, 600))
        g = out["gif"]
        say(
            f"  ours {g['seconds']:.2f} s, baseline {g['baseline_seconds']:.2f} s "
            f"({g['baseline_seconds'] / g['seconds']:.1f}x faster)"
        )
    if "alloc" in parts:
        from allocation.bench_alloc import bench_alloc
        from learning import ALLOCATORS

        say("alloc: ms per round, 50 types, 7 tasks a round ...")
        out["alloc"] = bench_alloc(allocators=ALLOCATORS)
        for n, r in out["alloc"].items():
            extra = "  ".join(f"{k} {v:.3g}" for k, v in r.items() if k != "ms_per_round")
            say(f"  {n:>5} robots: market {r['ms_per_round']:.3f} ms/round  {extra}")
    return out
