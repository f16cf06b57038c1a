"""The package's modules, read and parsed once per test process, for the tests that scan them.

Several tests check the whole package's syntax (one fact, one home; one class name, one
meaning). A parse of its ~280 modules costs about 1.2 s of CPU: each scan parsing them again
paid it four times in one file alone. Parsed once per process (an xdist worker runs many
of these tests), the scans share the trees, which they only read.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parent.parent


class Module(NamedTuple):
    """One module of the package: its path, as from the checkout's root, and its syntax."""

    path: Path
    where: str
    """``mearm/kinematics/chain.py``."""
    source: str
    tree: ast.Module
    """Shared by every scan in the process: read it, never change it."""


@functools.cache
def package_modules() -> tuple[Module, ...]:
    """Every ``.py`` file under ``mearm/``, in path order, parsed."""
    out = []
    for path in sorted((ROOT / "mearm").rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        out.append(Module(path, path.relative_to(ROOT).as_posix(), source, ast.parse(source)))
    return tuple(out)


def syntax(source: str | ast.Module) -> ast.Module:
    """``source`` parsed, or the tree itself (a scan takes either)."""
    return source if isinstance(source, ast.Module) else ast.parse(source)
