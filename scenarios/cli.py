"""The ``mrta`` command line.

Every bad input (a malformed scenario, an unknown key, a missing file, a negative count) ends
with one line ``mrta: error: <what and where>`` on stderr and exit code 2, never a traceback.
Ctrl-C stops cleanly with exit code 130 and says what was kept.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

EXIT_USAGE = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2 (argparse prints usage too; keep it short)
        self.exit(
            EXIT_USAGE, f"mrta: error: {message} (see 'mrta {self.prog.split()[-1]} --help')\n"
        )


def _seed_list(text: str) -> list[int]:
    """'10' -> seeds 0..9; '3,5,8' -> those seeds; '2-6' -> 2..6."""
    try:
        if "," in text:
            seeds = [int(s) for s in text.split(",") if s.strip()]
        elif "-" in text.strip("-"):
            a, b = text.split("-", 1)
            seeds = list(range(int(a), int(b) + 1))
        else:
            n = int(text)
            if n < 1:
                raise argparse.ArgumentTypeError(f"need at least one seed, got {n}")
            seeds = list(range(n))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a seed count or list: {text!r}") from None
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"seeds must be non-negative integers: {text!r}")
    return seeds


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _non_negative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    from learning import ALLOCATORS

    p = _Parser(
        prog="mrta",
        description="Multi-robot task allocation: market auction, QL-MRTA and ExpT-MRTA "
        "(Ezercan Kayır) in an abstract cost world or a pymunk world.",
        epilog="Scenarios are bundled names (mrta validate --list) or TOML paths.",
    )
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    v = sub.add_parser("validate", help="check scenario files and print a short description")
    v.add_argument("files", nargs="*", help="scenario names or TOML paths")
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
    r.add_argument("--cost", choices=["abstract", "distance", "time"], default="abstract")
    r.add_argument(
        "--seeds",
        type=_seed_list,
        default=_seed_list("10"),
        help="a count N (seeds 0..N-1), a list '1,4,9' or a range '0-19' (default 10)",
    )
    r.add_argument(
        "--out", type=Path, default=None, help="output folder (default renders/<scenario>/)"
    )
    r.add_argument(
        "--workers", type=_positive_int, default=None, help="processes (default: all cores)"
    )
    r.add_argument("--robot", default="R5", help="robot whose experience fig2 shows (default R5)")
    r.add_argument("--no-progress", action="store_true", help="hide the progress bar")

    s = sub.add_parser("stream", help="write a seeded task stream to JSON or CSV for replay")
    s.add_argument("scenario")
    s.add_argument("--seed", type=_non_negative_int, default=0)
    s.add_argument("--out", type=Path, required=True, help="FILE.json or FILE.csv")

    run = sub.add_parser(
        "run",
        help="one allocator, one cost model, one seed: metrics.json and run_manifest.json",
        description="Play the paper protocol once. Writes metrics.json and run_manifest.json to "
        "--out; with --checkpoint also checkpoint.npz after every task set, which --resume "
        "continues from (the result equals an uninterrupted run). --replay repeats the run a "
        "manifest describes and must give an identical metrics.json.",
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
        "--checkpoint", action="store_true", help="write OUT/checkpoint.npz after every set"
    )
    run.add_argument("--resume", action="store_true", help="continue from OUT/checkpoint.npz")
    run.add_argument("--allocator", choices=sorted(ALLOCATORS), default="expt")
    run.add_argument("--cost", choices=["abstract", "distance", "time"], default="abstract")
    run.add_argument("--seed", type=_non_negative_int, default=0)
    run.add_argument("--stream", type=Path, default=None, help="replay a stream file (mrta stream)")
    run.add_argument("--out", type=Path, default=None, help="output folder (default renders/run/)")
    return p


def cmd_validate(args) -> int:
    from scenarios.loader import bundled_names, load_scenario

    if args.list or not args.files:
        for name in bundled_names():
            print(name)
        return 0
    for f in args.files:
        sc = load_scenario(f)
        spatial = "spatial" if sc.spatial else "abstract"
        print(
            f"{sc.source}: ok: {sc.name!r}, {sc.n_robots} robots, {sc.n_types} task types, "
            f"{sc.stream.n_sets} sets x {sc.stream.rounds_per_set} rounds, {spatial}"
        )
    return 0


def cmd_reproduce(args) -> int:
    from scenarios.reproduce import reproduce, summary_table

    scenario = args.scenario or ("paper" if args.cost == "abstract" else "paper_spatial")
    out = args.out or Path("renders") / Path(scenario).stem
    t0 = time.perf_counter()
    metrics = reproduce(
        scenario,
        args.seeds,
        out,
        cost=args.cost,
        workers=args.workers,
        trace_robot=args.robot,
        progress=not args.no_progress,
    )
    print(
        f"{metrics['scenario']} ({metrics['cost_model']} cost), test-set completion, "
        f"mean ± 95% CI over {len(args.seeds)} seeds:"
    )
    print(summary_table(metrics))
    print(
        f"wrote {out}/metrics.json, fig1_completion.png, fig2_r5.png, table2.md, tradeoff.png "
        f"in {time.perf_counter() - t0:.1f} s"
    )
    return 0


def cmd_stream(args) -> int:
    import numpy as np

    from scenarios.protocol import _load
    from sim.tasks import generate_stream, save_stream

    sc = _load(args.scenario)
    stream_ss = np.random.SeedSequence(args.seed).spawn(3)[0]
    stream = generate_stream(sc, np.random.default_rng(stream_ss))
    if not args.out.parent.is_dir():
        raise FileNotFoundError(f"{args.out.parent}: output folder does not exist")
    save_stream(stream, args.out)
    print(f"wrote {len(stream)} tasks ({stream.n_sets} sets) to {args.out}")
    return 0


def cmd_run(args) -> int:
    from scenarios.manifest import build_manifest, read_manifest, write_manifest
    from scenarios.metrics import aggregate
    from scenarios.protocol import RunSpec, UserError, _load, execute, write_json_atomic

    out = args.out or Path("renders") / "run"
    if args.replay is not None:
        if args.scenario:
            raise UserError("give either a scenario or --replay MANIFEST, not both")
        out = args.out or args.replay.parent / "replay"
        _, specs = read_manifest(args.replay, scratch=out)
        spec = specs[0]
    elif not args.scenario:
        raise UserError("run needs a SCENARIO (or --replay MANIFEST)")
    else:
        spec = RunSpec(
            str(args.scenario),
            args.allocator,
            args.cost,
            args.seed,
            stream_file=str(args.stream) if args.stream else "",
        )
    checkpoint = out / "checkpoint.npz" if (args.checkpoint or args.resume) else None
    if args.resume and not checkpoint.is_file():
        raise UserError(f"{checkpoint}: no checkpoint to resume from (run with --checkpoint first)")
    scenario = _load(spec.scenario)
    out.mkdir(parents=True, exist_ok=True)
    write_manifest(out, build_manifest(scenario, [spec]))
    summary = execute(spec, checkpoint=checkpoint, resume=args.resume)
    metrics = {
        "scenario": scenario.name,
        "cost_model": spec.cost,
        "seeds": [spec.seed],
        "allocators": {spec.allocator: aggregate([summary])},
    }
    write_json_atomic(out / "metrics.json", metrics)
    comp = summary["completion"]["overall"]
    print(
        f"{spec.allocator} on {scenario.name} ({spec.cost} cost, seed {spec.seed}): completion "
        f"low {comp['low']:.3f} high {comp['high']:.3f} all {comp['all']:.3f}; "
        f"wrote {out}/metrics.json"
    )
    return 0


COMMANDS = {
    "validate": cmd_validate,
    "reproduce": cmd_reproduce,
    "stream": cmd_stream,
    "run": cmd_run,
}


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mrta`` console script."""
    from learning.checkpoint import CheckpointError
    from learning.episode import InvariantError
    from scenarios.loader import ScenarioError
    from scenarios.protocol import UserError
    from sim.tasks import StreamFileError

    args = build_parser().parse_args(argv)
    try:
        return COMMANDS[args.command](args)
    except (ScenarioError, StreamFileError, UserError) as exc:
        print(f"mrta: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except FileNotFoundError as exc:
        print(f"mrta: error: {exc.filename or exc}: file or folder not found", file=sys.stderr)
        return EXIT_USAGE
    except CheckpointError as exc:
        print(f"mrta: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except InvariantError as exc:
        print(f"mrta: invariant violated: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(
            "mrta: interrupted; completed outputs were kept, nothing was half-written",
            file=sys.stderr,
        )
        return 130


if __name__ == "__main__":
    sys.exit(main())
