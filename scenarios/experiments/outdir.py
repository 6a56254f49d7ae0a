"""Output folders written as a whole: checked before the run, staged, locked, swapped in.

A command that writes a folder of results (``mrta run``, ``reproduce``, ``compare``) works in a
hidden sibling, ``.<name>.partial``, and renames it into place only when every file is written:
a failed or interrupted run leaves the previous folder exactly as it was, never a mix of old and
new files. With a checkpoint the staging folder is kept on failure (it holds the checkpoint
``--resume`` continues from) and is found again by the next run. A lock file beside the folder,
``.<name>.lock``, holding the writer's process id and host, stops a second command writing the
same folder (a lock left by a process that no longer runs is taken over).

Problems with the path itself (an empty name, a file where the folder should be, a file above
it, no permission, a symbolic-link loop) are found before any work: :func:`check_out_dir`
raises :class:`OutputError`, one line naming the path.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import socket
from collections.abc import Iterator
from pathlib import Path


class OutputError(ValueError):
    """An output path that cannot be written; ``str(err)`` is one line naming it."""


def check_out_dir(out: Path | str, option: str = "--out") -> Path:
    """``out`` as a folder this process can create or replace, or OutputError.

    Args:
        out: the folder a command will write.
        option: how the user gave it (named in the message).
    """
    if str(out).strip() == "":
        raise OutputError(f"{option} '': an empty path names no folder")
    out = Path(out)
    try:
        full = out.resolve(strict=False)
    except (RuntimeError, OSError) as exc:  # a symbolic-link loop
        raise OutputError(f"{option} {out}: cannot be resolved ({exc})") from None
    here = Path.cwd().resolve()
    if full == here or full in here.parents:
        raise OutputError(
            f"{option} {out}: the folder you are in (or one above it) cannot be replaced"
        )
    if out.is_file() or (out.exists() and not out.is_dir()):
        raise OutputError(f"{option} {out}: is a file, not a folder")
    above = out.parent
    while not above.exists():
        above = above.parent
    if not above.is_dir():
        raise OutputError(f"{option} {out}: {above} is a file, so no folder can be made under it")
    if not os.access(above, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {out}: {above} is not writable")
    if out.is_dir() and not os.access(out, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {out}: the folder is not writable")
    return out


def check_out_file(path: Path | str, option: str) -> Path:
    """``path`` as a file this process can write (its folder exists and is writable; it is not
    a folder), or OutputError naming ``option``."""
    if str(path).strip() == "":
        raise OutputError(f"{option} '': an empty path names no file")
    path = Path(path)
    if path.is_dir():
        raise OutputError(f"{option} {path}: is a folder, not a file")
    if not path.parent.is_dir():
        raise OutputError(f"{option} {path}: the folder {path.parent} does not exist")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise OutputError(f"{option} {path}: the folder {path.parent} is not writable")
    return path


def staging_dir(out: Path) -> Path:
    """Where a command writes ``out``'s files before they are renamed into place."""
    return out.parent / f".{out.name}.partial"


def lock_path(out: Path) -> Path:
    """The lock file of ``out``."""
    return out.parent / f".{out.name}.lock"


@contextlib.contextmanager
def folder_lock(out: Path) -> Iterator[None]:
    """Hold ``out``'s lock while the block runs; OutputError if another live process holds it."""
    lock = lock_path(out)
    lock.parent.mkdir(parents=True, exist_ok=True)
    me = f"{os.getpid()} {socket.gethostname()}\n"
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            holder = _holder(lock)
            if holder is not None:
                raise OutputError(
                    f"{out}: another mrta run ({holder}) is writing this folder; "
                    f"wait for it, or remove {lock} if it is gone"
                ) from None
            lock.unlink(missing_ok=True)  # left by a process that no longer runs
            continue
        with os.fdopen(fd, "w") as fh:
            fh.write(me)
        break
    else:  # pragma: no cover - two processes taking over the same stale lock at once
        raise OutputError(f"{out}: could not take the lock {lock}")
    try:
        yield
    finally:
        lock.unlink(missing_ok=True)


def _holder(lock: Path) -> str | None:
    """'pid N on HOST' of a live lock holder, or None if the lock is stale or unreadable."""
    try:
        pid_text, _, host = lock.read_text().strip().partition(" ")
        pid = int(pid_text)
    except (OSError, ValueError):
        return None
    if host and host != socket.gethostname():
        return f"pid {pid} on {host}"  # another machine: cannot tell, so it holds
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return None
    except PermissionError:
        pass
    return f"pid {pid}"


@contextlib.contextmanager
def staged_folder(
    out: Path, *, keep_on_failure: bool = False, fresh: bool = True
) -> Iterator[Path]:
    """Yield the staging folder to write ``out``'s files in; rename it into place on success.

    The block runs under ``out``'s lock. On success the old ``out`` (if any) is swapped out and
    removed, so ``out`` holds exactly the new files. On any exception (``KeyboardInterrupt``
    too) ``out`` is untouched and the staging folder is removed, or kept when
    ``keep_on_failure`` (it holds a checkpoint to resume from).

    Args:
        out: the folder the command writes (checked with :func:`check_out_dir` first).
        keep_on_failure: leave the staging folder behind on failure (it holds a checkpoint).
        fresh: start from an empty staging folder; False keeps what an earlier, interrupted
            run left there (its checkpoint, to resume from).
    """
    out = Path(out)
    stage = staging_dir(out)
    with folder_lock(out):
        if stage.exists() and fresh:
            shutil.rmtree(stage)
        stage.mkdir(parents=True, exist_ok=True)
        try:
            yield stage
        except BaseException:
            if not keep_on_failure:
                shutil.rmtree(stage, ignore_errors=True)
            raise
        swap_in(stage, out)


def swap_in(stage: Path, out: Path) -> None:
    """Replace folder ``out`` by ``stage`` (two renames on one file system; the old folder is
    removed after)."""
    old = out.parent / f".{out.name}.old.{os.getpid()}"
    if out.exists():
        os.replace(out, old)
    try:
        os.replace(stage, out)
    except OSError:
        if old.exists():
            os.replace(old, out)  # put the previous output back
        raise
    shutil.rmtree(old, ignore_errors=True)
    with contextlib.suppress(OSError):
        fd = os.open(out.parent, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def os_error_line(exc: OSError) -> str:
    """One line for a file-system error: the path and what went wrong."""
    where = exc.filename or ""
    if exc.errno == errno.ENOSPC:
        what = "no space left on the device"
    elif exc.errno == errno.EROFS:
        what = "read-only file system"
    elif exc.errno == errno.ELOOP:
        what = "too many symbolic links (a loop?)"
    else:
        what = exc.strerror or str(exc)
    return f"{where}: {what}" if where else what
