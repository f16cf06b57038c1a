"""Errors of the meshcat view and its headless screenshots.

What the caller gave or has (a value out of range, a port in use, no browser installed,
a view already closed) is bad input: exit 2, as every :class:`ViewError`. What fails
while the view runs (a browser that crashes or stops answering, a scene that is never
drawn, a server that does not reply, a disk that fills) is :class:`ViewRunError`: exit 1.
"""

from __future__ import annotations

from mearm.errors import MearmError


class ViewError(MearmError):
    """The meshcat view cannot be started, updated or rendered as asked."""


class ViewRunError(ViewError):
    """The view failed while it ran; what it was given was good.

    A browser that exits or stops answering, a scene not drawn or a meshcat server that
    does not reply within the timeout, a PNG the disk has no room for. Running the
    same command again may succeed; changing it is not what is needed.
    """

    exit_status = 1  # the run failed; the input was good


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
        from_env: Whether the one candidate is ``$MEARM_CHROMIUM``'s, found nowhere.
    """

    def __init__(self, candidates: tuple[str, ...], *, from_env: bool = False):
        self.candidates = tuple(candidates)
        self.from_env = from_env
        if from_env:
            message = (
                f"$MEARM_CHROMIUM = {self.candidates[0]!r}: no such executable (give a "
                "browser's path or a name on PATH, or unset it to use chromium from PATH)"
            )
        else:
            message = (
                f"no headless browser found (looked for {', '.join(self.candidates)} on "
                "PATH; $MEARM_CHROMIUM unset); install one, e.g. `apt-get install chromium`"
            )
        super().__init__(message)
