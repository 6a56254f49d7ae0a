"""The experiment protocol: one run from a seed, many runs in parallel, and ``reproduce``.

Seeding follows Gymnasium: one integer seed becomes ``np.random.SeedSequence(seed)``, spawned
into three generators (task stream, world, allocator) by :func:`learning.seeding.run_generators`.
The stream depends on the seed only, so every allocator and cost model of a comparison sees the
very same tasks. A run's result depends on its spec only, never on the process, worker or order
it ran in.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from learning.assembly import build_world, seeded_stream
from learning.checkpoint import (
    CheckpointError,
    allocator_arrays,
    load_checkpoint,
    restore_allocator,
    save_checkpoint,
)
from learning.episode import record_arrays, record_from_arrays, run_protocol
from learning.registry import allocator_class
from scenarios.experiments.metrics import (
    completion_table,
    spatial_metrics,
    spatial_per_robot,
    summarize_run,
)
from scenarios.loader import load_scenario, read_toml, resolve
from sim.scenario import Scenario
from sim.scenario.overrides import apply_overrides
from sim.tasks import TaskStream, load_stream


class UserError(ValueError):
    """Bad command-line input; the CLI prints the message on one line and exits with code 2."""


@dataclass(frozen=True, slots=True)
class RunSpec:
    """Everything that determines one run."""

    scenario: str  # bundled name or path
    allocator: str
    cost: str = "abstract"
    seed: int = 0
    overrides: tuple[tuple[str, float], ...] = ()  # (("experience.delta_u", 0.1), ...)
    trace_robot: str = ""  # keep per-round experience trace of this robot (fig. 2)
    stream_file: str = ""  # replay this stream instead of generating one


def load_named(name: str) -> Scenario:
    """A scenario by bundled name or path, loaded once per process and file content (runs of
    a sweep share it; a file written again between runs is read again)."""
    path = resolve(name)
    raw = read_toml(path)[1]  # one line for a file that cannot be read
    return _load_content(str(path), hashlib.sha256(raw).hexdigest())


@lru_cache(maxsize=32)
def _load_content(path: str, sha256: str) -> Scenario:
    """``load_scenario(path)``, once per path and content (``sha256`` of the file)."""
    return load_scenario(path)


def check_cost(scenario: Scenario, cost: str) -> None:
    if cost != "abstract" and scenario.spatial is None:
        raise UserError(
            f"cost model {cost!r} needs a spatial scenario; {scenario.name!r} has no [spatial] "
            "table (try --scenario paper_spatial)"
        )


def build_run(spec: RunSpec):
    """Scenario, stream, world, cost model, allocator and the world's generator of a spec,
    ready to play (world and cost model built as the environments build theirs:
    :mod:`learning.assembly`)."""
    scenario = apply_overrides(load_named(spec.scenario), spec.overrides)
    check_cost(scenario, spec.cost)
    stream, rngs = seeded_stream(scenario, spec.seed)
    if spec.stream_file:
        stream = load_stream(Path(spec.stream_file))
        check_stream(scenario, stream, spec.stream_file)
    world, cost = build_world(scenario, spec.cost)
    allocator = allocator_class(spec.allocator)(scenario)
    allocator.reset(rngs.allocator)
    return scenario, stream, world, cost, allocator, rngs.world


def check_stream(scenario: Scenario, stream: TaskStream, where: str) -> None:
    """A replayed stream must fit the scenario it is played in."""
    if stream.n_sets != scenario.stream.n_sets:
        raise UserError(
            f"{where}: stream has {stream.n_sets} sets, scenario wants {scenario.stream.n_sets}"
        )
    if len(stream) and (stream.types.max() >= scenario.n_types or stream.types.min() < 0):
        raise UserError(f"{where}: task types outside 0..{scenario.n_types - 1}")
    if scenario.spatial is not None and np.isnan(stream.sites).any():
        raise UserError(f"{where}: a spatial scenario needs task sites (x, y) for every task")


def execute(
    spec: RunSpec,
    checkpoint: Path | None = None,
    resume: bool = False,
    recorder=None,
    task_table: bool = False,
    on_round=None,
    stall_map: bool = False,
) -> dict:
    """Run one spec and return its JSON-able summary (plus the fig. 2 trace when asked).

    Args:
        checkpoint: write learned state here after every task set (atomically).
        resume: continue from ``checkpoint`` instead of starting afresh; the result equals
            that of an uninterrupted run.
        recorder: a ``sim.recording.TrajectoryRecorder`` (spatial worlds) to fill.
        task_table: add ``"task_table"``, one row per test-phase task that was allocated.
        stall_map: add ``"stall_map"`` (spatial worlds): ``cell_m`` and ``seconds``, where
            driving robots stood still, by cause (``sim.spatial.stalls.StallMeter.seconds_map``).
        on_round: called after every announcement round (progress bars).
    """
    scenario, stream, world, cost, allocator, rng = build_run(spec)
    if recorder is not None:
        world.recorder = recorder
    resume_at = _resume(spec, checkpoint, allocator, world, rng) if resume else None
    on_set_end = None
    if checkpoint is not None:

        def on_set_end(phase: int, set_pos: int, rec) -> None:
            arrays, meta = allocator_arrays(allocator)
            arrays.update(record_arrays(rec))
            arrays.update({f"world/{k}": v for k, v in world.state_arrays().items()})
            meta.update(
                spec=_spec_json(spec),
                phase=phase,
                set_pos=set_pos,
                world_rng_state=rng.bit_generator.state,
            )
            save_checkpoint(checkpoint, arrays, meta)

    record = run_protocol(
        scenario,
        stream,
        allocator,
        world,
        cost,
        rng,
        trace=bool(spec.trace_robot),
        on_set_end=on_set_end,
        resume=resume_at,
        recorder=recorder,
        on_round=on_round,
    )
    out = summarize_run(scenario, stream, record, allocator.learns)
    out["spec"] = dataclasses.asdict(spec)
    if task_table:
        out["task_table"] = completion_table(scenario, stream, record)
    if scenario.spatial is not None:
        out["spatial"] = {
            **spatial_metrics(scenario, stream, record, spec.cost),
            **world.summary(record),
        }
        out["per_robot"] = spatial_per_robot(scenario, record)
        if stall_map:  # a world with space is a sim.spatial.world.PymunkWorld
            stalls = world.stalls
            out["stall_map"] = {"cell_m": stalls.cell_m, "seconds": stalls.seconds_map()}
    if spec.trace_robot and record.trace_u:
        j = [r.name for r in scenario.robots].index(spec.trace_robot)
        learn_rounds = len(record.learn.task_ids)
        out["trace"] = {
            "robot": spec.trace_robot,
            "round": record.trace_time[:learn_rounds],
            "tem": np.array(record.trace_u)[:learn_rounds, j].tolist(),
            "behaviour": np.array(record.trace_behaviour)[:learn_rounds, j].tolist(),
            "space": np.array(record.trace_space)[:learn_rounds, j].tolist(),
            "capabilities": [scenario.task_types[i] for i in scenario.robots[j].capabilities],
            "task_types": list(scenario.task_types),
        }
    return out


def _spec_json(spec: RunSpec) -> dict:
    return json.loads(json.dumps(dataclasses.asdict(spec)))


def _resume(spec: RunSpec, checkpoint: Path | None, allocator, world, rng):
    """Restore allocator, world and record from a checkpoint; return run_protocol's resume."""
    if checkpoint is None:
        raise UserError("--resume needs a checkpoint file")
    arrays, meta = load_checkpoint(checkpoint)
    if meta.get("spec") != _spec_json(spec):
        raise CheckpointError(f"{checkpoint}: written by another run (spec {meta.get('spec')})")
    restore_allocator(allocator, arrays, meta)
    world.reset(rng)
    try:  # a checkpoint whose world arrays do not fit this world (edited or damaged)
        world.restore_arrays({k[6:]: v for k, v in arrays.items() if k.startswith("world/")})
    except (ValueError, KeyError) as exc:
        raise CheckpointError(f"{checkpoint}: world/{exc}") from None
    rng.bit_generator.state = meta["world_rng_state"]
    return int(meta["phase"]), int(meta["set_pos"]), record_from_arrays(arrays)


