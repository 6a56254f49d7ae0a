"""Checkpoints of learned state: ``.npz`` files with ``allow_pickle=False``, written atomically.

A checkpoint holds plain arrays only: per-robot Q-tables, alphabets and histories, the
experience counters and behaviours (refusals are behaviour 2), the allocator's random
generator state and counters, the world's clock, and the run record so far. Metadata is one
JSON document stored as a unicode array. Writing goes to a temporary file in the same folder,
is fsynced and then renamed over the old checkpoint, so a process killed mid-write leaves the
previous checkpoint intact. A file that is truncated, corrupt or of another format raises
:class:`CheckpointError` before anything is restored: a state is loaded whole or not at all.

Layout (keys of the ``.npz``):

- ``meta``: JSON with ``format`` ("expt-mrta-checkpoint/1"), ``allocator``, ``spec``, the
  position to resume from (``phase``, ``set_pos``), counters and the RNG state;
- ``q/<j>``, ``alphabet/<j>``, ``recent/<j>``: robot j's Q-table (n_j**h x 2), task set, history;
- ``exp/<name>``: ExpT experience arrays (eta, mu, v, v_sum, count, behaviour), if any;
- ``rec/<phase>/<column>``: the run record so far (see :func:`learning.episode.record_arrays`).
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from learning.qtable import HistoryQTable
from sim.atomic import atomic_open

FORMAT = "expt-mrta-checkpoint/1"
EXPERIENCE_ARRAYS = ("eta_", "mu_", "v_", "v_sum_", "count_", "behaviour_")


class CheckpointError(ValueError):
    """A checkpoint that cannot be loaded; the message names the file and the problem."""


def allocator_arrays(allocator) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Learned state of an allocator as (arrays, JSON-able metadata)."""
    arrays: dict[str, np.ndarray] = {}
    meta: dict[str, Any] = {"allocator": allocator.name}
    if not allocator.learns:
        return arrays, meta
    learner = allocator.learner_
    for j, table in enumerate(learner.tables_):
        arrays[f"q/{j}"] = table.q_
        arrays[f"alphabet/{j}"] = np.asarray(table.alphabet_, dtype=np.int64)
        arrays[f"recent/{j}"] = np.asarray(table.recent_, dtype=np.int64)
    meta["epsilon"] = learner.epsilon_
    meta["learning_sets_seen"] = learner.learning_sets_seen_
    meta["rng_state"] = learner.rng_.bit_generator.state
    if hasattr(allocator, "experience_"):
        for name in EXPERIENCE_ARRAYS:
            arrays[f"exp/{name}"] = getattr(allocator.experience_, name)
        meta["auctions"] = allocator.auctions_
        meta["refusal_log"] = [list(x) for x in allocator.refusal_log_]
    return arrays, meta


def restore_allocator(allocator, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    """Put the state written by :func:`allocator_arrays` back into a freshly reset allocator."""
    if meta.get("allocator") != allocator.name:
        raise CheckpointError(
            f"checkpoint is for allocator {meta.get('allocator')!r}, not {allocator.name!r}"
        )
    if not allocator.learns:
        return
    learner = allocator.learner_
    h = learner.spec.history
    tables = []
    for j in range(len(learner.tables_)):
        table = HistoryQTable(arrays[f"alphabet/{j}"].tolist(), h)
        q = arrays[f"q/{j}"]
        if q.shape != table.q_.shape:
            raise CheckpointError(
                f"robot {j}: Q-table shape {q.shape} does not match {table.q_.shape}"
            )
        table.q_ = q.astype(float).copy()
        table.recent_ = arrays[f"recent/{j}"].tolist()
        tables.append(table)
    learner.tables_ = tables
    learner.epsilon_ = float(meta["epsilon"])
    learner.learning_sets_seen_ = int(meta["learning_sets_seen"])
    learner.rng_.bit_generator.state = meta["rng_state"]
    if hasattr(allocator, "experience_"):
        for name in EXPERIENCE_ARRAYS:
            setattr(allocator.experience_, name, arrays[f"exp/{name}"].copy())
        allocator.auctions_ = int(meta["auctions"])
        allocator.refusal_log_ = [tuple(x) for x in meta["refusal_log"]]


def save_checkpoint(path: Path, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    """Write arrays + metadata atomically: temporary file, fsync, rename, fsync the folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    doc = {"format": FORMAT, **meta}
    payload = {"meta": np.array(json.dumps(doc)), **arrays}
    with atomic_open(path, "wb", sync_folder=True) as fh:
        np.savez(fh, **payload)


def load_checkpoint(path: Path) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Read a checkpoint whole; raise CheckpointError for a missing, truncated or foreign file."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: no checkpoint file")
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (
        OSError,
        ValueError,
        KeyError,
        EOFError,
        zipfile.BadZipFile,
        json.JSONDecodeError,
    ) as exc:
        raise CheckpointError(
            f"{path}: corrupt or truncated checkpoint ({type(exc).__name__})"
        ) from None
    if meta.get("format") != FORMAT:
        raise CheckpointError(
            f"{path}: not an expt-mrta checkpoint (format {meta.get('format')!r})"
        )
    return arrays, meta
