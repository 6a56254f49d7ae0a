"""Output files written atomically (``sim.atomic``: a temporary file beside the target,
fsync, then a rename).

An interrupted command never leaves a half-written ``metrics.json``, CSV or summary behind.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sim.atomic import atomic_open


def write_csv_atomic(path: Path, columns: dict[str, list]) -> None:
    """Write equal-length columns as CSV (``tasks.csv``) via a temporary file and a rename."""
    with atomic_open(path, newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(list(columns))
        writer.writerows(zip(*columns.values(), strict=True))


def strict_json(doc: Any) -> Any:
    """``doc`` with every NaN and infinity replaced by ``None``: JSON that any parser reads.

    Outputs say why a value is null in a field beside it (``ci95_note``, ``estimate_note``).
    """
    if isinstance(doc, float):
        return doc if math.isfinite(doc) else None
    if isinstance(doc, dict):
        return {k: strict_json(v) for k, v in doc.items()}
    if isinstance(doc, list | tuple):
        return [strict_json(v) for v in doc]
    if hasattr(doc, "item") and hasattr(doc, "dtype"):  # numpy scalars
        return strict_json(doc.item())
    return doc


def dumps(doc: Any, **kwargs) -> str:
    """Strict JSON text (no NaN or Infinity tokens) of ``doc``."""
    return json.dumps(strict_json(doc), allow_nan=False, **kwargs)


def write_json_atomic(path: Path, doc: Any) -> None:
    """Write strict JSON via a temporary file, fsync and rename: never a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    doc = strict_json(doc)
    text = json.dumps(doc, indent=1, allow_nan=False) + "\n"
    with atomic_open(path) as fh:
        fh.write(text)


def write_npz_atomic(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """Write arrays to an ``.npz`` via a temporary file and rename; no object arrays, so it
    loads with ``allow_pickle=False``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    for name, value in arrays.items():
        if np.asarray(value).dtype == object:
            raise TypeError(f"{path.name}/{name}: object arrays need pickle")
    with atomic_open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)


def write_rows_atomic(path: Path, header: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """Write a header and rows as CSV, lines ending in ``\\n`` (``runs.csv``), through a
    temporary file, fsync and rename."""
    with atomic_open(path, newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
