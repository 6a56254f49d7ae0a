"""Argument parsing of the ``mrta`` command line: subcommands, their options and value types."""

from __future__ import annotations

import argparse
import contextlib
import io
import math
from collections.abc import Sequence
from pathlib import Path

from scenarios.experiments.hardcases import LOOK_AHEAD_DEFAULT
from sim.scenario import AVOIDANCE, LOOK_AHEAD

EXIT_USAGE = 2
COSTS = ("abstract", "distance", "time")
SCENARIO = "bundled scenario name (mrta validate --list) or TOML path"
WORKERS = "processes (default: all cores)"
NO_PROGRESS = "no progress bars (they are off anyway when stderr is not a terminal)"


class _Help(argparse.HelpFormatter):
    """Appends ``(default: X)`` to an option's help unless the help already names its default."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        hidden = default is None or default is False or default is argparse.SUPPRESS
        shown = not hidden and not action.required
        if shown and "default" not in text and action.option_strings:
            if isinstance(default, list | tuple):
                default = ",".join(str(x) for x in default) if default else "none"
            text += f" (default: {str(default).replace('%', '%%')})"
        return text


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", _Help)
        super().__init__(*args, **kwargs)

    def error(self, message: str):  # one line, exit 2 (argparse prints usage too; keep it short)
        command = self.prog.split()[-1]  # "mrta" itself for unknown arguments of any command
        hint = "mrta --help" if command == "mrta" else f"mrta {command} --help"
        self.exit(EXIT_USAGE, f"mrta: error: {message} (see '{hint}')\n")


MAX_SEEDS = 10_000  # seeds one command runs (scenarios.experiments.budget.MAX_SEEDS)


def _seed_list(text: str) -> list[int]:
    """'10' -> seeds 0..9; '3,5,8' -> those seeds; '2-6' -> 2..6; at most MAX_SEEDS seeds,
    counted before any list is built."""
    try:
        if "," in text:
            parts = [s for s in text.split(",") if s.strip()]
            _seed_count(len(parts))
            seeds = [int(s) for s in parts]
        elif "-" in text.strip("-"):
            a, b = text.split("-", 1)
            lo, hi = int(a), int(b)
            _seed_count(hi - lo + 1)
            seeds = list(range(lo, hi + 1))
        else:
            n = int(text)
            if n < 1:
                raise argparse.ArgumentTypeError(f"need at least one seed, got {n}")
            _seed_count(n)
            seeds = list(range(n))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a seed count or list: {text!r}") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"seeds must be non-negative integers: {text!r}")
    return seeds


def _out_path(text: str) -> Path:
    """argparse type of an output path: not empty (``Path('')`` would be the current folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file or folder")
    return Path(text)


def _seed_count(n: int) -> None:
    if n > MAX_SEEDS:
        raise argparse.ArgumentTypeError(f"{n:,} seeds: at most {MAX_SEEDS:,} in one command")


def _float_list(text: str) -> tuple[float, ...]:
    if text.strip().lower() == "none":
        return ()
    try:
        values = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"not a comma-separated list of numbers: {text!r}"
        ) from None
    if not values or any(not 0 <= v <= 2 for v in values):
        raise argparse.ArgumentTypeError(f"delta_u values must lie in [0, 2]: {text!r}")
    return values


def int_at_least(lowest: int):
    """argparse type: an integer >= ``lowest`` with a one-line error otherwise."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if value < lowest:
            raise argparse.ArgumentTypeError(f"must be at least {lowest}, got {value}")
        return value

    return parse


_positive_int = int_at_least(1)


def _non_negative_float(text: str) -> float:
    """argparse type: a finite number >= 0 with a one-line error otherwise."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (value >= 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


