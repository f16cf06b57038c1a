"""Narrow interfaces: below the simulators no function takes the whole ``Config``.

The layers under the simulators (kinematics, vision, ik, hardware) are passed what they
need (a ``ColorClass``, the arm, servo specs), as Pinocchio's functions take a model and
its data, never a global settings object. Two things would widen them again: a parameter
annotated ``Config`` (as a name, a string or inside a union), and importing ``Config``
itself from ``mearm.config``; this test finds both.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
from conftest import ROOT

#: The packages below the simulators.
NARROW = ("kinematics", "vision", "ik", "hardware")

_CONFIG_WORD = re.compile(r"(?<![\w.])(?:[\w]+\.)*Config(?!\w)")


def _names_config(annotation: ast.expr | None) -> bool:
    """True when an annotation mentions the whole ``Config`` (``Config``, "Config", x.Config)."""
    if annotation is None:
        return False
    for node in ast.walk(annotation):
        if isinstance(node, ast.Name) and node.id == "Config":
            return True
        if isinstance(node, ast.Attribute) and node.attr == "Config":
            return True
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            if _CONFIG_WORD.search(node.value):
                return True
    return False


def _wide_parameters(tree: ast.AST) -> list[str]:
    """``function(parameter)`` for every parameter annotated with the whole ``Config``."""
    out = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        a = node.args
        params = [*a.posonlyargs, *a.args, *a.kwonlyargs, a.vararg, a.kwarg]
        out += [
            f"{node.name}({p.arg}) line {node.lineno}"
            for p in params
            if p is not None and _names_config(p.annotation)
        ]
    return out


def _config_imports(tree: ast.AST) -> list[str]:
    """``line N`` for every import of ``Config`` itself from ``mearm.config``."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("mearm.config"):
            out += [f"line {node.lineno}" for a in node.names if a.name == "Config"]
    return out


def _modules() -> list[Path]:
    return sorted(p for pkg in NARROW for p in (ROOT / "mearm" / pkg).rglob("*.py"))


def _findings(source: str) -> list[str]:
    tree = ast.parse(source)
    return _wide_parameters(tree) + [f"imports Config {x}" for x in _config_imports(tree)]


@pytest.mark.parametrize("path", _modules(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_no_function_below_the_simulators_takes_the_whole_config(path: Path) -> None:
    """No parameter there is annotated ``Config``, and ``Config`` is not imported there."""
    assert _findings(path.read_text(encoding="utf-8")) == []


def test_the_packages_exist() -> None:
    """The scan reads real modules (a renamed package would make the test vacuous)."""
    for pkg in NARROW:
        assert list((ROOT / "mearm" / pkg).glob("*.py")), pkg


@pytest.mark.parametrize(
    "source",
    [
        "from mearm.config import Config\n",
        "def f(config: Config) -> None: ...\n",
        "def f(config: 'Config') -> None: ...\n",
        "def f(*, config: Config | None = None) -> None: ...\n",
        "def f(c: 'mearm.config.Config') -> None: ...\n",
        "class A:\n    def m(self, config: cfg.Config) -> None: ...\n",
        "def f(c: 'list[Config]') -> None: ...\n",
    ],
)
def test_the_scan_finds_a_wide_interface(source: str) -> None:
    """Each way of taking or importing the whole Config is found (so the test can fail)."""
    assert _findings(source)


@pytest.mark.parametrize(
    "source",
    [
        "from mearm.config import ColorClass, ControllerConfig\n",
        "def f(c: ControllerConfig, v: 'VisionConfig') -> None: ...\n",
        "def f(config) -> None: ...\n",
    ],
)
def test_the_scan_lets_a_narrow_interface_pass(source: str) -> None:
    """A part of the config (ControllerConfig, VisionConfig, a ColorClass) is narrow enough."""
    assert _findings(source) == []
