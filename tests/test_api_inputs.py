"""The scene, config and environment functions called from Python: bad input is named.

From a library walk (2026-12-06): ``random_scene(config, 2.5, 1)`` raised AttributeError,
a seed of ``None`` or ``1.5`` a TypeError from the comparison or from NumPy, and
``check_scene`` a bare ``KeyError: 'purple'`` for an object of no class, where each
docstring promises a SceneError naming the rule; ``load_config(3)`` and
``gym.make(..., config=3)`` a TypeError.
"""

from __future__ import annotations

import numpy as np
import pytest

from mearm import load_config, random_scene
from mearm.config import SceneObject
from mearm.task import check_scene
from mearm.task.scene import SceneError


@pytest.fixture(scope="module")
def config():
    return load_config("sim")


@pytest.mark.parametrize(
    ("counts", "seed", "words"),
    [
        (2.5, 1, "the number of objects must be a whole number, or one per class name"),
        ("3", 1, "got '3'"),
        (True, 1, "got True"),
        ({"red": 2.0}, 1, "got {'red': 2.0}"),
        (3, None, "the seed must be a whole number in [0, 4294967295], got None"),
        (3, 1.5, "got 1.5"),
    ],
)
def test_a_count_or_seed_that_is_no_whole_number_is_named(config, counts, seed, words) -> None:
    with pytest.raises(SceneError) as info:
        random_scene(config, counts, seed)
    assert words in str(info.value)


def test_numpy_integers_are_whole_numbers(config) -> None:
    assert random_scene(config, np.int64(3), np.int64(1)) == random_scene(config, 3, 1)


def test_an_object_of_no_class_is_named_with_the_classes(config) -> None:
    with pytest.raises(SceneError) as info:
        check_scene(config, [SceneObject(color="purple", x=-4.0, y=45.0)])
    assert str(info.value).endswith(
        "task.scene[0] (purple at x -4, y 45 cm): no class 'purple'; classes: red, green, blue"
    )


@pytest.mark.parametrize(
    ("path", "overrides", "words"),
    [
        (3, (), "a config is a file's path or a shipped config's name, got 3"),
        ("sim", "controller.kp=0.2", "overrides must be a list of 'dotted.key=value' strings"),
        ("sim", [3], "got [3]"),
    ],
)
def test_load_config_names_an_argument_of_another_type(path, overrides, words) -> None:
    """``load_config(3)`` was a bare TypeError; a string of overrides blamed its first
    character (``--set: 'c': expected dotted.key=value``)."""
    from mearm.errors import ConfigError

    with pytest.raises(ConfigError) as info:
        load_config(path, overrides)
    assert words in str(info.value)


def test_an_environments_config_of_another_type_is_an_option_error() -> None:
    pytest.importorskip("gymnasium")
    from mearm.envs import EnvOptionError, TwinEnv

    with pytest.raises(EnvOptionError, match="config must be a config's name, its file or a"):
        TwinEnv(config=3)


def test_the_models_kinematics_name_a_joint_vector_of_another_length() -> None:
    """``fk_cm`` of three joints reached Pinocchio ("wrong argument size: expected 4, got
    3", from a C++ file); ``check_limits`` raised IndexError. InvalidJointsError now, naming
    the joints and, for the actuated ones alone, how to make them whole."""
    from mearm.kinematics import ArmModel
    from mearm.kinematics.errors import InvalidJointsError

    model = ArmModel(load_config("sim").arm)
    short = model.home[:3]
    for call in (model.fk_cm, model.jacobian, model.check_limits, model.approach_jacobian):
        with pytest.raises(InvalidJointsError, match=r"expected 4 values, one per joint \(base"):
            call(short)
    with pytest.raises(InvalidJointsError, match=r"chain\.full\(q\)"):
        model.fk_cm(short)
    with pytest.raises(InvalidJointsError, match="got shape \\(5,\\)"):
        model.fk_cm([0.0] * 5)
    assert np.allclose(model.fk_cm(list(model.home)), model.fk_cm(model.home))


def test_a_target_of_none_is_named_as_given() -> None:
    """``solve(None)`` said "got nan" (None as a float); it says None."""
    from mearm.exceptions import InvalidTargetError
    from mearm.ik import make_solver
    from mearm.kinematics import ArmModel

    config = load_config("sim")
    model = ArmModel(config.arm)
    with pytest.raises(InvalidTargetError, match=r"in cm, got None$"):
        make_solver(model, config.controller).solve(None, model.home)  # type: ignore[arg-type]
