"""The errors of recording and reading LeRobot datasets."""

from __future__ import annotations

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


class ExtraMissingError(MearmError):
    """pyarrow or PyAV, which recording needs, is not installed."""

    def __init__(self, module: str):
        self.module = module
        super().__init__(
            f"recording a dataset needs {module}, which is not installed: "
            "pip install 'mearm[record]'"
        )


class EncoderError(MearmError):
    """The process encoding a recording's video failed or stopped."""
