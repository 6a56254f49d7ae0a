"""The size of a piece of work, estimated before anything is built, and the limits it must keep.

A typo on the command line (``--seeds 1000000000``) or in a sweep file must not start a
computation that cannot finish or fill the memory: counts are bounded where they are parsed
(:data:`MAX_SEEDS`, :data:`MAX_RUNS`), and :func:`check_work` estimates what a batch of runs
holds in memory at once (each worker's task stream and world, and every finished run's summary
until the batch ends) against this machine's memory, refusing with one line that names the
limit.
"""

from __future__ import annotations

import os

from scenarios.experiments.protocol import UserError

MAX_SEEDS = 10_000  # seeds of one command or sweep
MAX_RUNS = 100_000  # runs of one command or sweep
SUMMARY_BYTES = 64 * 1024  # a finished run's summary kept until its batch ends, about
TASK_BYTES = 7 * 8 * 4  # a task of a stream: 7 columns, and what the world keeps of it
ROBOT_BYTES = 64 * 1024  # a robot of a pymunk world: bodies, joints, fleet arrays, paths
WORKER_BYTES = 250 * 2**20  # a worker process: Python, numpy, scipy, pymunk
MEMORY_SHARE = 0.8  # of the machine's memory a batch may plan to use


def machine_memory_bytes() -> int:
    """This machine's physical memory, bytes (0 if it cannot be read)."""
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 0


def check_count(name: str, n: int, limit: int) -> None:
    """UserError if ``n`` (of ``name``) is more than ``limit``."""
    if n > limit:
        raise UserError(f"{name}: {n:,} is more than the {limit:,} one command accepts")


def estimate_bytes(scenario, n_runs: int, workers: int) -> int:
    """Memory a batch of ``n_runs`` runs of ``scenario`` on ``workers`` processes holds at its
    peak, about, bytes."""
    s = scenario.stream
    tasks = s.n_sets * s.rounds_per_set * s.batch_max
    per_worker = WORKER_BYTES + tasks * TASK_BYTES
    if scenario.spatial is not None:
        per_worker += scenario.n_robots * ROBOT_BYTES
    return max(1, workers) * per_worker + n_runs * SUMMARY_BYTES


def check_work(scenario, n_runs: int, workers: int, memory_bytes: int | None = None) -> None:
    """Refuse, with one line naming the limit, a batch that cannot run on this machine: more
    than :data:`MAX_RUNS` runs, or an estimated peak memory above :data:`MEMORY_SHARE` of the
    machine's (``memory_bytes``: the machine's, for tests)."""
    check_count("runs", n_runs, MAX_RUNS)
    have = machine_memory_bytes() if memory_bytes is None else memory_bytes
    need = estimate_bytes(scenario, n_runs, workers)
    if have and need > MEMORY_SHARE * have:
        raise UserError(
            f"{n_runs:,} runs of {scenario.name!r} on {workers} worker(s) need about "
            f"{need / 2**30:.1f} GiB, more than {MEMORY_SHARE:.0%} of this machine's "
            f"{have / 2**30:.1f} GiB (fewer seeds, sets or workers)"
        )
