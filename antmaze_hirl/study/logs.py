"""The study's append-only logs, with a checksum on every line: what tells a torn or damaged record.

Formats (one record per line, appended and fsynced by :func:`~antmaze_hirl.atomic_io.durable_append`):

* JSON lines (``clicks.jsonl``, ``answers.jsonl``, ``events.jsonl``): each line is a JSON object whose
  last key is ``"crc32"``, the CRC-32 (8 lowercase hex digits) of the line's text without that key:
  ``{"a": 1}`` is written ``{"a": 1, "crc32": "<crc32 of '{"a": 1}'>"}``. The line stays plain JSON.
* CSV (``episodes.csv``): the header ends with a ``crc32`` column, and each row's last cell is the
  CRC-32 of the row's text before the comma that precedes it.

Readers (:func:`read_json_records`, :func:`read_csv_rows`):

* a partial last line (no final newline: a crash inside an append) is skipped with a warning that
  names the file and line; the server trims it on restart (:func:`~antmaze_hirl.atomic_io.trim_torn_tail`)
  and logs the trim as a ``torn_tail_trimmed`` event;
* any other bad line (checksum mismatch, not JSON, wrong number of cells, a line without a checksum
  after lines with one) is refused with :class:`DamagedLog`, whose message names the file and line.

Files written before checksums existed still load: JSON lines without ``crc32`` before the first line
that has one are read as they are, and a CSV whose header has no ``crc32`` column is read (and appended
to) without checksums. Such legacy lines are only as safe as they always were: a torn last line is still
found, a changed value is not.

Files written up to 0.2.0 name some keys otherwise: they read through
:func:`antmaze_hirl.experiments.old_folders.current_study_record`.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import os
import re
import warnings
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from antmaze_hirl.atomic_io import durable_append

CHECKSUM_FIELD = "crc32"
"""Name of the checksum key (JSON lines) and column (CSV)."""

_JSON_SEAL = re.compile(r'^(.*), "crc32": "([0-9a-f]{8})"}$', re.DOTALL)
_CSV_SEAL = re.compile(r"^(.*),([0-9a-f]{8})$", re.DOTALL)


class DamagedLog(ValueError):
    """A log line that is not what was written: the message names the file and the line number."""


def line_checksum(text: str) -> str:
    """CRC-32 of ``text`` (UTF-8) as 8 lowercase hex digits."""
    return f"{zlib.crc32(text.encode('utf-8')):08x}"


def sealed_json_line(record: Mapping[str, Any]) -> str:
    """``record`` as one JSON line ending with its checksum (and a newline).

    Raises:
        ValueError: If ``record`` is empty, has a ``crc32`` key, or holds NaN or infinity (not JSON).
    """
    if not record or CHECKSUM_FIELD in record:
        raise ValueError(f"a log record must be a non-empty object without a {CHECKSUM_FIELD!r} key")
    body = json.dumps(dict(record), allow_nan=False)
    return f'{body[:-1]}, "{CHECKSUM_FIELD}": "{line_checksum(body)}"}}\n'


def append_json_record(path: str | Path, record: Mapping[str, Any]) -> None:
    """Appends ``record`` to a JSON-lines log, with its checksum, durably (or not at all: :func:`append_or_undo`)."""
    append_or_undo(path, sealed_json_line(record))


def append_or_undo(path: str | Path, text: str) -> None:
    """Appends ``text`` durably, or, if that fails, cuts the file back to what it was and re-raises.

    A full disk can fail the append after some bytes reached the file (at flush or fsync): left there,
    they would be a torn or an unconfirmed line, and a retry would add it again. The cut is best effort
    (a cut needs no space); a file that did not exist is removed.

    Raises:
        OSError: The append's error (``ENOSPC``, ``EIO``...), after the cut.
    """
    path = Path(path)
    try:
        size: int | None = path.stat().st_size
    except FileNotFoundError:
        size = None
    try:
        durable_append(path, text)
    except BaseException:
        with contextlib.suppress(OSError):
            if size is None:
                path.unlink(missing_ok=True)
            else:
                os.truncate(path, size)
        raise


def append_csv_row(path: str | Path, columns: Sequence[str], row: Mapping[str, Any]) -> None:
    """Appends ``row`` to a CSV log, with its checksum, durably or not at all; a new file gets the header first.

    A legacy file (its header has no ``crc32`` column) gets legacy rows, so it stays one format; a file
    whose header is an older, shorter prefix of ``columns`` (columns added since) gets rows of its own columns.
    """
    path = Path(path)
    sealed = True
    if path.exists() and path.stat().st_size:
        with path.open(encoding="utf-8", newline="") as handle:
            header = next(csv.reader([handle.readline()]), [])
        sealed = bool(header) and header[-1] == CHECKSUM_FIELD
        own = header[:-1] if sealed else header
        if 0 < len(own) < len(columns) and list(columns[: len(own)]) == own:
            columns = own  # written before the later columns existed: it stays as it was
        text = ""
    else:
        text = _csv_text([*columns, CHECKSUM_FIELD]) + "\n"
    body = _csv_text([csv_cell(row.get(column, "")) for column in columns])
    text += f"{body},{line_checksum(body)}\n" if sealed else body + "\n"
    append_or_undo(path, text)


def csv_cell(value: Any) -> str:
    """A value as :func:`append_csv_row` writes it (``None`` as an empty cell)."""
    return "" if value is None else str(value)


def _csv_text(cells: Sequence[str]) -> str:
    buffer = io.StringIO()
    csv.writer(buffer, lineterminator="").writerow(cells)
    return buffer.getvalue()


def _lines(path: Path) -> list[tuple[int, str]]:
    """``(number, text)`` of the file's complete lines; a torn last line is dropped with a warning."""
    text = path.read_bytes().decode("utf-8", errors="replace")
    lines = text.split("\n")
    tail = lines.pop()  # "" when the file ends with a newline
    if tail:
        warnings.warn(
            f"{path}:{len(lines) + 1}: skipped a partial last line ({len(tail)} characters, no newline): "
            "an append was cut off",
            stacklevel=3,
        )
    return [(number, line.removesuffix("\r")) for number, line in enumerate(lines, start=1)]


