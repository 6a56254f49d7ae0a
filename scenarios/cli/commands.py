"""The ``mrta`` subcommands: each reads its parsed arguments, runs and prints what it wrote.

Heavy modules are imported inside each command, so ``mrta --help`` and ``mrta validate`` start
fast. ``COMMANDS`` maps a subcommand name to its function (:mod:`scenarios.cli.app` calls it).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

MIN_SEEDS = 5


def avoidance_overrides(args) -> tuple[tuple[str, str], ...]:
    """The scenario overrides ``--avoidance`` and ``--look-ahead`` ask for (none when not
    given)."""
    out = () if args.avoidance is None else (("spatial.avoidance", args.avoidance),)
    return out + (() if args.look_ahead is None else (("spatial.look_ahead", args.look_ahead),))


def warn_few_seeds(seeds: list[int]) -> None:
    """One line on stderr when a confidence interval rests on fewer than MIN_SEEDS seeds."""
    if len(seeds) < MIN_SEEDS:
        print(
            f"mrta: warning: {len(seeds)} seed(s): 95% intervals from fewer than {MIN_SEEDS} "
            "seeds are unreliable (or null for one seed)",
            file=sys.stderr,
        )


def _is_sweep(name_or_path: str) -> bool:
    """A sweep file (a top-level ``[sweep]`` table and no ``[scenario]``), or the name of a
    bundled sweep that is not a bundled scenario's."""
    from scenarios.loader import locate, read_toml

    path = locate(name_or_path)
    if path is not None and path.is_file():
        doc, _ = read_toml(path)
        return "sweep" in doc and "scenario" not in doc
    return path is None and locate(name_or_path, "sweeps") is not None


def cmd_validate(args) -> int:
    from scenarios.loader import bundled_names, load_scenario
    from scenarios.sweep.spec import load_sweep

    if args.list or not args.files:
        for name in bundled_names():
            print(name)
        return 0
    for f in args.files:
        if _is_sweep(f):
            sw = load_sweep(f)
            print(
                f"{sw.source}: ok: sweep {sw.name!r}, {len(sw.runs)} runs "
                f"({len(sw.runs) // len(sw.seeds)} combinations x {len(sw.seeds)} seeds)"
            )
            continue
        sc = load_scenario(f)
        spatial = "spatial" if sc.spatial else "abstract"
        print(
            f"{sc.source}: ok: {sc.name!r}, {sc.n_robots} robots, {sc.n_types} task types, "
            f"{sc.stream.n_sets} sets x {sc.stream.rounds_per_set} rounds, {spatial}"
        )
    return 0


