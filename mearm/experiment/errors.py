"""The experiment's own error, and how an exception reads on one line."""

from __future__ import annotations

from mearm.errors import MearmError


class TrialFailed(MearmError):
    """A trial run by a worker failed on its camera or servos (the log holds it)."""


def one_line(exc: BaseException) -> str:
    """``exc``'s message on one line (its type's name when it has none)."""
    return " ".join(str(exc).split()) or type(exc).__name__
