"""The environments' errors."""

from __future__ import annotations

from mearm.errors import MearmError


class EnvOptionError(MearmError, ValueError):
    """An environment option out of range, unknown, or a config that is not the twin's."""


class PolicyError(MearmError):
    """A policy that cannot be loaded, or whose action is not one the environment takes."""
