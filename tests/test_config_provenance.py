"""A config error names the file the bad key was written in, through ``extends`` too.

A chain of configs is merged, then validated: a mistake in a config that another
extends is said of that config's file, not of the file given to ``--config``; the top
file's own keys and ``--set`` keep theirs.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import refused_line
from conftest import ROOT

from mearm.config import load_config
from mearm.exceptions import ConfigError

#: How a message run outside the checkout names the shipped sim.yaml.
SIM_SHOWN = str((ROOT / "configs" / "sim.yaml").resolve())


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def _fk(config: str, *more: str, cwd: Path) -> str:
    """``mearm fk --config CONFIG`` run in ``cwd``: its one line of stderr (it must fail)."""
    return refused_line(["fk", "--config", config, *more, "--joints", "120,93,-132"], cwd=cwd)


@pytest.mark.heavy
def test_a_mistake_in_an_extended_config_names_that_config(tmp_path: Path) -> None:
    _write(tmp_path, "base.yaml", "extends: sim\ncontroller: {kpp: 0.2}\n")
    _write(tmp_path, "top.yaml", "extends: base.yaml\ncontroller: {kd: 0.02}\n")
    assert _fk("top.yaml", cwd=tmp_path) == (
        "mearm fk: error: base.yaml: controller.kpp: unknown key; did you mean kp? "
        f"({SIM_SHOWN} shows every key)"
    )


@pytest.mark.heavy
def test_a_bad_value_two_configs_down_names_its_file(tmp_path: Path) -> None:
    _write(tmp_path, "shared/base.yaml", "extends: sim\ncontroller: {kp: -5}\n")
    _write(tmp_path, "shared/mid.yaml", "extends: base.yaml\ncontroller: {kd: 0.02}\n")
    _write(tmp_path, "top.yaml", "extends: shared/mid.yaml\n")
    assert _fk("top.yaml", cwd=tmp_path) == (
        "mearm fk: error: shared/base.yaml: controller.kp: Input should be greater than 0 (got -5)"
    )


@pytest.mark.heavy
def test_a_named_joint_changed_in_an_extended_config_names_it(tmp_path: Path) -> None:
    _write(
        tmp_path,
        "base.yaml",
        "extends: sim_mearm_v1\narm:\n  joints:\n    shoulder: {limits: {min: 100, max: 20}}\n",
    )
    _write(tmp_path, "top.yaml", "extends: base.yaml\narm:\n  joints:\n    elbow: {home: -50}\n")
    assert _fk("top.yaml", cwd=tmp_path) == (
        "mearm fk: error: base.yaml: arm.joints.shoulder.limits: min (100) must be below max (20)"
    )


@pytest.mark.heavy
def test_the_top_files_own_mistake_is_still_its_own(tmp_path: Path) -> None:
    _write(tmp_path, "base.yaml", "extends: sim\ncontroller: {kd: 0.02}\n")
    _write(tmp_path, "top.yaml", "extends: base.yaml\ncontroller: {kp: -5}\n")
    assert _fk("top.yaml", cwd=tmp_path) == (
        "mearm fk: error: top.yaml: controller.kp: Input should be greater than 0 (got -5)"
    )


@pytest.mark.heavy
def test_a_key_the_top_file_changes_over_a_bad_one_is_the_top_files(tmp_path: Path) -> None:
    """The file that wrote the value validation saw is the one named."""
    _write(tmp_path, "base.yaml", "extends: sim\ncontroller: {kp: 0.3}\n")
    _write(tmp_path, "top.yaml", "extends: base.yaml\ncontroller: {kp: -1}\n")
    assert _fk("top.yaml", cwd=tmp_path).startswith("mearm fk: error: top.yaml: controller.kp:")


@pytest.mark.heavy
def test_mistakes_in_two_files_name_the_given_file_and_lead_the_other(tmp_path: Path) -> None:
    _write(tmp_path, "base.yaml", "extends: sim\ncontroller: {kp: -5}\n")
    _write(tmp_path, "top.yaml", "extends: base.yaml\ncontroller: {kd: -1}\n")
    assert _fk("top.yaml", cwd=tmp_path) == (
        "mearm fk: error: top.yaml: 2 problems: base.yaml: controller.kp: Input should be "
        "greater than 0 (got -5); controller.kd: Input should be greater than or equal to 0 "
        "(got -1)"
    )


@pytest.mark.heavy
def test_set_keeps_its_attribution_over_an_extended_config(tmp_path: Path) -> None:
    """A bad --set over a good chain is --set's; over a bad chain, the given file's."""
    _write(tmp_path, "base.yaml", "extends: sim\ncontroller: {kd: 0.02}\n")
    _write(tmp_path, "top.yaml", "extends: base.yaml\n")
    assert _fk("top.yaml", "--set", "controller.kd=-1", cwd=tmp_path) == (
        "mearm fk: error: --set: controller.kd: Input should be greater than or equal to 0 (got -1)"
    )
    _write(tmp_path, "base.yaml", "extends: sim\ncontroller: {kp: -5}\n")
    assert _fk("top.yaml", "--set", "controller.kd=-1", cwd=tmp_path) == (
        "mearm fk: error: top.yaml: 2 problems: base.yaml: controller.kp: Input should be "
        "greater than 0 (got -5); controller.kd: Input should be greater than or equal to 0 "
        "(got -1)"
    )


def test_load_config_names_the_extended_file(tmp_path: Path) -> None:
    base = _write(tmp_path, "base.yaml", "arm: {use: mearm_v1, tool: {settel_s: 1}}\n")
    top = _write(tmp_path, "top.yaml", "extends: base.yaml\ncontroller: {kd: 0.02}\n")
    with pytest.raises(ConfigError) as caught:
        load_config(top)
    assert caught.value.path == str(base)
    assert caught.value.problems[0].startswith("arm.tool.settel_s: unknown key")
