"""The virtual Uno's one error: it cannot be built or started."""

from __future__ import annotations

from collections.abc import Sequence

from mearm.errors import MearmError


class VirtualUnoError(MearmError):
    """The virtual Uno cannot be built or started.

    Attributes:
        packages: The Debian packages that would provide what is missing (empty when
            something else failed).
    """

    def __init__(self, message: str, packages: Sequence[str] = ()):
        self.packages = tuple(packages)
        super().__init__(f"virtual Uno: {message}")
