"""Files written atomically: a temporary file beside the target, fsync, then a rename.

Every file the package writes for a user (metrics, CSV, ``.npz`` trajectories and
checkpoints, task streams, GIFs, videos) goes through here, so an interrupted or failing
write never leaves a half-written target, never damages the file it was replacing, and
never leaves its temporary file behind.

The temporary file is ``.<name>.<pid>.tmp<suffix>`` in the target's folder (the same file
system, so the rename is atomic; the process id keeps two processes writing the same
target, as parallel sweeps can, off each other's temporary files). Only a process killed
outright (SIGKILL, a power cut) leaves its hidden temporary file behind; the target is then
still the previous complete file.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any


def temp_beside(path: Path, suffix: str = "") -> Path:
    """The temporary file's name for ``path`` (``suffix`` for writers that need one)."""
    path = Path(path)
    return path.with_name(f".{path.name}.{os.getpid()}.tmp{suffix}")


def _fsync_file(path: Path) -> None:
    with open(path, "rb") as fh:
        os.fsync(fh.fileno())


def _fsync_folder(folder: Path) -> None:
    fd = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextmanager
def replacing(path: Path, suffix: str = "", *, sync_folder: bool = False) -> Iterator[Path]:
    """Yield a temporary path to write ``path``'s new content to, by any writer that takes a
    path (PIL, ffmpeg). On a clean exit the file is synced and renamed over ``path``; on any
    exception (``KeyboardInterrupt`` too) it is removed and ``path`` is left as it was.
    ``sync_folder`` also syncs the folder, so the rename itself survives a power cut."""
    path = Path(path)
    tmp = temp_beside(path, suffix)
    try:
        yield tmp
        _fsync_file(tmp)
        os.replace(tmp, path)
        if sync_folder:
            _fsync_folder(path.parent)
    finally:
        tmp.unlink(missing_ok=True)


@contextmanager
def atomic_open(
    path: Path, mode: str = "w", *, newline: str | None = None, sync_folder: bool = False
) -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path`` for writing (``mode`` ``"w"`` or ``"wb"``);
    what was written replaces ``path`` only when the block ends without an exception."""
    if mode not in ("w", "wb"):
        raise ValueError(f"atomic_open: mode must be 'w' or 'wb', not {mode!r}")
    with replacing(path, sync_folder=sync_folder) as tmp:
        encoding = "utf-8" if mode == "w" else None
        with open(tmp, mode, newline=newline, encoding=encoding) as fh:
            yield fh
