"""What ``mrta run`` and ``mrta render`` write, as library functions a notebook can call.

:func:`write_run` plays one :class:`~scenarios.experiments.protocol.RunSpec` and writes its
folder (``metrics.json``, ``run_manifest.json``; in a spatial scenario ``tasks.csv``,
``spatial.png``, ``stalls.npz`` and ``stalls.png``; with robot faults ``faults.png``; with a
checkpoint ``checkpoint.npz``) as a whole (:mod:`scenarios.experiments.outdir`): a failed or
interrupted run leaves the folder as it was. :func:`render_run` plays a spec while recording and
writes its trajectory GIF (and an MP4, and the trajectory ``.npz``, if asked).
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path

from scenarios.experiments.manifest import build_manifest, write_manifest
from scenarios.experiments.metrics import aggregate
from scenarios.experiments.outdir import check_out_dir, check_out_file, staged_folder, staging_dir
from scenarios.experiments.output import write_csv_atomic, write_json_atomic, write_npz_atomic
from scenarios.experiments.progress import progress_bar, protocol_rounds
from scenarios.experiments.protocol import RunSpec, UserError, execute, load_named
from sim.scenario.overrides import apply_overrides

CHECKPOINT = "checkpoint.npz"


@dataclass
class RunFiles:
    """What :func:`write_run` did.

    Attributes:
        out: the folder written.
        summary: the run's summary (:func:`~scenarios.experiments.protocol.execute`), without
            its task table and stall map (they are in the files).
        metrics: what ``metrics.json`` holds.
        files: the names written in ``out``.
        stall_places: one line naming where driving robots stood longest ("" if none).
    """

    out: Path
    summary: dict
    metrics: dict
    files: list[str] = field(default_factory=list)
    stall_places: str = ""


def checkpoint_path(out: Path) -> Path:
    """Where a run into ``out`` keeps its checkpoint while it runs (and where ``--resume``
    finds it): the staging folder, whose files replace ``out`` when the run is complete."""
    return staging_dir(Path(out)) / CHECKPOINT


def write_run(
    spec: RunSpec,
    out: Path,
    *,
    checkpoint: bool = False,
    resume: bool = False,
    progress: bool = True,
) -> RunFiles:
    """Play ``spec`` and write its output folder ``out`` as a whole.

    Args:
        spec: the run.
        out: the folder to write (replaced only once every file is written).
        checkpoint: keep a checkpoint after every task set (``checkpoint.npz``), kept through a
            failure or an interruption so that ``resume`` can continue the run.
        resume: continue from that checkpoint; the outputs equal those of an uninterrupted run.
        progress: a progress display on stderr.

    Raises:
        OutputError: ``out`` cannot be written (checked before the run).
        UserError: ``resume`` without a checkpoint; a bad override.
    """
    out = check_out_dir(out)
    if resume and not checkpoint_path(out).is_file() and not (out / CHECKPOINT).is_file():
        raise UserError(f"{out}: no checkpoint to resume from (run with --checkpoint first)")
    scenario = load_named(spec.scenario)
    apply_overrides(scenario, spec.overrides)  # a bad override stops here, before anything
    manifest = build_manifest(scenario, [spec])
    with staged_folder(out, keep_on_failure=checkpoint, fresh=not resume) as stage:
        ck = stage / CHECKPOINT if (checkpoint or resume) else None
        if resume and not ck.is_file():  # a finished run's checkpoint: continue from it
            shutil.copy2(out / CHECKPOINT, ck)
        desc = f"run {spec.allocator} on {scenario.name}"
        with progress_bar(protocol_rounds(scenario), desc, "round", progress) as bar:
            summary = execute(
                spec,
                checkpoint=ck,
                resume=resume,
                task_table=True,
                on_round=bar.update,
                stall_map=True,
            )
        files, metrics, places = _write_run_files(stage, spec, scenario, summary, manifest)
    return RunFiles(out, summary, metrics, files, places)


def _write_run_files(stage: Path, spec: RunSpec, scenario, summary: dict, manifest: dict):
    """Write a finished run's files into ``stage``: (their names, metrics.json's content, the
    line naming where robots stood longest)."""
    write_manifest(stage, manifest)
    files = ["run_manifest.json"]
    table = summary.pop("task_table")
    stalls = summary.pop("stall_map", None)
    places = ""
    if scenario.spatial is not None:
        from scenarios.experiments.figures import fig_run_spatial

        write_csv_atomic(stage / "tasks.csv", table)
        fig_run_spatial(table, summary["spatial"], spec.cost, stage / "spatial.png")
        files += ["tasks.csv", "spatial.png"]
    if stalls is not None:
        places = write_stall_map(stage, stalls, scenario.spatial)
        files += ["stalls.npz", "stalls.png"]
    metrics = {
        "scenario": scenario.name,
        "cost_model": spec.cost,
        "seeds": [spec.seed],
        "allocators": {spec.allocator: aggregate([summary])},
    }
    write_json_atomic(stage / "metrics.json", metrics)
    files.append("metrics.json")
    if "faults" in summary:
        from scenarios.experiments.figures import fig_faults_run

        fig_faults_run(summary["faults"], stage / "faults.png")
        files.append("faults.png")
    if (stage / CHECKPOINT).is_file():
        files.append(CHECKPOINT)
    return files, metrics, places


def write_stall_map(out: Path, stalls: dict, spatial) -> str:
    """``stalls.npz`` (``seconds``: robot-s standing by cause and cell, ``causes``, ``cell_m``,
    ``arena_wh``) and ``stalls.png`` of a run; returns the line naming where robots stood
    longest."""
    import numpy as np

    from scenarios.experiments.figures import fig_stall_map, places_line, stall_places
    from sim.spatial.stalls import CAUSES

    seconds, cell_m = stalls["seconds"], float(stalls["cell_m"])
    arena = (spatial.width_m, spatial.height_m)
    write_npz_atomic(
        out / "stalls.npz",
        {
            "seconds": seconds,
            "causes": np.array(CAUSES),
            "cell_m": np.array(cell_m),
            "arena_wh": np.array(arena),
        },
    )
    still = spatial.stalls.still_mps
    fig_stall_map(seconds, cell_m, arena, spatial.obstacles, out / "stalls.png", still)
    return places_line(stall_places(seconds, cell_m), cell_m)


@dataclass
class RenderFiles:
    """What :func:`render_run` wrote: the files, the frame size and the time span drawn (s)."""

    files: list[Path]
    size: tuple[int, int]
    t_from: float
    t_to: float
    end_s: float


def render_run(
    spec: RunSpec,
    gif: Path,
    *,
    frames: int = 200,
    fps: int = 20,
    size: tuple[int, int | None] = (600, None),
    t_from: float = 0.0,
    t_to: float | None = None,
    trail_s: float = 10.0,
    mp4: Path | None = None,
    trajectory: Path | None = None,
    progress: bool = True,
) -> RenderFiles:
    """Play ``spec`` (a spatial scenario) while recording and draw its trajectory GIF.

    Every option is checked before the run: the output files' folders, the frame count and
    rate, the time span against the run's planned length, ffmpeg for ``mp4``.

    Args:
        spec: the run (its scenario must have a ``[spatial]`` table).
        gif: the GIF to write; mp4, trajectory: an MP4 and the recorded trajectory (``.npz``)
            too, if given.
        frames, fps: frames drawn and played per second (at most 50).
        size: (width, height) in px; height None fits the arena.
        t_from, t_to: the simulated span drawn, s (``t_to`` None: 180 s from ``t_from`` or the
            end of the run).
        trail_s: seconds of trail behind each robot.
        progress: progress displays on stderr.

    Raises:
        UserError: a bad option, or a scenario without ``[spatial]``.
    """
    from sim.recording import TrajectoryRecorder
    from sim.render import render_gif, render_mp4
    from sim.render.animation import ffmpeg_path
    from sim.render.style import fitted_height

    sc = apply_overrides(load_named(spec.scenario), spec.overrides)
    if sc.spatial is None:
        raise UserError(f"{spec.scenario}: render needs a spatial scenario (a [spatial] table)")
    check_out_file(gif, "--gif")
    for path, option in ((mp4, "--mp4"), (trajectory, "--trajectory")):
        if path is not None:
            check_out_file(path, option)
    if mp4 is not None and ffmpeg_path() is None:
        raise UserError("--mp4 needs ffmpeg on the PATH (none found); the GIF needs nothing")
    check_render_options(frames, fps, t_from, t_to, trail_s, planned_end_s(sc))
    recorder = TrajectoryRecorder.for_scenario(sc)
    rounds = protocol_rounds(sc)
    with progress_bar(rounds, f"render: simulate {sc.name}", "round", progress) as bar:
        execute(spec, recorder=recorder, on_round=bar.update)
    traj = recorder.finish()
    end = float(traj.times_s[-1])
    t_to = min(end, t_from + 180.0) if t_to is None else min(t_to, end)
    if not t_from < t_to:
        raise UserError(f"--from {t_from:g}: the run ended at {end:.1f} s, before it")
    written = []
    if trajectory is not None:
        traj.save(trajectory)
        written.append(Path(trajectory))
    width, height = size
    px = (width, height if height is not None else fitted_height(width, traj.arena_wh))
    kw = {"frames": frames, "fps": fps, "size": px, "t_from": t_from, "t_to": t_to}
    kw["trail_s"] = trail_s
    try:
        with progress_bar(frames, f"render: draw {frames} frames", "frame", progress) as bar:
            render_gif(traj, gif, on_frame=bar.update, **kw)
        written.append(Path(gif))
        if mp4 is not None:
            render_mp4(traj, mp4, **kw)
            written.append(Path(mp4))
    except (ValueError, RuntimeError) as exc:
        raise UserError(str(exc)) from None
    return RenderFiles(written, px, t_from, t_to, end)


def planned_end_s(scenario) -> float:
    """When the last announcement of the protocol's sets comes, s (the run lasts a little
    longer: it drains its last set)."""
    s = scenario.stream
    return (s.learn_sets + s.test_sets) * s.rounds_per_set * s.announce_interval_s


def check_render_options(
    frames: int, fps: int, t_from: float, t_to: float | None, trail_s: float, end_s: float
) -> None:
    """The drawing options, checked before a run: UserError naming the first bad one."""
    if frames < 1:
        raise UserError(f"--frames {frames}: draw at least one frame")
    if not 1 <= fps <= 50:
        raise UserError(f"--fps {fps}: a GIF plays 1 to 50 frames per second")
    if not (trail_s >= 0.0 and trail_s < float("inf")):
        raise UserError(f"--trail {trail_s}: must be a finite number of seconds >= 0")
    if not t_from >= 0.0:
        raise UserError(f"--from {t_from}: must be >= 0 s")
    if t_from >= end_s:
        raise UserError(
            f"--from {t_from:g}: the run's last announcement comes at {end_s:g} s (fewer --sets?)"
        )
    if t_to is not None and not t_to > t_from:
        raise UserError(f"--from {t_from:g} / --to {t_to:g}: need from < to")
