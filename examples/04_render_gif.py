"""Write your own spatial scenario, validate it, run it and render a trajectory GIF headless.

What it shows
    A scenario is a TOML file (format: scenarios/data/paper_spatial.toml and README, "Scenario
    files"). The one below is small: a 12 m x 8 m arena with one obstacle, 4 robots, two task
    types (``pick`` and ``inspect``, two sites each) and a short task stream. The script

    1. writes it to ``arena_12x8.toml`` and loads it with ``scenarios.loader.load_scenario``,
       which validates everything before any work (unknown keys, sites inside obstacles,
       unreachable sites, robots starting in walls, ...) and raises ``ScenarioError`` with a
       one-line message; it also shows that message for a broken copy (a site inside the
       obstacle);
    2. runs it with one allocator (``RunSpec`` takes the TOML path as the scenario) while a
       ``sim.recording.TrajectoryRecorder`` records robot poses and task events;
    3. draws the recording into ``arena_12x8.gif`` with ``sim.render.render_gif`` (matplotlib's
       Agg canvas and Pillow: no display needed), as ``mrta render`` does.

    The same from the shell: ``mrta validate arena_12x8.toml`` and
    ``mrta render arena_12x8.toml --allocator market --gif arena.gif``.

Outputs (in the current folder, or ``--out``)
    ``arena_12x8.toml``  the scenario;
    ``arena_12x8.gif``   the animation (first ``--seconds`` simulated seconds).

Run
    cd "$(mktemp -d)" && python /path/to/examples/04_render_gif.py
        2 task sets, 150 frames of 600 px: about 5 s;
    ... --quick                       1 set, 20 frames of 300 px: about 3 s;
    ... --allocator expt --seconds 240 --frames 300   other allocator, longer film.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.loader import ScenarioError, load_scenario
from scenarios.protocol import RunSpec, execute
from sim.recording import TrajectoryRecorder
from sim.render import render_gif
from sim.render.style import fitted_height

NAME = "arena_12x8"
SCENARIO_TOML = """\
# A small spatial scenario: 12 m x 8 m, one obstacle, 4 robots, 2 task types.
[scenario]
name = "arena_12x8"
description = "Four robots, pick and inspect tasks around one obstacle"
task_types = ["pick", "inspect"]
exec_time_s = [8.0, 5.0]

# start: where the robot stands when a run begins (m); cost: abstract cost per capable type
[[robots]]
name = "A"
start = [1.0, 2.0]
capabilities = ["pick", "inspect"]
cost = { pick = 3, inspect = 3 }

[[robots]]
name = "B"
start = [1.0, 6.0]
capabilities = ["pick"]
cost = { pick = 2 }

[[robots]]
name = "C"
start = [11.0, 2.0]
capabilities = ["inspect"]
cost = { inspect = 2 }

[[robots]]
name = "D"
start = [11.0, 6.0]
capabilities = ["pick", "inspect"]
cost = { pick = 4, inspect = 4 }

[stream]
batch_min = 1
batch_max = 3
p_high = 0.3
n_sets = 2
rounds_per_set = 8
learn_sets = 1           # set 1 learns
test_sets = 1            # set 2 is tested
announce_interval_s = 8.0

[spatial]
width_m = 12.0
height_m = 8.0
obstacles = [[[5.0, 2.5], [7.0, 2.5], [7.0, 5.5], [5.0, 5.5]]]

[spatial.sites]
pick = [[3.0, 7.0], [9.0, 1.0]]
inspect = [[6.0, 7.0], [6.0, 1.0]]

[spatial.drive]
radius_m = 0.25
"""
BROKEN_SITE = ("pick = [[3.0, 7.0], [9.0, 1.0]]", "pick = [[3.0, 7.0], [6.0, 4.0]]")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1 set, 20 small frames")
    parser.add_argument("--allocator", default="market", help="market, ql, expt, module:Class")
    parser.add_argument("--cost", default="distance", help="abstract, distance or time")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--frames", type=int, default=None, help="GIF frames (default 150)")
    parser.add_argument("--seconds", type=float, default=120.0, help="simulated seconds to draw")
    parser.add_argument("--out", type=Path, default=Path("."), help="output folder")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)

    # 1. write, load and validate
    toml_path = args.out / f"{NAME}.toml"
    toml_path.write_text(SCENARIO_TOML)
    scenario = load_scenario(toml_path)
    print(
        f"{toml_path}: ok: {scenario.n_robots} robots, {scenario.n_types} task types, "
        f"{scenario.stream.n_sets} sets x {scenario.stream.rounds_per_set} rounds, "
        f"{scenario.spatial.width_m:g} x {scenario.spatial.height_m:g} m"
    )
    broken = args.out / f"{NAME}_broken.toml"
    broken.write_text(SCENARIO_TOML.replace(*BROKEN_SITE))
    try:
        load_scenario(broken)
    except ScenarioError as exc:
        print(f"a broken copy is refused: {exc}")
    finally:
        broken.unlink()

    # 2. run it while recording
    overrides = (("stream.n_sets", 1), ("stream.test_sets", 1)) if args.quick else ()
    spec = RunSpec(str(toml_path), args.allocator, args.cost, args.seed, overrides)
    recorder = TrajectoryRecorder.for_scenario(scenario)
    summary = execute(spec, recorder=recorder)
    traj = recorder.finish()
    done = summary["completion"]["overall"]
    print(
        f"{args.allocator}, seed {args.seed}: {summary['tasks']['allocated']} of "
        f"{summary['tasks']['announced']} test-phase tasks allocated (high {done['high']:.2f}, "
        f"low {done['low']:.2f}), {summary['spatial']['distance_m']:.0f} m driven for them"
    )

    # 3. render
    width = 300 if args.quick else 600
    frames = args.frames or (20 if args.quick else 150)
    size = (width, fitted_height(width, traj.arena_wh))
    t_to = min(float(traj.times_s[-1]), args.seconds)
    gif = render_gif(traj, args.out / f"{NAME}.gif", frames=frames, fps=10, size=size, t_to=t_to)
    print(f"wrote {gif} ({frames} frames of {size[0]}x{size[1]} px, 0-{t_to:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
