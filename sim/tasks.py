"""Task streams: seeded generation, announcement batches, and JSON/CSV files.

A stream is a set of column arrays, one row per task, ordered by (set, round). Every
allocator of a comparison replays the same stream, so they see the very same tasks.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sim.atomic import atomic_open
from sim.scenario import Scenario

STREAM_COLUMNS = ("id", "set", "round", "type", "high", "x", "y")


@dataclass(frozen=True, slots=True)
class Batch:
    """The tasks announced together in one round."""

    set_index: int
    round_index: int
    ids: np.ndarray  # (k,) int
    types: np.ndarray  # (k,) int, indices into Scenario.task_types
    high: np.ndarray  # (k,) bool, True for high priority
    sites: np.ndarray  # (k, 2) float, m; NaN in abstract streams

    def __len__(self) -> int:
        return int(self.ids.size)


@dataclass(frozen=True, slots=True)
class TaskStream:
    """All tasks of an experiment, one row per task, ordered by set and round."""

    set_index: np.ndarray
    round_index: np.ndarray
    types: np.ndarray
    high: np.ndarray
    sites: np.ndarray  # (N, 2)
    n_sets: int
    rounds_per_set: int

    def __len__(self) -> int:
        return int(self.types.size)

    def batches(self, set_index: int) -> Iterator[Batch]:
        """Yield the rounds of one set in order (a round may be empty only in hand-made streams)."""
        rows = np.flatnonzero(self.set_index == set_index)
        rounds = self.round_index[rows]
        for r in range(self.rounds_per_set):
            sel = rows[rounds == r]
            yield Batch(set_index, r, sel, self.types[sel], self.high[sel], self.sites[sel])

    def to_columns(self) -> dict[str, np.ndarray]:
        return {
            "id": np.arange(len(self)),
            "set": self.set_index,
            "round": self.round_index,
            "type": self.types,
            "high": self.high.astype(int),
            "x": self.sites[:, 0],
            "y": self.sites[:, 1],
        }


def generate_stream(scenario: Scenario, rng: np.random.Generator) -> TaskStream:
    """Draw a stream: per round U{batch_min..batch_max} tasks, uniform types, P(high) = p_high.

    In spatial scenarios each task is placed at one of its type's sites, drawn uniformly.
    """
    spec = scenario.stream
    n_rounds = spec.n_sets * spec.rounds_per_set
    sizes = rng.integers(spec.batch_min, spec.batch_max + 1, size=n_rounds)
    total = int(sizes.sum())
    round_of_task = np.repeat(np.arange(n_rounds), sizes)
    types = rng.integers(0, scenario.n_types, size=total)
    high = rng.random(total) < spec.p_high
    sites = np.full((total, 2), np.nan)
    if scenario.spatial is not None:
        pick = rng.random(total)
        for i, points in enumerate(scenario.spatial.sites):
            rows = np.flatnonzero(types == i)
            idx = np.minimum((pick[rows] * len(points)).astype(int), len(points) - 1)
            sites[rows] = np.asarray(points, dtype=float)[idx]
    return TaskStream(
        set_index=round_of_task // spec.rounds_per_set,
        round_index=round_of_task % spec.rounds_per_set,
        types=types,
        high=high,
        sites=sites,
        n_sets=spec.n_sets,
        rounds_per_set=spec.rounds_per_set,
    )


class StreamFileError(ValueError):
    """A stream file that cannot be read; the message names the file and the problem."""


def save_stream(stream: TaskStream, path: Path) -> None:
    """Write a stream as JSON (``.json``) or CSV (any other suffix), atomically."""
    path = Path(path)
    cols = stream.to_columns()
    if path.suffix == ".json":
        doc = {
            "n_sets": stream.n_sets,
            "rounds_per_set": stream.rounds_per_set,
            "columns": {k: [_jsonable(x) for x in v.tolist()] for k, v in cols.items()},
        }
        text = json.dumps(doc)
        with atomic_open(path) as fh:
            fh.write(text)
        return
    with atomic_open(path, newline="") as fh:
        fh.write(f"# n_sets={stream.n_sets} rounds_per_set={stream.rounds_per_set}\n")
        writer = csv.writer(fh)
        writer.writerow(STREAM_COLUMNS)
        for row in zip(*(cols[c].tolist() for c in STREAM_COLUMNS), strict=True):
            writer.writerow(["" if isinstance(v, float) and np.isnan(v) else v for v in row])


def _jsonable(x: float | int) -> float | int | None:
    return None if isinstance(x, float) and np.isnan(x) else x


def load_stream(path: Path) -> TaskStream:
    """Read a stream written by :func:`save_stream`; raises StreamFileError on bad content."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise StreamFileError(f"{path}: cannot read stream file ({exc.strerror})") from None
    try:
        if path.suffix == ".json":
            doc = json.loads(text)
            n_sets, rounds = int(doc["n_sets"]), int(doc["rounds_per_set"])
            raw = doc["columns"]
            cols = {c: raw[c] for c in STREAM_COLUMNS}
        else:
            lines = text.splitlines()
            header = dict(kv.split("=") for kv in lines[0].lstrip("# ").split())
            n_sets, rounds = int(header["n_sets"]), int(header["rounds_per_set"])
            rows = list(csv.DictReader(lines[1:]))
            cols = {c: [r[c] if r[c] != "" else None for r in rows] for c in STREAM_COLUMNS}
        set_index = np.asarray(cols["set"], dtype=int)
        round_index = np.asarray(cols["round"], dtype=int)
        types = np.asarray(cols["type"], dtype=int)
        high = np.asarray(cols["high"], dtype=int).astype(bool)
        sites = np.column_stack(
            [np.asarray([np.nan if v is None else float(v) for v in cols[c]]) for c in "xy"]
        ).reshape(-1, 2)
    except (KeyError, ValueError, TypeError, IndexError, json.JSONDecodeError) as exc:
        raise StreamFileError(
            f"{path}: malformed stream file ({type(exc).__name__}: {exc})"
        ) from None
    if (set_index < 0).any() or (set_index >= n_sets).any():
        raise StreamFileError(f"{path}: column 'set' outside 0..{n_sets - 1}")
    if (round_index < 0).any() or (round_index >= rounds).any():
        raise StreamFileError(f"{path}: column 'round' outside 0..{rounds - 1}")
    order = np.lexsort((round_index, set_index))
    return TaskStream(
        set_index[order],
        round_index[order],
        types[order],
        high[order],
        sites[order],
        n_sets,
        rounds,
    )
