"""A config's errors name what the caller gave: ``path``/``overrides`` in Python, flags on the CLI.

``load_config("")`` said ``--config: the value is empty`` and ``load_config("sim",
overrides=["controller.kp=nan"])`` said ``--set: controller.kp: …``: flags a Python call
does not have. The library names its own arguments (as ``gym.make(..., overrides=[...])``
already did); every command still names ``--config`` and ``--set``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import refused_line

from mearm.config import load_config
from mearm.config.files import config_source
from mearm.errors import ConfigError


def _said(path: str | Path | None, overrides: list[str]) -> str:
    with pytest.raises(ConfigError) as caught:
        load_config(path, overrides)
    return str(caught.value)


def _fk(*args: str, cwd: Path) -> str:
    """``mearm fk ARGS`` run in ``cwd``: its one line of stderr (it must fail, exit 2)."""
    return refused_line(["fk", *args, "--joints", "120,93,-132"], cwd=cwd)


def test_an_empty_path_is_said_of_path() -> None:
    assert _said("", []).startswith(
        "path: the value is empty: give a config file's path or the name of a packaged config"
    )


@pytest.mark.parametrize("path", ["sim", None])
def test_a_bad_override_is_said_of_overrides(path: str | None) -> None:
    assert _said(path, ["controller.kp=nan"]) == (
        "overrides: controller.kp: Input should be a finite number (got 'nan')"
    )
    assert _said(path, ["servo.nonsense=1"]).startswith("overrides: servo.nonsense: unknown key")
    assert _said(path, ["controller.kp"]) == (
        "overrides: 'controller.kp': expected dotted.key=value, e.g. arm.joints.base.home=90"
    )


def test_the_hints_give_the_override_as_python_takes_it(tmp_path: Path) -> None:
    assert _said("sim", ["twin.faults.0.at_s=1"]) == (
        "overrides: twin.faults.0: no item 0: twin.faults is an empty list; set the whole "
        "list instead, e.g. overrides=['twin.faults=[{at_s: 1}]']"
    )
    assert _said("sim", ["extends=lab"]) == (
        "overrides: extends: the config a file builds on is named in the file, not by "
        "overrides: load that config instead, or write extends: in your file"
    )
    assert _said("sim", ["arm.use=desk_5dof"]) == (
        "overrides: arm.use: the reference arm a config builds on is named in its file "
        "(arm: {use: NAME}), not by overrides; an override changes the keys of the arm it names"
    )
    missing = tmp_path / "nowhere.json"
    assert _said("sim", [f"servo.calibration_file={missing}"]) == (
        f"overrides: servo.calibration_file: {str(missing)!r} is not a file; a relative path "
        "in a config file is relative to that file's folder, one given by overrides to the "
        "current folder"
    )


def test_a_loaded_config_is_from_its_file_with_overrides() -> None:
    config = load_config("sim", ["controller.kp=0.3"])
    source = config_source(config)
    assert source is not None and source.endswith("sim.yaml with overrides")
    assert config_source(load_config(None, ["controller.kp=0.3"])) == "overrides"


def test_a_caller_names_where_its_values_came_from() -> None:
    """What a command passes (``mearm.cli.config_from_args``): its flags."""
    with pytest.raises(ConfigError) as caught:
        load_config("", path_as="--config", overrides_as="--set")
    assert str(caught.value).startswith("--config: the value is empty")
    with pytest.raises(ConfigError) as caught:
        load_config("sim", ["controller.kp=nan"], path_as="--config", overrides_as="--set")
    assert str(caught.value) == "--set: controller.kp: Input should be a finite number (got 'nan')"


@pytest.mark.parametrize(
    ("override", "said"),
    [
        ("controller.kp=nan", "--set: controller.kp: Input should be a finite number (got 'nan')"),
        (
            "twin.faults.0.at_s=1",
            "--set: twin.faults.0: no item 0: twin.faults is an empty list; set the whole list "
            "instead, e.g. --set 'twin.faults=[{at_s: 1}]'",
        ),
        (
            "extends=lab",
            "--set: extends: the config a file builds on is named in the file, not by --set: "
            "give that config as --config, or write extends: in your file",
        ),
        (
            "arm.use=desk_5dof",
            "--set: arm.use: the reference arm a config builds on is named in its file "
            "(arm: {use: NAME}), not by --set; --set changes the keys of the arm it names",
        ),
        (
            "servo.calibration_file=nowhere.json",
            "--set: servo.calibration_file: 'CWD/nowhere.json' is not a file; a relative "
            "path in a config file is relative to that file's folder, one given by --set to "
            "the current folder",
        ),
    ],
)
def test_the_cli_still_names_its_flags(tmp_path: Path, override: str, said: str) -> None:
    line = _fk("--config", "sim", "--set", override, cwd=tmp_path)
    assert line == f"mearm fk: error: {said.replace('CWD', str(tmp_path))}"


def test_the_environment_names_its_arguments() -> None:
    """``gym.make(..., config=…, overrides=[…])``: its own arguments, ``config`` and
    ``overrides`` (docs/learning.md)."""
    gym = pytest.importorskip("gymnasium")
    import mearm.envs  # noqa: F401, PLC0415  (registers the environments)

    with pytest.raises(ConfigError) as caught:
        gym.make("mearm/PickPlace-v0", config="")
    assert str(caught.value).startswith("config: the value is empty")
    with pytest.raises(ConfigError) as caught:
        gym.make("mearm/PickPlace-v0", config="sim_mujoco", overrides=["twin.faults.0.at_s=1"])
    assert str(caught.value).endswith("e.g. overrides=['twin.faults=[{at_s: 1}]']")
