"""Parameter sweeps from a TOML file (``mrta sweep``), locally or on a Dask cluster, resumable.

A sweep file names scenarios, allocators, cost models, seeds and the parameters to vary (any
``section.key`` that :func:`scenarios.experiments.protocol.apply_overrides` understands)::

    [sweep]
    scenarios = ["paper"]
    allocators = ["ql", "expt"]
    costs = ["abstract"]            # default
    seeds = 10                      # 0..9, or a list [0, 4, 7]

    [fixed]                         # applied to every run
    "stream.n_sets" = 20

    [grid]                          # every combination (or [[points]]: explicit combinations)
    "experience.delta_u" = [0.05, 0.1, 0.3]
    "experience.n_min" = [20, 40]

A ``[[points]]`` entry may add ``allocators = ["expt"]`` to run only those allocators at that
point (an ExpT-MRTA parameter need not be repeated for QL-MRTA and the market). String
parameters (``"experience.refusal" = "reserve"``) are swept like numbers.

Every run writes one row to ``runs.csv`` as soon as it finishes (flushed and fsynced), so an
interrupted sweep re-run into the same folder only runs what is missing. At the end the rows are
rewritten in spec order (never in completion order), and ``summary.csv``, ``summary.json`` and
one ``sensitivity_<parameter>.png`` per swept parameter are written, all atomically.
"""

from __future__ import annotations

import csv
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from pathlib import Path

from scenarios.experiments.budget import check_work
from scenarios.experiments.outdir import check_out_dir, folder_lock
from scenarios.experiments.output import write_rows_atomic
from scenarios.experiments.protocol import RunSpec, UserError, compile_once, execute, load_named
from scenarios.sweep.report import metric_row, read_rows, typed_row, write_outputs
from scenarios.sweep.spec import SweepSpec, load_sweep

__all__ = ["run_metrics", "run_sweep"]


def _all_cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def run_metrics(spec: RunSpec) -> dict[str, str]:
    """Worker side: run one spec, return its metric columns as CSV strings."""
    return metric_row(execute(spec))


def run_sweep(
    spec_path: str | Path,
    out: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
) -> list[dict]:
    """Run every combination of a sweep file and write runs.csv, summaries and plots to ``out``.

    Args:
        spec_path: the sweep TOML file (or a bundled sweep name, see ``load_sweep``).
        out: output folder; runs already in ``out/runs.csv`` are not run again.
        workers: local processes (default: every core this process may use); ignored with
            ``scheduler``.
        scheduler: address of a running dask.distributed scheduler (``tcp://host:8786``).
        progress: show a tqdm bar with an ETA.

    Returns:
        One dict per run in spec order: the runs.csv row with numbers parsed.

    Raises:
        UserError, ScenarioError: a bad sweep file, scenario or output folder (one-line message).
    """
    sweep = load_sweep(spec_path)
    _check_work(sweep, workers)
    client = _dask_client(scheduler) if scheduler else None
    try:
        return _run(sweep, Path(out), workers, client, progress)
    finally:
        if client is not None:
            client.close()


def _check_work(sweep: SweepSpec, workers: int | None) -> None:
    """Each scenario's runs against this machine (``budget.check_work``)."""
    per_scenario: dict[str, int] = {}
    for run in sweep.runs:
        per_scenario[run.spec.scenario] = per_scenario.get(run.spec.scenario, 0) + 1
    procs = _all_cores() if workers is None else workers
    for name, n in per_scenario.items():
        check_work(load_named(name), n, min(procs, n))


def _run(sweep: SweepSpec, out: Path, workers, client, progress: bool) -> list[dict]:
    """Resume from ``out/runs.csv``, run what is missing, then write every output in spec order
    (under ``out``'s lock: a second sweep into the same folder is refused)."""
    out = check_out_dir(out)
    with folder_lock(out):
        return _run_locked(sweep, out, workers, client, progress)


def _run_locked(sweep: SweepSpec, out: Path, workers, client, progress: bool) -> list[dict]:
    out.mkdir(parents=True, exist_ok=True)
    csv_path = out / "runs.csv"
    header = sweep.columns()
    keys = [sweep.key(run) for run in sweep.runs]
    done = read_rows(csv_path, header, set(keys))
    write_rows_atomic(csv_path, header, list(done.values()))  # drops a truncated last line
    todo = [(k, run) for k, run in zip(keys, sweep.runs, strict=True) if k not in done]
    with csv_path.open("a", newline="") as fh:
        fresh = _execute_all(sweep, todo, fh, workers, client, progress)
    done.update(fresh)
    rows = [done[k] for k in keys]
    write_rows_atomic(csv_path, header, rows)
    write_outputs(sweep, rows, out)
    return [typed_row(row, sweep) for row in rows]


def _execute_all(sweep: SweepSpec, todo, fh, workers, client, progress) -> dict:
    """Run the missing specs; append each row to ``fh`` the moment it is known."""
    from scenarios.experiments.progress import progress_bar

    writer = csv.writer(fh, lineterminator="\n")
    fresh: dict[tuple[str, ...], list[str]] = {}
    skipped = len(sweep.runs) - len(todo)
    desc = f"sweep {sweep.name}" + (f" ({skipped} done before)" if skipped else "")
    bar = progress_bar(len(todo), desc, "run", progress and bool(todo))

    def record(key, run, metrics: dict[str, str]) -> None:
        row = sweep.key_row(run) + [metrics[c] for c in sweep.metric_columns]
        writer.writerow(row)
        fh.flush()
        os.fsync(fh.fileno())
        fresh[key] = row
        bar.update()

    try:
        if not todo:
            return fresh
        if client is not None:
            _run_dask(client, todo, record)
        elif (workers or _all_cores()) <= 1 or len(todo) == 1:
            for key, run in todo:
                record(key, run, run_metrics(run.spec))
        else:
            _run_pool(workers or _all_cores(), todo, record)
    finally:
        bar.close()
    return fresh


def _run_pool(workers: int, todo, record) -> None:
    compile_once([run.spec for _, run in todo])
    pool = ProcessPoolExecutor(max_workers=min(workers, len(todo)))
    try:
        pending = {pool.submit(run_metrics, run.spec): (key, run) for key, run in todo}
        while pending:
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                key, run = pending.pop(fut)
                record(key, run, fut.result())
    except BaseException:  # Ctrl-C or a failed run: keep what is written, drop the queue
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def _dask_client(address: str):
    try:
        from distributed import Client
    except ImportError:
        raise UserError(
            "--scheduler needs dask.distributed: pip install 'expt-mrta[cluster]'"
        ) from None
    try:
        return Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise UserError(f"cannot connect to the Dask scheduler at {address}: {exc}") from None


def _run_dask(client, todo, record) -> None:
    """Submit every run to the cluster; rows are recorded as futures complete."""
    from distributed import as_completed

    futures = client.map(run_metrics, [run.spec for _, run in todo], pure=False)
    origin = {fut.key: item for fut, item in zip(futures, todo, strict=True)}
    try:
        for fut in as_completed(futures):
            key, run = origin[fut.key]
            record(key, run, fut.result())
    except BaseException:
        client.cancel(futures)
        raise
