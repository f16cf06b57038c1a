"""One name, one meaning: no two modules of the package share a name, nor two classes.

``mearm.config.twin_camera`` beside ``mearm.sim.twin.twin_camera`` (the camera's settings and
the camera), or two ``Outcome`` classes (a sort's counts and an IK recovery's result),
make a reader open the file to learn which one an import means.
"""

from __future__ import annotations

import ast
from collections import defaultdict

import pytest
from conftest import ROOT
from package_source import package_modules

PACKAGE = ROOT / "mearm"

#: Module names that mean the same thing wherever they stand.
SHARED_MODULE_NAMES = {
    "__init__",  # a package
    "__main__",  # a package's command (python -m)
    "errors",  # a package's family of errors, all under mearm.errors.MearmError
}


def _modules() -> list[tuple[str, str]]:
    """(name, where) for every module and package of mearm: ``collision`` → its path."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        where = str(path.relative_to(ROOT))
        out.append((path.stem, where))
        if path.name == "__init__.py" and path.parent != PACKAGE:
            out.append((path.parent.name, where))
    return out


def test_no_two_modules_share_a_name():
    """Each module or package name, but the shared few, is used once in the package."""
    places = defaultdict(list)
    for name, where in _modules():
        if name not in SHARED_MODULE_NAMES:
            places[name].append(where)
    assert {n: w for n, w in places.items() if len(w) > 1} == {}


@pytest.mark.heavy
def test_no_two_classes_share_a_name():
    """Each class name (exceptions, records, protocols, nested ones too) is defined once."""
    places = defaultdict(list)
    for module in package_modules():
        for node in ast.walk(module.tree):
            if isinstance(node, ast.ClassDef):
                places[node.name].append(f"{module.where}:{node.lineno}")
    assert {n: w for n, w in places.items() if len(w) > 1} == {}
