"""The wrong object passed to a public entry point: a named error saying what to pass.

A whole config where its section is wanted, an arm's description where the model is, a
string where a scene is: each stopped deep inside on a bare AttributeError that named
neither the argument nor the remedy. Now each entry point checks its arguments where it
is built (never in a solve's loop) and raises the package's error of that family, as
``ArmModel(config)`` already did (:class:`ModelError`, "pass its .arm").
"""

from __future__ import annotations

import numpy as np
import pytest

from mearm.backends import open_parts, table_world
from mearm.config import load_config
from mearm.exceptions import (
    CalibrationError,
    ConfigError,
    InvalidJointsError,
    MearmError,
    ModelError,
)
from mearm.ik import IKTarget, PdPij, fastest_solver, make_solver, solve_batch, solve_ik
from mearm.kinematics import ArmModel
from mearm.task.rig import open_rig
from mearm.vision.detector import ColorDetector

CONFIG = load_config("sim")
MODEL = ArmModel(CONFIG.arm)
TARGET = IKTarget((-10.99, 49.70, 12.76))


def _solve_with(model, controller):
    return PdPij(model, controller).solve(TARGET)


PASS_CONTROLLER = "got a Config: pass config.controller"
PASS_MODEL = r"pass ArmModel\(config.arm\)"


@pytest.mark.parametrize(
    ("call", "error", "says"),
    [
        pytest.param(
            lambda: _solve_with(MODEL, CONFIG), ConfigError, f"PdPij .*{PASS_CONTROLLER}",
            id="PdPij(model, config)",
        ),
        pytest.param(
            lambda: PdPij(MODEL, None), ConfigError, "PdPij needs a ControllerConfig.*got None",
            id="PdPij(model, None)",
        ),
        pytest.param(
            lambda: solve_ik(MODEL, CONFIG, TARGET), ConfigError, f"solve_ik .*{PASS_CONTROLLER}",
            id="solve_ik(model, config)",
        ),
        pytest.param(
            lambda: make_solver(MODEL, CONFIG), ConfigError, f"make_solver .*{PASS_CONTROLLER}",
            id="make_solver(model, config)",
        ),
        pytest.param(
            lambda: _solve_with(CONFIG.arm, CONFIG.controller), ModelError,
            f"PdPij needs an ArmModel.*got an ArmDescription: {PASS_MODEL}",
            id="PdPij(config.arm, controller)",
        ),
        pytest.param(
            lambda: make_solver(CONFIG.arm, CONFIG.controller), ModelError,
            f"make_solver .*{PASS_MODEL}",
            id="make_solver(config.arm, controller)",
        ),
        pytest.param(
            lambda: fastest_solver(CONFIG), ModelError,
            f"fastest_solver .*got a Config: {PASS_MODEL}",
            id="fastest_solver(config)",
        ),
        pytest.param(
            lambda: solve_batch(CONFIG.arm, [[0.0, 20.0, 10.0]]), ModelError,
            f"solve_batch .*{PASS_MODEL}",
            id="solve_batch(config.arm)",
        ),
    ],
)  # fmt: skip
def test_an_ik_entry_point_names_what_to_pass(call, error, says) -> None:
    with pytest.raises(error, match=says) as caught:
        call()
    assert isinstance(caught.value, MearmError)


def test_the_right_objects_still_solve() -> None:
    """The checks refuse only the wrong objects."""
    assert make_solver(MODEL, CONFIG.controller).solve(TARGET).status == "converged"
    assert solve_ik(MODEL, CONFIG.controller, TARGET).status == "converged"


VISION, CLASSES = CONFIG.vision, CONFIG.task.classes


@pytest.mark.parametrize(
    ("call", "error", "says"),
    [
        pytest.param(
            lambda: ColorDetector(CONFIG, None, CLASSES), ConfigError,
            "ColorDetector needs a VisionConfig.*got a Config: pass config.vision",
            id="vision=config",
        ),
        pytest.param(
            lambda: ColorDetector(VISION, None, CONFIG.task), ConfigError,
            "ColorDetector .*got a TaskConfig: pass config.task.classes",
            id="classes=config.task",
        ),
        pytest.param(
            lambda: ColorDetector(VISION, None, ["red"]), ConfigError,
            r"a sequence of ColorClass.*got \['red'\]",
            id="classes=names",
        ),
        pytest.param(
            lambda: ColorDetector(VISION, CONFIG.calibration, CLASSES), CalibrationError,
            r"got a CalibrationConfig: pass camera_geometry\(config.calibration, config.camera\)",
            id="calibration=its section",
        ),
        pytest.param(
            lambda: ColorDetector.from_config(CONFIG, CONFIG.calibration, CONFIG.camera, CLASSES),
            ConfigError, "from_config .*got a Config: pass config.vision",
            id="from_config(config)",
        ),
        pytest.param(
            lambda: ColorDetector.from_config(VISION, CONFIG, CONFIG.camera, CLASSES),
            ConfigError, "from_config .*CalibrationConfig.*pass config.calibration",
            id="from_config(calibration=config)",
        ),
    ],
)  # fmt: skip
def test_the_detector_names_what_to_pass(call, error, says) -> None:
    with pytest.raises(error, match=says):
        call()


def _open_rig(config, scene):
    with open_rig(config, scene):
        pass


@pytest.mark.parametrize(
    ("call", "says"),
    [
        pytest.param(
            lambda: _open_rig(CONFIG, "abc"),
            r"open_rig needs a scene: a list of SceneObject.*got 'abc'",
            id="open_rig(config, str)",
        ),
        pytest.param(
            lambda: _open_rig(CONFIG, [{"color": "red", "x": 0, "y": 20}]),
            "open_rig needs a scene",
            id="open_rig(config, dicts)",
        ),
        pytest.param(
            lambda: _open_rig(CONFIG.arm, None),
            "open_rig needs the whole config.*got an ArmDescription",
            id="open_rig(config.arm)",
        ),
        pytest.param(
            lambda: table_world(CONFIG, "abc"), "table_world needs a scene",
            id="table_world(config, str)",
        ),
        pytest.param(
            lambda: open_parts(CONFIG.task, None),
            "open_parts needs the whole config.*got a TaskConfig",
            id="open_parts(config.task)",
        ),
    ],
)  # fmt: skip
def test_the_rig_names_what_to_pass(call, says) -> None:
    with pytest.raises(ConfigError, match=says):
        call()


def test_a_scene_of_scene_objects_still_opens() -> None:
    with open_rig(CONFIG, list(CONFIG.task.scene)) as rig:
        assert len(rig.world.objects) == len(CONFIG.task.scene)


@pytest.mark.parametrize(
    ("q", "says"),
    [
        ([1.0, 2.0], r"3 values, one per actuated joint \(base, shoulder, elbow\).*\(2,\)"),
        ("abc", "must be numbers"),
        ([np.nan, 0.0, 0.0], "must be finite"),
        ([0.0, np.inf, 0.0], "must be finite"),
        (np.zeros((3, 3)), r"shape \(3, 3\)"),
    ],
    ids=["two values", "a string", "NaN", "inf", "3x3"],
)  # fmt: skip
def test_chain_full_refuses_joints_as_the_model_does(q, says) -> None:
    with pytest.raises(InvalidJointsError, match=says):
        MODEL.chain.full(q)


def test_chain_full_says_a_full_vector_is_already_whole() -> None:
    with pytest.raises(InvalidJointsError, match=r"actuated_of\(q\)"):
        MODEL.chain.full(MODEL.home)
    np.testing.assert_array_equal(MODEL.chain.full(MODEL.chain.actuated_of(MODEL.home)), MODEL.home)
