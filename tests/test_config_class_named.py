"""A class the arm's tool cannot take is named, not numbered, as every other class error.

``--set task.classes.blue.diameter_cm=4.5`` said ``task.classes.2.diameter_cm: a 4.5 cm
cylinder is 4.5 cm across, not less than the open jaws' 4 cm …`` (and a bin too tall for
its class's release height ``task.classes.1.bin_height_cm``), where a bad value of the
same class says ``task.classes.blue.diameter_cm: Input should be …``: the classes are
"named, not numbered" (docs/troubleshooting.md), and ``--set`` takes the name.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.errors import ConfigError

#: The one line for a class of 4.5 cm cylinders in the paper arm's 4 cm jaws.
CYLINDER = (
    "task.classes.blue.diameter_cm: a 4.5 cm cylinder is 4.5 cm across, not less than the "
    "open jaws' 4 cm (arm.tool.gripper.open_cm): the open jaws must pass it; use smaller "
    "objects or a wider-opening gripper"
)
#: The same for a cube of sim_shapes_mujoco, the first of its classes.
CUBE = (
    "task.classes.red_cube.diameter_cm: a 4.5 cm cube is 6.36 cm across its diagonal, not "
    "less than the open jaws' 4 cm (arm.tool.gripper.open_cm): the open jaws must pass it "
    "at any yaw (they turn to its faces only where a wrist roll can); use smaller objects "
    "or a wider-opening gripper"
)
#: sim_shapes_mujoco's first class's diameter.
RED_CUBE = "task.classes.red_cube.diameter_cm"
#: Walls of the green bin that reach above where its objects are released.
WALLS = (
    "task.classes.green.bin_height_cm: 30 cm walls reach above the bottom of an object "
    "released at bin_cm z = 20 cm (7.24 cm above the table): at most 7.24 cm, or raise "
    "bin_cm z"
)


def _said(path: str | Path, overrides: list[str]) -> str:
    with pytest.raises(ConfigError) as caught:
        load_config(path, overrides)
    return str(caught.value)


@pytest.mark.parametrize(
    ("config", "override", "said"),
    [
        ("sim", "task.classes.blue.diameter_cm=4.5", CYLINDER),
        ("sim_shapes_mujoco", f"{RED_CUBE}=4.5", CUBE),
        ("sim", "task.classes.green.bin_height_cm=30", WALLS),
    ],
)
def test_the_class_is_named_in_python(config: str, override: str, said: str) -> None:
    assert _said(config, [override]) == f"overrides: {said}"


def test_the_class_is_named_in_the_file_that_sets_it(tmp_path: Path) -> None:
    wide = tmp_path / "wide.yaml"
    wide.write_text("extends: sim\ntask:\n  classes:\n    blue: {diameter_cm: 4.5}\n")
    (tmp_path / "top.yaml").write_text("extends: wide.yaml\ncontroller: {kp: 0.3}\n")
    assert _said(wide, []) == f"{wide}: {CYLINDER}"
    assert _said(tmp_path / "top.yaml", []) == f"{wide}: {CYLINDER}"  # where it is written


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["sort", "--config", "sim", "--set", "task.classes.blue.diameter_cm=4.5"], CYLINDER),
        (
            ["detect", "--camera", "--config", "sim", "--set", "task.classes.blue.diameter_cm=4.5"],
            CYLINDER,
        ),
        (["sort", "--config", "sim_shapes_mujoco", "--set", f"{RED_CUBE}=4.5"], CUBE),
        (["sort", "--config", "sim", "--set", "task.classes.green.bin_height_cm=30"], WALLS),
    ],
)
def test_the_class_is_named_on_the_command_line(tmp_path: Path, argv: list[str], said: str) -> None:
    r = run_in_process(argv, cwd=tmp_path)
    assert (r.code, r.stdout) == (2, ""), r
    assert "Traceback" not in r.stderr
    assert r.stderr.splitlines() == [f"mearm {argv[0]}: error: --set: {said}"]
