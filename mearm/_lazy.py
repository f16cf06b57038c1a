"""Lazy public names of a package: imported from their module on first use (PEP 562).

A package lists ``name → module`` and gets a module ``__getattr__`` that imports the
module the first time the name is asked for (and keeps it), and a ``__dir__`` that lists
its ``__all__``; a run imports only the parts it uses.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping, Sequence
from typing import Any


def lazy_exports(
    package: str, lazy: Mapping[str, str], namespace: dict[str, Any], public: Sequence[str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package`` whose ``lazy`` names live in other modules.

    Args:
        package: The package's name (for the error message).
        lazy: Each lazy name and the module that defines it.
        namespace: The package's ``globals()``: a name, once imported, is kept there.
        public: The package's ``__all__``.
    """

    def __getattr__(name: str) -> Any:
        module = lazy.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return list(public)

    return __getattr__, __dir__