def cmd_reproduce(args) -> int:
    from scenarios.experiments.reproduce import (
        DEFAULT_DELTA_U_GRID,
        SPATIAL_DELTA_U_GRID,
        reproduce,
        summary_table,
    )

    spatial = args.cost != "abstract"
    scenario = args.scenario or ("paper_spatial" if spatial else "paper")
    seeds = args.seeds or list(range(5 if spatial else 10))
    warn_few_seeds(seeds)
    grid = (
        args.tradeoff
        if args.tradeoff is not None
        else (SPATIAL_DELTA_U_GRID if spatial else DEFAULT_DELTA_U_GRID)
    )
    out = args.out or Path("renders") / (
        Path(scenario).stem + ("" if not spatial else f"_{args.cost}")
    )
    t0 = time.perf_counter()
    metrics = reproduce(
        scenario,
        seeds,
        out,
        cost=args.cost,
        workers=args.workers,
        delta_u_grid=grid,
        trace_robot=args.robot,
        progress=not args.no_progress,
        extra_allocators=tuple(args.with_allocators),
        overrides=avoidance_overrides(args),
    )
    print(
        f"{metrics['scenario']} ({metrics['cost_model']} cost), test-set completion, "
        f"mean ± 95% CI over {len(seeds)} seeds:"
    )
    print(summary_table(metrics))
    files = "metrics.json, fig1_completion.png, fig2_r5.png, table2.md" + (
        ", tradeoff.png" if grid else ""
    )
    print(f"wrote {out}/{{{files}}} in {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_stream(args) -> int:
    from learning.seeding import run_generators
    from scenarios.experiments.outdir import check_out_file
    from scenarios.experiments.protocol import load_named
    from sim.tasks import generate_stream, save_stream

    out = check_out_file(args.out, "--out")
    sc = load_named(args.scenario)
    stream = generate_stream(sc, run_generators(args.seed).stream)
    save_stream(stream, out)
    print(f"wrote {len(stream)} tasks ({stream.n_sets} sets) to {args.out}")
    return 0


def cmd_run(args) -> int:
    from scenarios.experiments.manifest import numerics_note, read_manifest
    from scenarios.experiments.outdir import check_out_dir, staging_dir
    from scenarios.experiments.protocol import RunSpec, UserError
    from scenarios.experiments.run_files import write_run

    out = check_out_dir(args.out if args.out is not None else Path("renders") / "run")
    if args.replay is not None:
        if args.scenario:
            raise UserError("give either a scenario or --replay MANIFEST, not both")
        out = check_out_dir(args.out or args.replay.parent / "replay")
        doc, specs = read_manifest(args.replay, scratch=staging_dir(out).with_suffix(".replay"))
        note = numerics_note(doc)
        if note:
            print(f"mrta: note: {args.replay}: {note}", file=sys.stderr)
        spec = specs[0]
    elif not args.scenario:
        raise UserError("run needs a SCENARIO (or --replay MANIFEST)")
    else:
        spec = RunSpec(
            str(args.scenario),
            args.allocator,
            args.cost,
            args.seed,
            avoidance_overrides(args),
            stream_file=str(args.stream) if args.stream else "",
        )
    done = write_run(
        spec,
        out,
        checkpoint=args.checkpoint or args.resume,
        resume=args.resume,
        progress=not args.no_progress,
    )
    comp = done.summary["completion"]["overall"]
    print(
        f"{spec.allocator} on {done.metrics['scenario']} ({spec.cost} cost, seed {spec.seed}): "
        f"completion low {comp['low']:.3f} high {comp['high']:.3f} all {comp['all']:.3f}; "
        f"wrote {out}/metrics.json"
    )
    if "spatial" in done.summary:
        from scenarios.experiments.figures import contact_line, stall_line
        from scenarios.experiments.protocol import load_named
        from sim.scenario.overrides import apply_overrides

        sp = apply_overrides(load_named(spec.scenario), spec.overrides).spatial
        print(contact_line(done.summary["spatial"], contacts=sp.contacts).replace("\n", "; "))
        print(stall_line(done.summary["spatial"], sp.stalls))
        if done.stall_places:
            print(done.stall_places + f" (map: {out}/stalls.png, stalls.npz)")
    return 0


def cmd_compare(args) -> int:
    from scenarios.experiments.compare import compare, markdown_table

    warn_few_seeds(args.seeds)
    out = args.out or Path("renders") / "compare" / Path(args.scenario).stem
    doc = compare(
        args.scenario,
        args.costs,
        args.allocators,
        args.seeds,
        out,
        workers=args.workers,
        progress=not args.no_progress,
        overrides=avoidance_overrides(args),
    )
    print(f"{doc['scenario']}: mean ± 95% CI over {len(args.seeds)} seeds (test sets)")
    print(markdown_table(doc))
    print(f"wrote {out}/compare.json, compare.md, compare.png")
    return 0


def cmd_render(args) -> int:
    from scenarios.experiments.protocol import RunSpec, UserError, load_named
    from scenarios.experiments.run_files import render_run

    sc = load_named(args.scenario)
    if sc.spatial is None:
        raise UserError(
            f"{args.scenario}: render needs a spatial scenario (one with a [spatial] table)"
        )
    if args.sets > sc.stream.n_sets:
        raise UserError(f"--sets {args.sets}: {sc.name!r} has {sc.stream.n_sets} task sets")
    sets = args.sets
    overrides = (("stream.n_sets", sets), ("stream.learn_sets", sets), ("stream.test_sets", sets))
    overrides += avoidance_overrides(args)
    spec = RunSpec(args.scenario, args.allocator, args.cost, args.seed, overrides)
    done = render_run(
        spec,
        args.gif,
        frames=args.frames,
        fps=args.fps,
        size=tuple(args.size),
        t_from=args.t_from,
        t_to=args.t_to,
        trail_s=args.trail,
        mp4=args.mp4,
        trajectory=args.trajectory,
        progress=not args.no_progress,
    )
    w, h = done.size
    print(
        f"wrote {args.gif} ({args.frames} frames of {w}x{h} px, "
        f"{done.t_from:.0f}-{done.t_to:.0f} s of {done.end_s:.0f} s)"
    )
    return 0


def cmd_hardcase(args) -> int:
    import json

    from scenarios.experiments.hardcases import CASES, run_case
    from scenarios.experiments.protocol import UserError
    from scenarios.loader import did_you_mean
    from sim.render import render_gif
    from sim.render.style import fitted_height

    if args.case not in CASES:
        hint = did_you_mean(args.case, CASES)
        raise UserError(f"hard case {args.case!r} unknown{hint}; choose from {', '.join(CASES)}")
    if args.gif is not None:
        from scenarios.experiments.outdir import check_out_file

        check_out_file(args.gif, "--gif")
    if not 1 <= args.fps <= 50:
        raise UserError(f"--fps {args.fps}: a GIF plays 1 to 50 frames per second")
    if args.seeds > 1 and args.jitter == 0.0:
        raise UserError(f"--seeds {args.seeds} without --jitter would repeat one run")
    if args.seeds > 1 and args.gif is not None:
        raise UserError("--gif draws one run: use it without --seeds")
    case = CASES[args.case]
    limit = case.limit_s if args.limit_s is None else args.limit_s
    from scenarios.experiments.progress import progress_bar

    seeds = [0] if args.jitter == 0.0 else list(range(1, args.seeds + 1))
    ticks = max(1, round(limit / 0.1))
    runs = []
    with progress_bar(
        ticks * len(seeds), f"hardcase: {args.case}", "tick", not args.no_progress
    ) as bar:
        for seed in seeds:
            try:
                out = run_case(
                    args.case,
                    args.robots,
                    args.control,
                    args.avoidance,
                    args.limit_s,
                    recorder=args.gif is not None,
                    on_tick=lambda _w: bar.update(),
                    jitter_m=args.jitter,
                    seed=seed,
                    look_ahead=args.look_ahead,
                )
            except ValueError as exc:
                raise UserError(str(exc)) from None
            runs.append(out)
    out = runs[0]
    traj = out.pop("trajectory", None)
    if traj is not None:
        width, height = args.size
        size = (width, height if height is not None else fitted_height(width, traj.arena_wh))
        with progress_bar(args.frames, "hardcase: draw", "frame", not args.no_progress) as bar:
            render_gif(
                traj, args.gif, frames=args.frames, fps=args.fps, size=size, trail_s=5.0,
                on_frame=bar.update,
            )  # fmt: skip
        out["gif"] = str(args.gif)
    clean = [{k: (None if v == float("inf") else v) for k, v in r.items()} for r in runs]
    if args.json:
        doc = clean[0] if args.jitter == 0.0 else {"runs": clean, **hardcase_summary(runs)}
        print(json.dumps(doc))
        return 0
    for r in runs:
        seed = f"seed {r['seed']}, starts moved by N(0, {args.jitter:g} m): " if seeds[0] else ""
        print(seed + hardcase_line(args.case, r, limit) + (f"; wrote {args.gif}" if traj else ""))
    if args.jitter > 0.0:
        s = hardcase_summary(runs)
        arrived = s["n_runs"] - s["runs_not_arrived"]
        times = f" (mean {s['time_mean_s']:.1f} s, max {s['time_max_s']:.1f} s)" if arrived else ""
        print(
            f"{s['n_runs']} runs: {s['runs_with_robot_contact']} with a robot-robot contact "
            f"({s['robot_touch']} touch, {s['robot_impact']} impact), "
            f"{s['runs_with_wall_contact']} with a robot-wall contact; all arrived in "
            f"{arrived}{times}; closest centres {s['closest_m']:.2f} m; failed tasks {s['failed']}"
        )
    return 0


def hardcase_line(case: str, r: dict, limit_s: float) -> str:
    """One run of ``mrta hardcase`` in words."""
    t = r["time_s"]
    when = (
        f"all arrived in {t:.1f} s"
        if t != float("inf")
        else f"not all arrived within {limit_s:g} s: {r['still_driving']} still driving"
    )
    return (
        f"{case}, {r['robots']} robots, avoidance {r['avoidance']}, "
        + ("look ahead on, " if r.get("look_ahead") == "on" else "")
        + ("traffic rules on, " if r.get("traffic") == "on" else "")
        + f"{r['control']} control: {when}; robot-robot contacts {r['robot_touch']} touch "
        f"{r['robot_impact']} impact, robot-wall {r['wall_touch']} touch "
        f"{r['wall_impact']} impact; closest centres {r['closest_m']:.2f} m; "
        f"failed tasks {r['failed']}"
    )


def hardcase_summary(runs: list[dict]) -> dict:
    """Counts over runs of one hard case: the runs, those with a robot-robot or robot-wall
    contact, the contacts of each kind, runs in which not every robot arrived, the mean and
    largest time of those that did (None if none did: the --json output stays strict JSON), the
    closest two centres came and the failed tasks."""
    times = [r["time_s"] for r in runs if r["time_s"] != float("inf")]
    return {
        "n_runs": len(runs),
        "runs_with_robot_contact": sum(r["robot_touch"] + r["robot_impact"] > 0 for r in runs),
        "runs_with_wall_contact": sum(r["wall_touch"] + r["wall_impact"] > 0 for r in runs),
        "robot_touch": sum(r["robot_touch"] for r in runs),
        "robot_impact": sum(r["robot_impact"] for r in runs),
        "runs_not_arrived": len(runs) - len(times),
        "time_mean_s": sum(times) / len(times) if times else None,
        "time_max_s": max(times) if times else None,
        "closest_m": min(r["closest_m"] for r in runs),
        "failed": sum(r["failed"] for r in runs),
    }


def cmd_bench(args) -> int:
    from scenarios.bench import run_bench
    from scenarios.experiments.output import dumps
    from scenarios.experiments.protocol import UserError

    if args.repeat > 1 and "sim" not in args.only:
        raise UserError(f"--repeat {args.repeat} repeats the sim part: add sim to --only")
    if args.split and "sim" not in args.only:
        raise UserError("--split splits the sim part's price: add sim to --only")
    result = run_bench(args.only, progress=not args.json, repeat=args.repeat, split=args.split)
    if args.json:
        print(dumps(result))
    return 0


def cmd_soak(args) -> int:
    from scenarios.experiments.output import dumps
    from scenarios.experiments.soak import soak

    result = soak(
        args.scenario,
        args.tasks,
        args.allocator,
        args.cost,
        args.seed,
        progress=not (args.json or args.no_progress),
        faults=args.faults + avoidance_overrides(args),
    )
    if args.json:
        print(dumps(result))
    else:
        for key, value in result.items():
            print(f"{key:>24}: {value:,.4g}" if isinstance(value, float) else f"{key:>24}: {value}")
    return 0


def cmd_sweep(args) -> int:
    """The ``mrta sweep`` command: run, then print where the outputs went."""
    from scenarios.sweep.against import read_runs, write_against
    from scenarios.sweep.avoidance_report import avoidance_rows
    from scenarios.sweep.report import key_columns
    from scenarios.sweep.runner import run_sweep
    from scenarios.sweep.spec import load_sweep

    sweep = load_sweep(args.spec)
    out = args.out or Path("renders") / "sweeps" / sweep.name
    against = getattr(args, "against", None)
    if against is not None:  # a bad file is an error before anything runs
        read_runs(against, key_columns(sweep), "--against")
    rows = run_sweep(
        args.spec,
        out,
        workers=args.workers,
        scheduler=args.scheduler,
        progress=not getattr(args, "no_progress", False),
    )
    groups = len({tuple(r[c] for c in key_columns(sweep) if c != "seed") for r in rows})
    report = avoidance_rows(rows, sweep.parameters)
    print(
        f"sweep {sweep.name}: {len(rows)} runs ({groups} combinations x {len(sweep.seeds)} seeds); "
        f"wrote {out}/runs.csv, summary.csv, summary.json"
        + (", avoidance.md, avoidance.json, avoidance.png" if report else "")
        + f" and {len(sweep.parameters)} sensitivity plot(s)"
    )
    if against is not None:
        doc = write_against(against, out, key_columns(sweep))
        print(
            f"against {against}: {len(doc['rows'])} group(s) paired by seed; "
            f"wrote {out}/against.md, against.json"
        )
    return 0


def cmd_study(args) -> int:
    """The ``mrta study`` command: run (or resume) the parts, print the tables."""
    from scenarios.experiments.protocol import UserError
    from scenarios.sweep.study import STUDIES, run_study
    from scenarios.sweep.study_analysis import markdown

    parts = STUDIES[args.name]
    if args.only:
        wanted = tuple(p.strip() for p in args.only.split(",") if p.strip())
        unknown = [p for p in wanted if p not in parts]
        if unknown or not wanted:
            raise UserError(f"--only: unknown part {unknown[0] if unknown else '(none)'!r}; "
                            f"parts of {args.name}: {', '.join(parts)}")  # fmt: skip
        parts = wanted
    out = args.out or Path("renders") / "study" / args.name
    if args.name == "faults":
        from scenarios.sweep.fault_study import markdown as fault_markdown
        from scenarios.sweep.fault_study import run_fault_study

        doc = run_fault_study(out, args.workers, args.scheduler, not args.no_progress)
        print(fault_markdown(doc))
        print(f"wrote {out}/study.json, study.md and faults.png")
        return 0
    doc = run_study(out, parts, args.workers, args.scheduler, not args.no_progress)
    print(markdown(doc))
    print(f"wrote {out}/study.json, study.md and the figures")
    return 0


def cmd_map_sites(args) -> int:
    import numpy as np

    from scenarios.experiments.protocol import UserError
    from sim.maps import load_map
    from sim.maps.placement import free_places

    if (args.types is None) == (args.names is None):
        raise UserError("map-sites needs either --types N or --names T1,T2,...")
    names = args.names or [f"T{i + 1}" for i in range(args.types)]
    occ = load_map(args.map)
    rng = np.random.default_rng(args.seed)
    n = len(names) * args.per_type
    places = free_places(occ, n + args.robots, rng, clearance_m=args.clearance, min_gap_m=args.gap)
    print(
        f"# {n} sites on {args.map}'s free floor ({args.clearance:g} m clear, {args.gap:g} m "
        f"apart, seed {args.seed}), in the map's frame (m)"
    )
    print("[spatial.sites]")
    for k, name in enumerate(names):
        pts = places[k * args.per_type : (k + 1) * args.per_type]
        print(f"{name} = [" + ", ".join(f"[{x:.2f}, {y:.2f}]" for x, y in pts) + "]")
    if args.robots:
        print(f"# start points for {args.robots} robots (start = [x, y] in each [[robots]])")
        for j, (x, y) in enumerate(places[n:]):
            print(f"# R{j + 1}: start = [{x:.2f}, {y:.2f}]")
    return 0


COMMANDS = {
    "validate": cmd_validate,
    "reproduce": cmd_reproduce,
    "stream": cmd_stream,
    "run": cmd_run,
    "compare": cmd_compare,
    "render": cmd_render,
    "bench": cmd_bench,
    "hardcase": cmd_hardcase,
    "sweep": cmd_sweep,
    "study": cmd_study,
    "soak": cmd_soak,
    "map-sites": cmd_map_sites,
}