def run_many(
    specs: Sequence[RunSpec],
    workers: int | None = None,
    progress: bool = True,
    desc: str = "runs",
) -> list[dict]:
    """Execute specs, in parallel when ``workers`` > 1; results come back in spec order."""
    from scenarios.experiments.progress import progress_bar

    workers = default_workers() if workers is None else workers
    bar = progress_bar(len(specs), desc, "run", progress)
    try:
        if workers <= 1 or len(specs) <= 1:
            results = []
            for spec in specs:
                results.append(execute(spec))
                bar.update()
            return results
        compile_once(specs)
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(execute, spec) for spec in specs]
            try:
                for fut in futures:
                    fut.add_done_callback(lambda _f: bar.update())
                return [f.result() for f in futures]
            except BaseException:
                for fut in futures:
                    fut.cancel()
                raise
    finally:
        bar.close()


def compile_once(specs: Sequence[RunSpec]) -> None:
    """Before worker processes start: compile (or load) the pymunk world's control kernel in
    this process when a spec is spatial, so a clean install compiles it once, not once per
    worker (each worker then loads it from the cache)."""
    if any(load_named(s.scenario).spatial is not None for s in specs):
        from sim.spatial.control.kernel.loading import ensure_compiled

        ensure_compiled()


def default_workers() -> int:
    return max(1, min(os.cpu_count() or 1, 8))