def _positive_float(text: str) -> float:
    """argparse type: a finite number > 0 with a one-line error otherwise."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


AVOIDANCE_HELP = (
    "collision avoidance of a spatial scenario, overriding its [spatial] avoidance: orca "
    "(reciprocal avoidance, the default) or none (the proximity law alone; figures before "
    "avoidance)"
)


LOOK_AHEAD_HELP = (
    "robot-aware planning of a spatial scenario with avoidance on, overriding its [spatial] "
    "look_ahead: on (a robot whose way runs past a robot at work that would keep it waiting "
    "plans round it when it is given its task or that robot begins work; the default) or off"
)


def _avoidance_option(parser) -> None:
    """``--avoidance orca|none`` and ``--look-ahead off|on``: a spatial run with or without
    collision avoidance, and with or without planning round robots at work."""
    parser.add_argument("--avoidance", choices=AVOIDANCE, default=None, help=AVOIDANCE_HELP)
    parser.add_argument("--look-ahead", choices=LOOK_AHEAD, default=None, help=LOOK_AHEAD_HELP)


FAULT_WORDS = {
    "mttf": "faults.mttf_s",
    "repair": "faults.repair_s",
    "permanent": "faults.p_permanent",
    "policy": "faults.policy",
}


def fault_option(text: str) -> tuple[tuple[str, object], ...]:
    """``--faults mttf=600,repair=60,permanent=0.01,policy=requeue`` as scenario overrides."""
    out = []
    for part in text.split(","):
        key, eq, value = part.partition("=")
        key = key.strip()
        if not eq or key not in FAULT_WORDS:
            raise argparse.ArgumentTypeError(
                f"{part!r}: expected KEY=VALUE with KEY one of {', '.join(FAULT_WORDS)}"
            )
        if key == "policy":
            if value not in ("requeue", "drop"):
                raise argparse.ArgumentTypeError(
                    f"policy={value!r}: unknown policy; one of ['requeue', 'drop']"
                )
            out.append((FAULT_WORDS[key], value))
            continue
        try:
            number = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{key}={value!r}: not a number") from None
        if key == "mttf" and not number > 0:
            raise argparse.ArgumentTypeError(f"mttf={value}: must be > 0 (s)")
        if key == "repair" and not number >= 0:
            raise argparse.ArgumentTypeError(f"repair={value}: must be >= 0 (s)")
        if key == "permanent" and not 0 <= number <= 1:
            raise argparse.ArgumentTypeError(f"permanent={value}: probability outside [0, 1]")
        out.append((FAULT_WORDS[key], number))
    return tuple(out)


_non_negative_int = int_at_least(0)


def _version() -> str:
    from importlib import metadata

    try:
        return metadata.version("expt-mrta")
    except metadata.PackageNotFoundError:  # a source checkout that is not installed
        return "unknown"


def build_parser() -> argparse.ArgumentParser:
    from learning.registry import PAPER_ALLOCATORS, available

    p = _Parser(
        prog="mrta",
        description="Multi-robot task allocation: market auction, QL-MRTA and ExpT-MRTA "
        "(Ezercan Kayır) in an abstract cost world or a pymunk world.",
        epilog="Scenarios are bundled names (mrta validate --list) or TOML paths.",
    )
    p.add_argument("--version", action="version", version=f"mrta (expt-mrta) {_version()}")
    p.add_argument(
        "--debug",
        action="store_true",
        help="on an error, also print the traceback (a failing plug-in allocator, say)",
    )
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    v = sub.add_parser(
        "validate",
        help="check scenario (or sweep) files and print a short description",
        description="Check scenario files, or sweep files (a [sweep] table), without running "
        "anything: one line each, 'ok' with what the file holds, or the first problem found "
        "(exit 2).",
    )
    v.add_argument("files", nargs="*", help="scenario or sweep names, or TOML paths")
    v.add_argument("--list", action="store_true", help="list the bundled scenarios")

    r = sub.add_parser(
        "reproduce",
        help="the paper protocol for all allocators over seeds: metrics.json, figures, Table 2",
        description="Run market, QL-MRTA and ExpT-MRTA on the same seeded task streams "
        "(learning sets with exploration, then test sets greedily), plus a delta_u sweep "
        "for the trade-off plot, and write metrics.json, fig1_completion.png, fig2_r5.png, "
        "table2.md and tradeoff.png to --out.",
    )
    r.add_argument(
        "--scenario", default=None, help="default: paper (paper_spatial for --cost distance/time)"
    )
    r.add_argument(
        "--cost",
        choices=COSTS,
        default="abstract",
        help="bid cost model (spatial for distance/time)",
    )
    r.add_argument(
        "--seeds",
        type=_seed_list,
        default=None,
        help="a count N (seeds 0..N-1), a list '1,4,9' or a range '0-19' "
        "(default 10 with the abstract cost, 5 with distance/time)",
    )
    r.add_argument(
        "--tradeoff",
        type=_float_list,
        default=None,
        help="delta_u values for tradeoff.png, comma-separated, or 'none' (default "
        "0.02,0.03,0.05,0.08,0.1,0.2,0.3,0.5 abstract; 0.02,0.3 distance/time)",
    )
    r.add_argument(
        "--out", type=_out_path, default=None, help="output folder (default renders/<scenario>/)"
    )
    r.add_argument("--workers", type=_positive_int, default=None, help=WORKERS)
    r.add_argument("--robot", default="R5", help="robot whose experience fig2 shows (default R5)")
    r.add_argument(
        "--with",
        dest="with_allocators",
        type=_allocator_list,
        default=[],
        metavar="ALLOCATORS",
        help="more allocators beside market, ql and expt, comma-separated: greedy, cbba, an "
        "installed plug-in or module:Class (default none)",
    )
    _avoidance_option(r)
    r.add_argument("--no-progress", action="store_true", help=NO_PROGRESS)

    s = sub.add_parser("stream", help="write a seeded task stream to JSON or CSV for replay")
    s.add_argument("scenario", help=SCENARIO)
    s.add_argument("--seed", type=_non_negative_int, default=0, help="run seed")
    s.add_argument("--out", type=_out_path, required=True, help="FILE.json or FILE.csv")

    run = sub.add_parser(
        "run",
        help="one allocator, one cost model, one seed: metrics.json and run_manifest.json",
        description="Play the paper protocol once. Writes metrics.json and run_manifest.json to "
        "--out; with --checkpoint also checkpoint.npz after every task set, which --resume "
        "continues from (the result equals an uninterrupted run). --replay repeats the run a "
        "manifest describes and must give an identical metrics.json. A spatial scenario also "
        "gives tasks.csv (one row per test-set task), spatial.png, and where driving robots "
        "stood still: stalls.png (a map per cause) and stalls.npz (robot-seconds by cause and "
        "cell; np.load(..., allow_pickle=False)).",
    )
    run.add_argument("scenario", nargs="?", help="scenario name or TOML path (not with --replay)")
    run.add_argument(
        "--replay",
        type=Path,
        default=None,
        metavar="MANIFEST",
        help="repeat the run recorded in a run_manifest.json",
    )
    run.add_argument(
        "--checkpoint",
        action="store_true",
        help="write OUT/checkpoint.npz after every task set (atomically): learned state, the "
        "record so far, generator states and the world (clock; in the pymunk world also poses, "
        "velocities, task bookkeeping and contact counts)",
    )
    run.add_argument(
        "--resume",
        action="store_true",
        help="continue from OUT/checkpoint.npz; the metrics.json and tasks.csv equal those of "
        "a run straight through",
    )
    run.add_argument(
        "--allocator",
        type=_allocator_name,
        default="expt",
        help=f"{', '.join(available())}, or module:Class of your own (default expt)",
    )
    run.add_argument("--cost", choices=COSTS, default="abstract", help="bid cost model")
    run.add_argument("--seed", type=_non_negative_int, default=0, help="run seed")
    run.add_argument("--stream", type=Path, default=None, help="replay a stream file (mrta stream)")
    run.add_argument(
        "--out", type=_out_path, default=None, help="output folder (default renders/run/)"
    )
    _avoidance_option(run)
    run.add_argument("--no-progress", action="store_true", help=NO_PROGRESS)
    c = sub.add_parser(
        "compare",
        help="cost models x allocators side by side (spatial scenarios): table and plot",
        description="Run every allocator under every cost model on the same seeded streams and "
        "write compare.json, compare.md and compare.png (completion per priority, distance "
        "driven, waiting of high-priority tasks, learning space; 95% CI over seeds).",
    )
    c.add_argument("scenario", help=SCENARIO)
    c.add_argument(
        "--costs",
        type=_name_list(set(COSTS)),
        default=list(COSTS),
        help="comma-separated cost models (default abstract,distance,time)",
    )
    c.add_argument(
        "--allocators",
        type=_allocator_list,
        default=list(PAPER_ALLOCATORS),
        help="comma-separated allocators: market, ql, expt, greedy, cbba, installed plug-ins "
        "or module:Class (default market,ql,expt)",
    )
    c.add_argument(
        "--seeds",
        type=_seed_list,
        default=_seed_list("5"),
        help="a count N (seeds 0..N-1), a list '1,4,9' or a range '0-19' (default 5; fewer than "
        "5 make the 95%% intervals unreliable)",
    )
    c.add_argument(
        "--out",
        type=_out_path,
        default=None,
        help="output folder (default renders/compare/<scenario>)",
    )
    c.add_argument("--workers", type=_positive_int, default=None, help=WORKERS)
    _avoidance_option(c)
    c.add_argument("--no-progress", action="store_true", help=NO_PROGRESS)

    g = sub.add_parser(
        "render",
        help="run a spatial scenario and write a trajectory GIF (headless)",
        description="Play the protocol (its first --sets task sets) in a spatial world, record "
        "robot poses and task events, and draw frames between --from and --to simulated seconds "
        "into a GIF (and an MP4 with --mp4 where ffmpeg exists). No display needed.",
    )
    g.add_argument("scenario", help="spatial scenario name or TOML path")
    g.add_argument(
        "--allocator", type=_allocator_name, default="expt", help="as for mrta run (default expt)"
    )
    g.add_argument("--cost", choices=COSTS, default="distance", help="bid cost model")
    g.add_argument("--seed", type=_non_negative_int, default=0, help="run seed")
    g.add_argument("--sets", type=_positive_int, default=2, help="task sets to play (default 2)")
    _avoidance_option(g)
    g.add_argument("--gif", type=_out_path, required=True, help="output GIF path")
    g.add_argument("--mp4", type=_out_path, default=None, help="also write an MP4 (needs ffmpeg)")
    _gif_options(g, frames=200, fps=20, width=600)
    g.add_argument(
        "--from",
        dest="t_from",
        type=_non_negative_float,
        default=0.0,
        help="start, simulated s (default 0)",
    )
    g.add_argument(
        "--to",
        dest="t_to",
        type=_positive_float,
        default=None,
        help="end, simulated s (default: --from + 180 or the end of the run)",
    )
    g.add_argument(
        "--trail",
        type=_non_negative_float,
        default=10.0,
        help="trail length, simulated s (default 10)",
    )
    g.add_argument(
        "--trajectory", type=_out_path, default=None, help="also save the recording (.npz)"
    )
    g.add_argument("--no-progress", action="store_true", help=NO_PROGRESS)

    b = sub.add_parser(
        "bench",
        help="speed and memory: simulation loop, GIF rendering, allocation, as ratios in one run",
        description="Measure, in this process: the spatial loop at 10, 100 and 1000 robots in "
        "the units users pay (real-time factor, wall seconds per simulated robot-hour, the price "
        "of collision avoidance as wall time with over without, with the traffic rules and with "
        "ORCA alone (with --split also split into the control period, the traffic rules, "
        "look-ahead and the jam rules, site work, the physics steps and the rest), and the loop "
        "per physics step in steps of a fixed calibration space (with --split also the control "
        "period's and the physics steps' share of it)); our GIF writer against FuncAnimation + "
        "PillowWriter; allocation time per round against team size. --json prints one JSON "
        "object. Compare the ratios, not absolute times: machines are shared and noisy.",
    )
    b.add_argument("--json", action="store_true", help="print one JSON object")
    b.add_argument(
        "--only",
        type=_name_list({"sim", "gif", "alloc", "maps"}),
        default=["sim", "gif", "alloc", "maps"],
        help="comma-separated parts (default sim,gif,alloc,maps)",
    )
    b.add_argument(
        "--repeat",
        type=_positive_int,
        default=1,
        help="rounds of the sim part; in each, an arena's three loops (without avoidance, "
        "ORCA with the rules, ORCA alone) run side by side in turns of 20 ms, so a slow spell "
        "of the machine falls on all three; every figure is its loop's quickest round's, every "
        "price the median round's, with the price of each round beside it: use 3 or more to "
        "compare two commits (default 1)",
    )
    b.add_argument(
        "--split",
        action="store_true",
        help="one round of the sim part more, with timers round the parts of the control "
        "period and round the physics steps, to split the price of avoidance into them (the "
        "timers slow the loop with avoidance, so the price itself comes from the untimed "
        "rounds)",
    )
    h = sub.add_parser(
        "hardcase",
        help="a classic hard case of robot motion (circle swap, junction, ...): times, contacts",
        description="Run one classic hard case of multi-robot motion in the pymunk world "
        "(robots of radius 0.25 m at 1 m/s, each sent straight to a goal of its own): circle "
        "(n robots on a 5 m circle swap to antipodal points; IR-SIM 2.12's RVO example: 10 "
        "robots in 17.8 s, 20 in 23.1 s), junction (4 robots cross), corridor (2 robots swap "
        "ends of a 0.75 m corridor), parked (a robot passes n - 1 parked robots), site (n "
        "robots sent to one site, 2 s of work each). Prints the time until every robot arrived, "
        "the contacts begun (touch or impact) and the closest two centres came; with --jitter "
        "and --seeds, the same for starts moved by a hair, run by run, and a summary. "
        "Example: mrta hardcase circle --jitter 1e-4 --seeds 10",
    )
    h.add_argument("case", help="circle, junction, corridor, parked or site")
    h.add_argument(
        "--robots",
        type=_positive_int,
        default=None,
        help="robots (default: circle 20, junction 4, corridor 2, parked 11, site 30)",
    )
    h.add_argument(
        "--avoidance", choices=("orca", "none"), default="orca", help="[spatial] avoidance"
    )
    h.add_argument(
        "--look-ahead",
        choices=("off", "on"),
        default=LOOK_AHEAD_DEFAULT,
        help="[spatial] look_ahead: plan round robots at work in the way "
        f"(default {LOOK_AHEAD_DEFAULT})",
    )
    h.add_argument(
        "--control",
        choices=("auto", "compiled", "array", "scalar"),
        default="auto",
        help="control period: the compiled kernel (auto, compiled), or its numpy references:"
        " all robots at once (array) or robot by robot (scalar)",
    )
    h.add_argument(
        "--limit-s",
        type=_positive_float,
        default=None,
        help="give up after this much simulated time, s (default: the case's, 60-300 s)",
    )
    h.add_argument(
        "--jitter",
        type=_non_negative_float,
        default=0.0,
        metavar="M",
        help="move every start by a normal draw of this standard deviation, m (default 0: the "
        "exact geometry); the crowd cases are chaotic, so a result should hold for any start "
        "within a hair of it",
    )
    h.add_argument(
        "--seeds",
        type=_positive_int,
        default=1,
        help="with --jitter, run seeds 1..N (one draw of the starts each) and summarise: runs "
        "with a contact, times (default 1)",
    )
    h.add_argument("--gif", type=_out_path, default=None, help="also write an animated GIF here")
    _gif_options(h, frames=150, fps=15, width=480)
    h.add_argument("--json", action="store_true", help="print one JSON object")
    h.add_argument("--no-progress", action="store_true", help=NO_PROGRESS)

    k = sub.add_parser(
        "soak",
        help="a long spatial run: memory, overlaps, stuck robots and invariants over 100k tasks",
        description="Play a spatial scenario until --tasks tasks were announced, keeping counts "
        "only, and report peak RSS at 10% and 100% of the run, the deepest overlap, failed "
        "tasks and wall time. Invariants are checked every round; a violation stops it (exit 1).",
    )
    k.add_argument(
        "--scenario", default="large", help="spatial scenario (default large: 100 robots)"
    )
    k.add_argument(
        "--tasks", type=_positive_int, default=100_000, help="tasks to announce (default 100000)"
    )
    k.add_argument("--allocator", type=_allocator_name, default="market", help="(default market)")
    k.add_argument("--cost", choices=COSTS, default="distance", help="bid cost model")
    k.add_argument("--seed", type=_non_negative_int, default=0, help="run seed")
    k.add_argument(
        "--faults",
        type=fault_option,
        default=(),
        metavar="KEY=VALUE,...",
        help="robot faults on top of the scenario's [faults] table: mttf=S (mean time to "
        "failure per robot, s), repair=S (repair time, s), permanent=P (share of failures "
        "for good), policy=requeue|drop (the broken robot's task); e.g. mttf=600,repair=60",
    )
    _avoidance_option(k)
    k.add_argument("--json", action="store_true", help="print one JSON object")
    k.add_argument("--no-progress", action="store_true", help=NO_PROGRESS)

    add_sweep_parser(sub)
    add_study_parser(sub)
    add_map_sites_parser(sub)
    return p


def add_map_sites_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``mrta map-sites MAP.yaml --types N --per-type K [--robots M] [--seed S]``."""
    p = subparsers.add_parser(
        "map-sites",
        help="task sites (and robot starts) on a ROS map's free floor, as a scenario block",
        description="Draw task sites on the free floor of a ROS map_server map (YAML + PGM/PNG) "
        "where a robot centre has --clearance metres of room, all in the largest connected "
        "region of such floor and at least --gap apart, and print them as a [spatial.sites] "
        "block in the map's frame (metres, as RViz shows them) to paste into a scenario; with "
        "--robots also start points for that many robots. Seeded: the same seed gives the "
        "same places.",
    )
    p.add_argument("map", type=Path, help="the map's YAML file")
    p.add_argument(
        "--types", type=_positive_int, default=None, help="task types T1..TN (or --names)"
    )
    p.add_argument("--names", type=_names, default=None, help="task type names, comma-separated")
    p.add_argument("--per-type", type=_positive_int, default=3, help="sites per task type")
    p.add_argument("--robots", type=_non_negative_int, default=0, help="robot starts to draw too")
    p.add_argument(
        "--clearance",
        type=_positive_float,
        default=0.45,
        help="room a place needs to every wall and obstacle, m (default 0.45: a 0.25 m robot "
        "with 0.1 m clearance and 0.1 m to spare)",
    )
    p.add_argument("--gap", type=_non_negative_float, default=1.0, help="least distance apart, m")
    p.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the draw")
    return p


