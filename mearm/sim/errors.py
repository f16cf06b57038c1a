"""The simulators' shared error: a change of the simulated table that cannot happen."""

from __future__ import annotations

from mearm.errors import MearmError


class WorldError(MearmError):
    """An impossible change of the simulated world, e.g. releasing when nothing is held."""


__all__ = ["WorldError"]
