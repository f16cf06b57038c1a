"""Runs recorded as LeRobotDataset v3.0 datasets (``--record``), checked and shown.

Needs the ``record`` extra (pyarrow, PyAV); imported only by a run that records or by
``mearm dataset``.
"""

from __future__ import annotations

from mearm._lazy import lazy_exports

__all__ = [
    "DatasetError",
    "DatasetExistsError",
    "DatasetRecorder",
    "DatasetWriteError",
    "check_dataset",
]

_LAZY = {
    "DatasetError": "mearm.dataset.errors",
    "DatasetExistsError": "mearm.dataset.errors",
    "DatasetRecorder": "mearm.dataset.recorder",
    "DatasetWriteError": "mearm.dataset.errors",
    "check_dataset": "mearm.dataset.format_check",
}

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
