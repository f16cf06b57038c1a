"""An unknown key in an arm points at the reference arm file the arm was made from.

A newcomer copies a reference arm (``configs/arms/*.yaml``) under a new name, or names
one with ``use:`` and gives the arm a name of its own; a misspelt key's hint shows the
file they started from, not always the paper's arm.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import refused_line
from conftest import ROOT

ARMS = ROOT / "configs" / "arms"


def _shown(arm: str) -> str:
    """How a message run outside the checkout names a reference arm's file."""
    return str((ARMS / f"{arm}.yaml").resolve())


def _copy(tmp_path: Path, arm: str, name: str, old: str, new: str) -> Path:
    """``configs/arms/ARM.yaml`` saved as ``NAME.yaml``, its arm renamed, ``old`` → ``new``."""
    text = (ARMS / f"{arm}.yaml").read_text()
    assert text.count(f"name: {arm}\n") == 1 and text.count(old) == 1
    path = tmp_path / f"{name}.yaml"
    path.write_text(text.replace(f"name: {arm}\n", f"name: {name}\n").replace(old, new))
    return path


def _fk(config: Path, joints: str) -> str:
    return refused_line(["fk", "--config", config.name, "--joints", joints], cwd=config.parent)


@pytest.mark.heavy
def test_a_renamed_copy_of_mearm_v1_points_at_mearm_v1(tmp_path: Path) -> None:
    path = _copy(
        tmp_path, "mearm_v1", "my_kit", "    - name: elbow\n", "    - name: elbow\n      hom: 3\n"
    )
    assert _fk(path, "90,90,-90") == (
        "mearm fk: error: my_kit.yaml: arm.joints.elbow.hom: unknown key; did you mean home? "
        f"({_shown('mearm_v1')} shows every key)"
    )


@pytest.mark.heavy
def test_a_renamed_copy_of_the_5dof_arm_points_at_it(tmp_path: Path) -> None:
    path = _copy(
        tmp_path,
        "desk_5dof",
        "my_desk",
        "    - name: wrist_roll\n",
        "    - name: wrist_roll\n      hom: 3\n",
    )
    assert _fk(path, "0,90,-90,0,0") == (
        "mearm fk: error: my_desk.yaml: arm.joints.wrist_roll.hom: unknown key; did you mean "
        f"home? ({_shown('desk_5dof')} shows every key)"
    )


@pytest.mark.heavy
def test_an_arm_that_uses_mearm_v1_under_its_own_name_points_at_mearm_v1(tmp_path: Path) -> None:
    path = tmp_path / "rig.yaml"
    path.write_text(
        "extends: sim\narm:\n  use: mearm_v1\n  name: my_kit\n  tool: {settel_s: 0.2}\n"
    )
    assert _fk(path, "90,90,-90") == (
        "mearm fk: error: rig.yaml: arm.tool.settel_s: unknown key; did you mean settle_s? "
        f"({_shown('mearm_v1')} shows every key)"
    )


@pytest.mark.heavy
def test_a_section_the_copied_arm_does_not_write_points_at_the_paper_arm(tmp_path: Path) -> None:
    """mearm_v1 has no tool actuators: the paper's arm shows one."""
    actuator = (
        "    actuators:\n      - {name: wrist_turn, limits: {min: 0, max: 90}, home: 45,\n"
        "         travel: 30, grip: 60, turns: 2,\n"
        "         servo: {channel: 5, zero_us: 1500, direction: 1, us_per_unit: 10}}\n"
    )
    path = _copy(tmp_path, "mearm_v1", "my_kit", "    gripper:\n", f"{actuator}    gripper:\n")
    assert _fk(path, "90,90,-90") == (
        "mearm fk: error: my_kit.yaml: arm.tool.actuators.wrist_turn.turns: unknown key"
        f" ({_shown('mearm_paper')} shows every key)"
    )


@pytest.mark.heavy
def test_an_arm_of_its_own_points_at_the_paper_arm(tmp_path: Path) -> None:
    path = tmp_path / "scratch.yaml"
    path.write_text(
        "arm:\n  name: scratch\n  joints:\n"
        "    - {name: a, dh: {a_cm: 1}, limits: {min: 0, max: 90}, hom: 3}\n"
        "  tool: {gripper: {name: g}}\n"
    )
    line = _fk(path, "90")
    assert line.startswith("mearm fk: error: scratch.yaml: 4 problems: "), line
    said = f"arm.joints.a.hom: unknown key; did you mean home? ({_shown('mearm_paper')} shows"
    assert said in line, line