def read_json_records(path: str | Path) -> list[tuple[int, dict[str, Any]]]:
    """The records of a JSON-lines log as ``(line number, record)``, checksums verified and removed.

    Blank lines are skipped; a torn last line is skipped with a warning (see the module docs).

    Raises:
        DamagedLog: For a line that fails its checksum, is not a JSON object, or repeats an earlier line exactly
            (names file and line).
    """
    path = Path(path)
    records, sealed_seen, seen = [], False, {}
    for number, line in _lines(path):
        if not line.strip():
            continue
        where = f"{path}:{number}"
        if line in seen:  # every record has a time or an id: an exact repeat is a copied line
            raise DamagedLog(f"{where}: repeats line {seen[line]} exactly: a copied or replayed line")
        seen[line] = number
        match = _JSON_SEAL.match(line)
        if match is not None:
            body, checksum = match.group(1) + "}", match.group(2)
            if line_checksum(body) != checksum:
                raise DamagedLog(f"{where}: checksum mismatch: the line was changed or damaged after it was written")
            sealed_seen = True
        elif sealed_seen:
            raise DamagedLog(f"{where}: the line has no checksum, but the lines before it have: damaged")
        else:
            body = line  # a legacy line, from before checksums
        try:
            record = json.loads(body)
        except ValueError as error:
            raise DamagedLog(f"{where}: not JSON ({error})") from None
        if not isinstance(record, dict):
            raise DamagedLog(f"{where}: expected a JSON object, got {type(record).__name__}")
        records.append((number, record))
    return records


def read_csv_rows(path: str | Path, columns: Sequence[str], added: Sequence[str] = ()) -> list[dict[str, str]]:
    """The rows of a CSV log as dicts of strings, checksums verified and the ``crc32`` column removed.

    An empty file has no rows. A torn last line is skipped with a warning (see the module docs).
    ``added`` names trailing columns of ``columns`` that files written before them lack: such a file is
    read with those cells empty.

    Raises:
        DamagedLog: For a header other than ``columns`` (with or without ``crc32``), or a row that fails
            its checksum or has another number of cells (names file and line).
    """
    path = Path(path)
    lines = _lines(path)
    if not lines:
        return []
    (_, header_line), rows = lines[0], lines[1:]
    header = next(csv.reader([header_line]), [])
    full = list(columns)
    for count in range(len(added) + 1):  # the header of this version, then of the versions before each addition
        own = full[: len(full) - count]
        if header in (own, [*own, CHECKSUM_FIELD]) and columns[len(own) :] == tuple(added[len(added) - count :]):
            columns = own
            break
    if header == [*columns, CHECKSUM_FIELD]:
        sealed = True
    elif header == list(columns):
        sealed = False  # a legacy file, from before checksums
    else:
        raise DamagedLog(f"{path}:1: columns {header}; expected {[*columns, CHECKSUM_FIELD]}")
    result = []
    for number, line in rows:
        where = f"{path}:{number}"
        body = line
        if sealed:
            match = _CSV_SEAL.match(line)
            if match is None or line_checksum(match.group(1)) != match.group(2):
                raise DamagedLog(f"{where}: checksum mismatch: the row was changed or damaged after it was written")
            body = match.group(1)
        cells = next(csv.reader([body]), [])
        if len(cells) != len(columns):
            raise DamagedLog(f"{where}: {len(cells)} cells; expected {len(columns)}")
        result.append({**dict.fromkeys(full, ""), **dict(zip(columns, cells, strict=True))})
    return result
