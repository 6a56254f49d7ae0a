"""Output files written atomically: a temporary file beside the target, then a rename.

An interrupted command never leaves a half-written ``metrics.json``, CSV or summary behind.
"""

from __future__ import annotations

import csv
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any


def write_csv_atomic(path: Path, columns: dict[str, list]) -> None:
    """Write equal-length columns as CSV (``tasks.csv``) via a temporary file and a rename."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp")
    with tmp.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(list(columns))
        writer.writerows(zip(*columns.values(), strict=True))
    os.replace(tmp, path)


def write_json_atomic(path: Path, doc: Any) -> None:
    """Write JSON via a temporary file, fsync and rename: never a half-written file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    with tmp.open("w") as fh:
        json.dump(doc, fh, indent=1, allow_nan=True)
        fh.write("\n")
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def write_rows_atomic(path: Path, header: Sequence[str], rows: Sequence[Sequence[str]]) -> None:
    """Write a header and rows as CSV, lines ending in ``\\n`` (``runs.csv``), through a
    temporary file, fsync and rename."""
    tmp = path.with_name(f".{path.name}.tmp")
    with tmp.open("w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
