"""``mrta bench``: speed and memory, reported as ratios against baselines measured in the same run.

- ``sim``: the full spatial loop (physics + control + task bookkeeping + recording) against a bare
  ``space.step`` loop on the same bodies, for 10, 100 and 1000 robots (``sim.bench_sim``);
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

        say("sim: full loop vs bare space.step, physics at 60 Hz ...")
        out["sim"] = bench_sim()
        for n, r in out["sim"].items():
            say(
                f"  {n:>5} robots: {r['steps_per_s']:>9,.0f} steps/s  {r['rtf']:>7,.0f}x real time "
                f" loop/bare = {r['bare_ratio']:.2f}"
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