def _names(text: str) -> list[str]:
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names or len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"task type names, distinct and comma-separated: {text!r}")
    return names


def add_sweep_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``mrta sweep SPEC.toml [--out DIR] [--against RUNS_CSV] [--workers N]
    [--scheduler ADDRESS]``."""
    p = subparsers.add_parser(
        "sweep",
        help="run a parameter sweep file: runs.csv, summary.csv/json, sensitivity plots",
        description="Run every combination of scenarios x allocators x cost models x parameter "
        "values x seeds named in a sweep TOML file, on local processes or a Dask cluster. "
        "Re-running into the same --out folder skips the runs already in runs.csv.",
    )
    p.add_argument("spec", help="sweep TOML file, or a bundled sweep name (e.g. delta_u)")
    p.add_argument(
        "--out", type=_out_path, default=None, help="output folder (default renders/sweeps/<name>/)"
    )
    p.add_argument(
        "--against",
        type=Path,
        default=None,
        metavar="RUNS_CSV",
        help="an earlier runs.csv of this sweep (another commit, another machine): after the "
        "sweep, write against.md and against.json, every group paired by seed with the old "
        "file's (mean per-seed change and its standard error); checked before anything runs",
    )
    add_runner_options(p)
    return p


def add_runner_options(p: argparse.ArgumentParser) -> None:
    """--workers, --scheduler and --no-progress of the commands that run sweeps."""
    p.add_argument(
        "--workers", type=int_at_least(1), default=None, help="local processes (default: all cores)"
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on a running Dask scheduler, e.g. tcp://10.0.0.5:8786 (needs expt-mrta[cluster])",
    )
    p.add_argument("--no-progress", action="store_true", help=NO_PROGRESS)


def add_study_parser(subparsers) -> argparse.ArgumentParser:
    """Add ``mrta study refusal [--out DIR] [--workers N] [--scheduler ADDRESS]``."""
    from scenarios.sweep.study import STUDIES

    p = subparsers.add_parser(
        "study",
        help="a bundled study (several sweeps read together): refusal, faults",
        description="refusal: where ExpT-MRTA's refusals cost completion and what the reserve "
        "rule wins back. Runs the bundled sweeps refusal_load (abstract paper scenario, offered "
        "load 0.45-2.4 and no overload), refusal_frontier (space against completion over delta_u "
        "x coverage_k) and refusal_spatial (paper_spatial, abstract and distance bids), 10 seeds "
        "each, into OUT/<sweep>/ (resumable: re-run to finish an interrupted study), then writes "
        "OUT/study.json, study.md, load.png, losses.png, frontier.png and spatial.png. About 5-10 "
        "minutes on two cores. faults: completion of market, QL-MRTA, ExpT-MRTA, greedy and "
        "CBBA against the robots' mean time to failure (the bundled sweep faults, abstract paper "
        "scenario, 5 seeds, MTTF inf = no faults as the reference) into OUT/faults/, then "
        "OUT/study.json, study.md and faults.png.",
    )
    p.add_argument("name", choices=sorted(STUDIES), help="which study (refusal, faults)")
    p.add_argument(
        "--out", type=_out_path, default=None, help="output folder (default renders/study/<name>/)"
    )
    p.add_argument(
        "--only",
        default=None,
        metavar="PARTS",
        help="comma-separated subset of the parts, e.g. refusal_load,refusal_frontier "
        "(default: all three)",
    )
    add_runner_options(p)
    return p


def _gif_options(p: argparse.ArgumentParser, frames: int, fps: int, width: int) -> None:
    """--frames, --fps and --size of a command that writes a GIF, with these defaults."""
    p.add_argument("--frames", type=_positive_int, default=frames, help="frames in the GIF")
    p.add_argument("--fps", type=_positive_int, default=fps, help="frames per second of playback")
    p.add_argument(
        "--size",
        type=_size,
        default=(width, None),
        help="W or WxH pixels; W alone fits the height to the arena, so no band stays empty "
        f"(default {width})",
    )


def _allocator_name(text: str) -> str:
    """An allocator name that resolves (built-in, plug-in or module:Class), else a usage error."""
    from learning.registry import AllocatorError, allocator_class

    try:
        allocator_class(text)
    except AllocatorError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def _allocator_list(text: str) -> list[str]:
    names = [t.strip() for t in text.split(",") if t.strip()]
    if not names:
        raise argparse.ArgumentTypeError("give at least one allocator")
    if len(set(names)) != len(names):
        raise argparse.ArgumentTypeError(f"an allocator is named twice in {text!r}")
    return [_allocator_name(n) for n in names]


def _name_list(allowed: set[str]):
    def parse(text: str) -> list[str]:
        names = [x.strip() for x in text.split(",") if x.strip()]
        bad = [x for x in names if x not in allowed]
        if bad or not names:
            raise argparse.ArgumentTypeError(
                f"unknown {', '.join(bad) or 'empty list'}; "
                f"choose from {', '.join(sorted(allowed))}"
            )
        return list(dict.fromkeys(names))

    return parse


def _size(text: str) -> tuple[int, int | None]:
    """'600x480' -> (600, 480); '600' -> (600, None): the height is fitted to the arena."""
    try:
        parts = [int(x) for x in text.lower().split("x")]
    except ValueError:
        parts = []
    if len(parts) not in (1, 2):
        raise argparse.ArgumentTypeError(
            f"size must be W or WxH, e.g. 600 or 600x600, got {text!r}"
        )
    w, h = parts[0], parts[1] if len(parts) == 2 else None
    if not (64 <= w <= 4096 and (h is None or 64 <= h <= 4096)):
        raise argparse.ArgumentTypeError(f"size {text} outside 64..4096 pixels per side")
    return w, h


def parse_command(argv: Sequence[str]) -> argparse.Namespace:
    """Parse ``mrta`` arguments (``argv`` without the ``mrta``) as the command line does, for
    code that holds command lines (the curated samples' table, the docs' checks): a usage
    error or ``--help`` raises ValueError with argparse's message instead of exiting."""
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            return build_parser().parse_args(list(argv))
    except SystemExit as exc:
        message = err.getvalue().strip() or f"mrta {' '.join(argv)}: exit {exc.code}, no command"
        raise ValueError(message) from None
