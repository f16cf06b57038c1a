"""A mistake inside a ``twin.faults`` entry is said at the path the user wrote.

An entry is one of several kinds, told apart by its ``kind``; pydantic puts that tag into
an error's path (``twin.faults.0.limp_servo.foo``), a key no config has. The path said
is the one the file or ``--set`` uses: ``twin.faults.0.foo``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import refused_line
from conftest import ROOT

DOCS_SHOWN = f"{(ROOT / 'docs' / 'configuration.md').resolve()}#twinfaults"


def _fk(*args: str, cwd: Path) -> str:
    """``mearm fk ARGS`` run in ``cwd``: its one line of stderr (it must fail, exit 2)."""
    return refused_line(["fk", *args, "--joints", "120,93,-132"], cwd=cwd)


@pytest.mark.heavy
def test_mistakes_in_a_files_fault_entries_are_said_at_their_path(tmp_path: Path) -> None:
    (tmp_path / "faults.yaml").write_text(
        "extends: sim_mujoco\ntwin:\n  faults:\n"
        "    - {kind: limp_servo, at_s: 1.0, joint: shoulder, foo: 1}\n"
        "    - {kind: camera_bump, at_s: -2.0, shift_cm: [1, 0, 0]}\n"
    )
    assert _fk("--config", "faults.yaml", cwd=tmp_path) == (
        "mearm fk: error: faults.yaml: 2 problems: twin.faults.0.foo: unknown key "
        f"({DOCS_SHOWN} shows every key); twin.faults.1.at_s: Input should be greater than "
        "or equal to 0 (got -2.0)"
    )


@pytest.mark.heavy
def test_an_unknown_key_in_a_set_fault_is_said_at_its_path(tmp_path: Path) -> None:
    fault = "twin.faults=[{kind: camera_black, at_s: 1, colour: 3}]"
    assert _fk("--config", "sim_mujoco", "--set", fault, cwd=tmp_path) == (
        f"mearm fk: error: --set: twin.faults.0.colour: unknown key ({DOCS_SHOWN} shows every key)"
    )


@pytest.mark.heavy
def test_a_nested_value_of_a_fault_is_said_at_its_path(tmp_path: Path) -> None:
    fault = "twin.faults=[{kind: camera_bump, at_s: 1, shift_cm: [1, 99, 0]}]"
    assert _fk("--config", "sim_mujoco", "--set", fault, cwd=tmp_path) == (
        "mearm fk: error: --set: twin.faults.0.shift_cm.1: Input should be less than or equal "
        "to 10 (got 99)"
    )


@pytest.mark.heavy
def test_a_fault_key_set_on_its_own_is_said_as_typed(tmp_path: Path) -> None:
    """The path said is the one --set took, so the value is shown as it was typed."""
    args = [
        "--set",
        "twin.faults=[{kind: camera_black, at_s: 1}]",
        "--set",
        "twin.faults.0.at_s=yes",
    ]
    assert _fk("--config", "sim_mujoco", *args, cwd=tmp_path) == (
        "mearm fk: error: --set: twin.faults.0.at_s: expected a number, got 'yes'"
    )
