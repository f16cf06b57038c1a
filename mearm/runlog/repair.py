"""A log whose writer was killed mid-line: :func:`find_torn_end`, :func:`set_aside_torn_end`.

The writer puts each record on disk as one line in one ``write``; a process killed
during that write (or a full disk) can leave the file ending in part of a line. The
reader stops there (:func:`~mearm.runlog.read_runlog`) and :class:`~mearm.runlog.RunLog`
refuses to append after it, since the next record would be read as the rest of the
broken line.

Before a run continues such a log (``mearm experiment`` resuming its ``--log``), the torn
end is *set aside*: its bytes are written to ``<log>.torn-<offset>`` beside the log (in
one step, ``fsync``-ed), and only then cut from the log, which again ends after its last
whole line. Nothing written is lost — the side file keeps the fragment — and a crash
between the two steps leaves the same torn end, which the next resume sets aside again
into the same side file. A last line that is a whole record missing only its newline is
not torn: :func:`end_line` adds the newline.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from mearm.fileio import write_atomic
from mearm.runlog.errors import RunLogError

_CHUNK = 1 << 16


@dataclass(frozen=True)
class TornEnd:
    """The end of a log after its last newline.

    Attributes:
        offset: Where the unfinished line starts [bytes from the start of the file].
        line: Its line number (from 1).
        data: Its bytes.
    """

    offset: int
    line: int
    data: bytes


def find_torn_end(path: str | Path) -> TornEnd | None:
    """The bytes after the last newline of ``path``, or ``None`` when it ends in one.

    Raises:
        RunLogError: The file cannot be read.
    """
    p = Path(path)
    try:
        with p.open("rb") as f:
            newlines = 0
            last_newline = -1
            offset = 0
            while chunk := f.read(_CHUNK):
                count = chunk.count(b"\n")
                if count:
                    newlines += count
                    last_newline = offset + chunk.rindex(b"\n")
                offset += len(chunk)
            if offset == last_newline + 1:
                return None
            f.seek(last_newline + 1)
            data = f.read()
    except OSError as exc:
        raise RunLogError(p, f"cannot read: {exc}") from None
    return TornEnd(offset=last_newline + 1, line=newlines + 1, data=data)


def set_aside_torn_end(path: str | Path, torn: TornEnd) -> Path:
    """Move the torn end into a side file, then cut it from the log.

    Args:
        path: The log.
        torn: What :func:`find_torn_end` found in it (checked again before the cut).

    Returns:
        The side file, ``<log>.torn-<offset>`` (``-2``, ``-3``, … if that name holds
        other bytes).

    Raises:
        RunLogError: The side file cannot be written, or the log changed meanwhile or
            cannot be cut; the log is then as it was.
    """
    p = Path(path)
    side = _side_file(p, torn)
    try:
        write_atomic(side, torn.data)
        with p.open("r+b") as f:
            f.seek(torn.offset)
            if f.read() != torn.data:
                raise RunLogError(p, "changed while its torn last line was being set aside")
            f.truncate(torn.offset)
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:
        raise RunLogError(p, f"cannot set its torn last line aside: {exc}") from None
    return side


def end_line(path: str | Path) -> None:
    """Add the newline a whole last record is missing.

    Raises:
        RunLogError: The file cannot be written.
    """
    p = Path(path)
    try:
        with p.open("ab") as f:
            f.write(b"\n")
            f.flush()
            os.fsync(f.fileno())
    except OSError as exc:
        raise RunLogError(p, f"cannot end its last line: {exc}") from None


def _side_file(path: Path, torn: TornEnd) -> Path:
    base = path.with_name(f"{path.name}.torn-{torn.offset}")
    side, n = base, 1
    while side.exists() and (not side.is_file() or side.read_bytes() != torn.data):
        n += 1
        side = base.with_name(f"{base.name}-{n}")
    return side
