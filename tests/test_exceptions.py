"""Errors by family: each next to the code that raises it, all named by mearm.exceptions."""

from __future__ import annotations

import ast
import importlib
import inspect
import subprocess
import sys

import pytest
from conftest import ROOT
from package_source import package_modules

import mearm
from mearm import exceptions
from mearm.errors import MearmError

PACKAGE = ROOT / "mearm"
#: Commands: their own errors (a refused key, an abandoned calibration) stay theirs.
COMMANDS = ("mearm.maker", "mearm.tools", "mearm.sort", "mearm.detect", "mearm.fk")


def _module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _library_errors() -> dict[str, str]:
    """Every ``MearmError`` subclass a module below the commands defines: name → module."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        name = _module_name(path)
        if name.rpartition(".")[2] == "__main__" or name.startswith(COMMANDS):
            continue
        if "class " not in path.read_text(encoding="utf-8"):
            continue
        module = importlib.import_module(name)
        for attr, value in vars(module).items():
            if (
                inspect.isclass(value)
                and issubclass(value, MearmError)
                and value.__module__ == name
                and not attr.startswith("_")
            ):
                found[attr] = name
    return found


def test_the_facade_names_every_error_of_the_library_at_its_home():
    """Each public error is in ``mearm.exceptions.__all__``, mapped to the module that
    defines it, and ``from mearm.exceptions import X`` gives that very class."""
    defined = _library_errors()
    mapped = {name: module for module, names in exceptions.FAMILIES.items() for name in names}
    assert mapped == defined
    assert sorted(exceptions.__all__) == sorted(defined)
    for name, module in defined.items():
        assert getattr(exceptions, name) is getattr(importlib.import_module(module), name)


def test_every_error_is_a_mearm_error_and_the_top_level_names_them_too():
    """One ``except MearmError`` catches them all; ``mearm.X`` is the same class."""
    for name in exceptions.__all__:
        error = getattr(exceptions, name)
        assert issubclass(error, MearmError), name
        assert getattr(mearm, name) is error
        assert name in mearm.__all__


@pytest.mark.heavy
def test_no_module_of_the_package_imports_the_facade():
    """Inside the package an error comes from its family: the façade names errors of every
    layer, so a lower layer importing it would reach up (only the package root may)."""
    offenders = []
    for module in package_modules():  # parsed once per process for every scan
        path = module.path
        if path in (PACKAGE / "__init__.py", PACKAGE / "exceptions.py"):
            continue
        for node in ast.walk(module.tree):
            names = (
                [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else []
            )
            if "mearm.exceptions" in names or (
                isinstance(node, ast.ImportFrom)
                and node.module == "mearm"
                and any(a.name == "exceptions" for a in node.names)
            ):
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert offenders == []


def test_one_error_loads_only_its_family():
    """``import mearm`` and catching a config error load neither NumPy nor the simulator
    nor SciPy (the analysis extra): a family is imported when one of its errors is."""
    code = (
        "import sys, mearm\n"
        "from mearm.exceptions import ConfigError, MearmError\n"
        "assert issubclass(ConfigError, MearmError)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in "
        "('numpy', 'scipy', 'pydantic') or m.startswith('mearm.')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT
    ).stdout
    assert out.strip() == "['mearm._lazy', 'mearm.errors', 'mearm.exceptions']"


def test_an_unknown_name_is_an_attribute_error():
    """A name the façade does not have is refused as any module refuses it."""
    with pytest.raises(AttributeError, match="has no attribute 'NoSuchError'"):
        exceptions.NoSuchError  # noqa: B018


def _in_commands(name: str) -> bool:
    return name.rpartition(".")[2] == "__main__" or name.startswith(COMMANDS)


def test_the_commands_errors_stay_with_the_commands():
    """docs/development.md: the commands' own errors (not in the façade) stay with them.

    Each ``MearmError`` subclass a command module defines is named by no module of the
    library (a command's work handed to the library turns its error into the library's,
    as the servos' calibration at a sort's start does): so no library call raises one
    and the façade, which names the library's, names every error code using mearm meets.
    """
    known = {"MearmError", *exceptions.__all__}
    commands = [m for m in package_modules() if _in_commands(_module_name(m.path))]
    found: set[str] = set()
    for _ in range(3):  # subclasses of subclasses
        for module in commands:
            for node in ast.walk(module.tree):
                if isinstance(node, ast.ClassDef) and any(
                    (b.id if isinstance(b, ast.Name) else getattr(b, "attr", "")) in known | found
                    for b in node.bases
                ):
                    found.add(node.name)
    found -= known
    assert {"NoBoardFound", "Refused", "CameraCalibrationFailed", "StepFailed"} <= found
    offenders = []
    for module in package_modules():
        name = _module_name(module.path)
        if _in_commands(name) or name in ("mearm", "mearm.exceptions"):
            continue
        for node in ast.walk(module.tree):
            used = (
                node.id
                if isinstance(node, ast.Name)
                else node.attr
                if isinstance(node, ast.Attribute)
                else None
            )
            aliases = [a.name for a in node.names] if isinstance(node, ast.ImportFrom) else []
            if used in found or found.intersection(aliases):
                offenders.append(f"{module.where}:{node.lineno}")
    assert offenders == []


def _raise_in_worker(error: MearmError) -> None:
    raise error


@pytest.mark.parametrize(
    "error",
    [
        "mearm.dataset.errors:ExtraMissingError('PyAV (av)')",
        "mearm.errors:ConfigError('a.yaml', ['arm.joints: an empty list; give one or more'])",
    ],
    ids=["extra-missing", "config"],
)
def test_an_error_raised_in_a_worker_process_reaches_the_parent_as_raised(error):
    """A worker's error is pickled back to the parent (``eval-policy --jobs 2``): the same
    class, message and attributes. Pickled as ``Exception`` does, the class called on its
    message, the missing extra's sentence came back said twice, and a ``ConfigError``
    did not come back at all (its ``__init__`` takes two arguments)."""
    import concurrent.futures

    module, _, call = error.partition(":")
    raised = eval(call, vars(importlib.import_module(module)))  # noqa: S307 - the cases above
    with concurrent.futures.ProcessPoolExecutor(1) as pool:
        with pytest.raises(type(raised)) as got:
            pool.submit(_raise_in_worker, raised).result(timeout=120)
    assert str(got.value) == str(raised)
    assert got.value.__dict__ == raised.__dict__
