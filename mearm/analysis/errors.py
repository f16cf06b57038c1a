"""Errors of run-log analysis."""

from __future__ import annotations

from mearm.errors import MearmError


class AnalysisError(MearmError):
    """The data cannot be analysed as asked (no routes, too few errors to fit, ...)."""
