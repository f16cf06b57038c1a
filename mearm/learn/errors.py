"""The baseline's errors, and the one place PyTorch is imported."""

from __future__ import annotations

from typing import Any

from mearm.errors import MearmError


class LearnExtraMissingError(MearmError):
    """PyTorch, which the learned baseline needs, is not installed."""

    def __init__(self) -> None:
        super().__init__(
            "a learned policy needs PyTorch, which is not installed: pip install 'mearm[learn]'"
        )


class DemosError(MearmError):
    """A ``--demos`` file that cannot be read, or was collected for another run."""


def import_torch() -> Any:
    """``torch``, or a one-line error naming the extra.

    Raises:
        LearnExtraMissingError: PyTorch is not installed.
    """
    try:
        import torch
    except ImportError:
        raise LearnExtraMissingError from None
    return torch
