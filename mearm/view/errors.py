"""Errors of the meshcat view and its headless screenshots."""

from __future__ import annotations

from mearm.errors import MearmError


class ViewError(MearmError):
    """The meshcat view cannot be started, updated or rendered."""


class ViewPortError(ViewError):
    """The view's web port cannot be used.

    Attributes:
        port: The port asked for.
        reason: Why it cannot be used (usually "Address already in use").
    """

    def __init__(self, port: int, reason: str):
        self.port = port
        self.reason = reason
        super().__init__(
            f"port {port} on 127.0.0.1: {reason}; choose another port or leave it unset "
            "to take the first free one from 7000"
        )


class ViewInputError(ViewError):
    """A value given to the view has the wrong shape, type or range.

    Attributes:
        argument: The argument's name, e.g. ``"q_rad"``.
        value: A short repr of the value given.
        allowed: What is allowed.
    """

    def __init__(self, argument: str, value: object, allowed: str):
        self.argument = argument
        text = repr(value)
        self.value = text if len(text) <= 80 else text[:77] + "..."
        self.allowed = allowed
        super().__init__(f"{argument} = {self.value}: expected {allowed}")


class BrowserNotFoundError(ViewError):
    """No Chromium-family browser to render the view headlessly.

    Attributes:
        candidates: The executable names looked up on PATH.
    """

    def __init__(self, candidates: tuple[str, ...]):
        self.candidates = tuple(candidates)
        super().__init__(
            f"no headless browser found (looked for {', '.join(self.candidates)} on PATH, "
            "and $MEARM_CHROMIUM); install one, e.g. `apt-get install chromium`"
        )
