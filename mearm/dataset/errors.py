"""The errors of recording and reading LeRobot datasets."""

from __future__ import annotations

import errno
import os
from pathlib import Path

from mearm.errors import MearmError


class DatasetError(MearmError):
    """A dataset directory cannot be recorded into or read.

    Attributes:
        path: The dataset's directory (or the file in it that is at fault).
    """

    def __init__(self, path: Path, message: str):
        self.path = path
        super().__init__(f"{path}: {message}")


class DatasetExistsError(DatasetError):
    """A non-empty directory given to record into without ``--resume``."""

    def __init__(self, path: Path):
        super().__init__(
            path,
            "is not empty: pass --resume to append episodes to the dataset there, or give "
            "a new or empty directory",
        )


#: A write failure's errno in the words a user looks for (the system's follow them).
_WRITE_FAILURES = {
    errno.ENOSPC: "disk full",
    errno.EDQUOT: "disk quota exceeded",
    errno.EFBIG: "file too large for this file system or process",
}


class DatasetWriteError(DatasetError):
    """A file of the dataset being recorded could not be written (a full disk, mostly).

    Not bad input: the recording failed while it ran. The episodes written before stay
    whole (each is written whole or not at all); the one being written is dropped.

    Attributes:
        path: The file that could not be written.
        errno: The system's error number (``errno.ENOSPC`` for a full disk), or ``None``.
    """

    exit_status = 1  # the run failed; the input was good

    def __init__(self, path: Path, errno_: int | None, detail: str, *, kept: int):
        self.errno = errno_
        reason = _WRITE_FAILURES.get(errno_) if errno_ is not None else None
        what = f"{reason} ({detail})" if reason else detail
        after = (
            f"the dataset keeps the {kept} episode{'' if kept == 1 else 's'} written before"
            if kept
            else "nothing was recorded"
        )
        super().__init__(path, f"cannot be written: {what}; recording stopped, {after}")

    @classmethod
    def of(cls, path: Path, exc: OSError, *, kept: int, why: str = "") -> DatasetWriteError:
        """The error of ``exc``, raised writing ``path`` (its own file name, if it has one).

        ``why``: what the file is for, said after the system's words (a file outside the
        dataset, such as the encoder's shared memory).
        """
        where = Path(exc.filename) if exc.filename else path
        # the system's words for the number (pyarrow's strerror wraps them in its own)
        detail = (os.strerror(exc.errno) if exc.errno else " ".join(str(exc).split())) or type(
            exc
        ).__name__
        return cls(where, exc.errno, f"{detail}; {why}" if why else detail, kept=kept)


class ExtraMissingError(MearmError):
    """pyarrow or PyAV, which recording or reading a dataset needs, is not installed."""

    def __init__(self, module: str):
        self.module = module
        super().__init__(
            f"recording or reading a dataset needs {module}, which is not installed: "
            "pip install 'mearm[record]'"
        )


class EncoderError(MearmError):
    """The process encoding a recording's video failed or stopped."""

    exit_status = 1  # a failure of the run: what was asked for was good
