"""Crash-safe file writes: a temp file in the target folder, fsync, then an atomic rename."""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any


def atomic_write_with(path: str | Path, write: Callable[[Path], object]) -> Path:
    """Lets ``write(tmp)`` fill a temp file beside ``path``, then renames it over ``path`` atomically.

    Readers see the old file or the new one, never a partial one; the temp file is fsynced before the
    rename (durable across a power cut) and removed if ``write`` fails. Each call gets its own temp
    name, so concurrent writers of one path never clobber each other's half-written files.

    Args:
        path: The file to (re)place.
        write: Writes the whole new content to the path it is given (e.g. ``model.save``).

    Returns:
        ``path``.

    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}")
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600 files; give the usual permissions
        write(tmp)
        fsync_path(tmp)
        os.replace(tmp, path)
        fsync_path(path.parent)  # the rename itself is durable only once the folder's entry is on disk
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def fsync_path(path: str | Path) -> None:
    """Flushes a file's content, or a folder's entries (renames, new files), to disk."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    """Writes ``data`` to ``path`` atomically (see :func:`atomic_write_with`)."""
    return atomic_write_with(path, lambda tmp: tmp.write_bytes(data))


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> Path:
    """Writes ``text`` (UTF-8) to ``path`` atomically (see :func:`atomic_write_with`)."""
    return atomic_write_bytes(path, text.encode())


def atomic_write_json(path: str | Path, data: Any, *, allow_nan: bool = True) -> Path:
    """Writes ``data`` as indented JSON, atomically (see :func:`atomic_write_with`).

    Args:
        path: The file to (re)place.
        data: JSON-ready data.
        allow_nan: ``False`` refuses NaN and infinity, which are not JSON (Python writes ``NaN``,
            which strict readers reject); the file is then left as it was.

    Raises:
        ValueError: With ``allow_nan=False``, for a non-finite float (names the file).
    """
    try:
        text = json.dumps(data, indent=2, allow_nan=allow_nan)
    except ValueError as error:
        raise ValueError(f"{path}: {error} (NaN and Infinity are not JSON)") from None
    return atomic_write_text(path, text + "\n")


def durable_append(path: str | Path, text: str) -> Path:
    """Appends ``text`` (UTF-8) to ``path`` and fsyncs it before returning.

    For logs written as events happen (a study's clicks and answers): once this returns, the line
    survives a ``kill -9`` or a power cut. A crash mid-call can leave at most a partial last line
    (no final newline): :func:`trim_torn_tail` cuts it off before the next append, and the readers in
    :mod:`antmaze_hirl.study.logs` skip it with a warning. A new file's folder entry is fsynced too.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not path.exists()
    with path.open("a", encoding="utf-8") as handle:
        handle.write(text)
        handle.flush()
        os.fsync(handle.fileno())
    if new:
        fsync_path(path.parent)
    return path


def trim_torn_tail(path: str | Path) -> bytes:
    """Cuts a partial last line (the bytes after the last newline) off ``path``, durably.

    A crash inside :func:`durable_append` can leave such a tail; appending after it would glue the
    next record onto it. Call this before appending to a log that a crash may have torn.

    Returns:
        The bytes removed (``b""`` when the file is missing, empty or ends with a newline), so that
        the caller can log what was cut.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        return b""
    if size == 0:
        return b""
    with path.open("r+b") as handle:
        handle.seek(size - 1)
        if handle.read(1) == b"\n":
            return b""
        # Read back from the end in blocks until a newline (logs are small; a block is usually enough).
        end, tail = size, b""
        while end > 0:
            start = max(end - 65_536, 0)
            handle.seek(start)
            block = handle.read(end - start)
            cut = block.rfind(b"\n")
            if cut >= 0:
                tail = block[cut + 1 :] + tail
                break
            tail = block + tail
            end = start
        handle.truncate(size - len(tail))
        handle.flush()
        os.fsync(handle.fileno())
    return tail
