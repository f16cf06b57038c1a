"""Format-1 configs migrate to the current layout and mean the same rig."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from mearm.config import Config, config_from_dict, default_classes
from mearm.config.defaults import PAPER_HUE_BANDS_DEG
from mearm.config.migrate import V1_JOINT_NAMES, is_v1_config, migrate_v1_config
from mearm.exceptions import ConfigError

REPO = Path(__file__).resolve().parents[1]
V1_FILES = ("configs/sim.yaml", "configs/lab.yaml", "configs/sim_paper_arm.yaml")


def v1_file(path: str) -> Any:
    """A config file as the last format-1 release had it (kept in tests/data/format1/)."""
    return yaml.safe_load((REPO / "tests" / "data" / "format1" / Path(path).name).read_text())


def migrated(path: str) -> Config:
    return config_from_dict(migrate_v1_config(v1_file(path)), source=path)


def home_tcp_cm(config: Config) -> np.ndarray:
    arm = config.arm
    return arm.tcp_cm(arm.full_values(arm.home()))


@pytest.mark.parametrize("path", V1_FILES)
def test_format_1_files_migrate_and_validate(path: str) -> None:
    """Each format-1 file becomes a valid config with the paper arm's home pose."""
    config = migrated(path)
    assert [j.name for j in config.arm.joints] == list(V1_JOINT_NAMES)
    np.testing.assert_allclose(home_tcp_cm(config), home_tcp_cm(Config()), atol=1e-9)
    np.testing.assert_allclose(home_tcp_cm(config), [-20.16, 34.91, 19.95], atol=0.01)


@pytest.mark.parametrize("path", V1_FILES)
def test_gripper_pulses_are_format_1s(path: str) -> None:
    """The gripper calibration gives exactly the open and closed pulses format 1 sent."""
    gripper = migrated(path).arm.tool.gripper
    assert gripper.servo.pulse_us(gripper.open_cm) == pytest.approx(1000.0, abs=1e-9)
    assert gripper.servo.pulse_us(gripper.closed_cm) == pytest.approx(1900.0, abs=1e-9)
    assert gripper.servo.channel == 4


def _without_speeds(arm: dict) -> dict:
    """An arm's dump without its servos' ``seconds_per_60deg``."""

    def drop(servo: dict | None) -> None:
        if servo is not None:
            servo.pop("seconds_per_60deg")

    for joint in arm["joints"]:
        drop(joint["servo"])
    drop(arm["tool"]["gripper"]["servo"])
    for actuator in arm["tool"]["actuators"]:
        drop(actuator["servo"])
    return arm


def test_migrated_sim_is_the_default_rig_with_format_1_names() -> None:
    """configs/sim.yaml wrote out format 1's defaults: it migrates to today's defaults."""
    config, default = migrated("configs/sim.yaml"), Config()
    renames = dict(zip(V1_JOINT_NAMES, (j.name for j in default.arm.joints), strict=True))
    arm = config.arm.model_dump()
    for joint in arm["joints"]:
        joint["name"] = renames[joint["name"]]
        if joint["coupling"] is not None:
            terms = joint["coupling"]["terms"]
            joint["coupling"]["terms"] = {renames[n]: c for n, c in terms.items()}
    # Format 1 had no servo speeds: a migrated file takes the field's default (a micro
    # servo's 0.10 s/60°), where today's defaults give the paper's RDS3135/MG996R.
    assert _without_speeds(arm) == _without_speeds(default.arm.model_dump())
    assert config.task == default.task
    assert config.vision == default.vision
    assert config.servo.model_dump(exclude={"error_model"}) == default.servo.model_dump(
        exclude={"error_model"}
    )
    assert config.servo.error_model.offset_deg == {"joint1": 0.0, "joint2": 0.0, "joint3": 0.0}
    # A homography the file gives without the frame size it was fitted at (format 1 had
    # none) is of unknown size, where the built-in one is the paper's 640x480.
    assert config.calibration.image_size_px is None
    assert default.calibration.image_size_px == (640, 480)
    assert (config.camera, config.calibration.model_dump(exclude={"image_size_px"})) == (
        default.camera,
        default.calibration.model_dump(exclude={"image_size_px"}),
    )
    assert config.controller == default.controller


def test_partial_file_takes_format_1_defaults() -> None:
    """sim_paper_arm.yaml sets only the error model; the rest is format 1's defaults."""
    partial, full = migrated("configs/sim_paper_arm.yaml"), migrated("configs/sim.yaml")
    assert partial.servo.error_model.offset_deg == {"joint1": 0.0, "joint2": 0.0, "joint3": 0.0}
    assert partial.servo.error_model.noise_std_deg == 0.55
    partial_dump, full_dump = (
        partial.model_dump(exclude={"servo"}),
        full.model_dump(exclude={"servo"}),
    )
    # The partial file's arm is today's default, with the paper's servo speeds.
    _without_speeds(partial_dump["arm"])
    _without_speeds(full_dump["arm"])
    # The built-in homography is the paper's, for 640x480; the one the full file gives,
    # without its frame size, is of unknown size.
    sizes = (
        partial_dump["calibration"].pop("image_size_px"),
        full_dump["calibration"].pop("image_size_px"),
    )
    assert sizes == ((640, 480), None)
    assert partial_dump == full_dump


def test_lab_keeps_its_rig() -> None:
    config = migrated("configs/lab.yaml")
    assert (config.servo.backend, config.camera.kind, config.task.scene) == ("serial", "device", [])


def test_arm_values_carry_over() -> None:
    """Limits, home, DH rows, servo calibrations and the gripper arm come from the old keys."""
    data = v1_file("configs/sim.yaml")
    robot, servo = data["robot"], data["servo"]
    robot["joint_limits_deg"]["joint2"] = {"min": 35.0, "max": 130.0}
    robot["home_deg"] = [110.0, 90.0, -130.0]
    robot["dh"][3]["a_cm"] = 15.0
    robot["gripper"].update(pick_height_cm=13.0, grip_angle_deg=-50.0, travel_angle_deg=20.0)
    robot["gripper"]["gripper_arm_limits_deg"] = {"min": -80.0, "max": 80.0}
    servo["joints"]["joint3"].update(zero_us=2300.0, us_per_deg=9.5, min_us=700)
    servo["joints"]["joint5"]["channel"] = 7
    arm = config_from_dict(migrate_v1_config(data)).arm
    j2, j3, j4 = arm.joints[1], arm.joints[2], arm.joints[3]
    assert j2.limits is not None and (j2.limits.min, j2.limits.max) == (35.0, 130.0)
    assert arm.home() == {"joint1": 110.0, "joint2": 90.0, "joint3": -130.0}
    assert j4.dh.a_cm == 15.0 and j4.coupling is not None and not j4.actuated
    assert j4.coupling.terms == {"joint2": -1.0, "joint3": -1.0}
    assert arm.full_values(arm.home())["joint4"] == pytest.approx(40.0)
    assert j3.servo is not None
    assert (j3.servo.zero_us, j3.servo.direction, j3.servo.us_per_unit) == (2300.0, 1, 9.5)
    assert j3.servo.min_us == 700
    (gripper_arm,) = arm.tool.actuators
    assert gripper_arm.name == "gripper_arm" and gripper_arm.servo.channel == 7
    assert (gripper_arm.home, gripper_arm.travel, gripper_arm.grip) == (60.0, 20.0, -50.0)
    assert (gripper_arm.limits.min, gripper_arm.limits.max) == (-80.0, 80.0)
    assert arm.tool.tcp_above_grip_cm == pytest.approx(11.5)


def test_classes_from_order_bins_and_bands() -> None:
    """Classes follow color_order, take their bins, the preset's bands and the overrides."""
    data = v1_file("configs/sim.yaml")
    data["task"]["color_order"] = ["blue", "red"]
    data["task"]["bins_cm"]["blue"] = [-25.0, 50.0, 18.0]
    data["vision"].update(preset="paper", object_diameter_cm=2.5)
    data["vision"]["bands"] = {"red": [{"lo_deg": 300.0, "hi_deg": 10.0}]}
    config = config_from_dict(migrate_v1_config(data))
    blue, red = config.task.classes
    assert config.task.class_names == ["blue", "red"]
    assert blue.bin_cm == (-25.0, 50.0, 18.0)
    assert [(b.lo_deg, b.hi_deg) for b in blue.hue_bands_deg] == list(PAPER_HUE_BANDS_DEG["blue"])
    assert [(b.lo_deg, b.hi_deg) for b in red.hue_bands_deg] == [(300.0, 10.0)]
    assert (config.vision.saturation_min, config.vision.value_min) == (0.1, 0.1)
    assert blue.diameter_cm == 2.5 and blue.grip_height_cm == 1.5
    assert blue.draw_rgb == {c.name: c for c in default_classes()}["blue"].draw_rgb
    assert {o.color for o in config.task.scene} == {"blue", "red"}, "green objects dropped"
    assert len(config.task.scene) == 8


def test_default_preset_bands_and_explicit_floors() -> None:
    data = v1_file("configs/sim.yaml")
    data["vision"].update(saturation_min=0.3, value_min=None)
    config = config_from_dict(migrate_v1_config(data))
    assert [c.hue_bands_deg for c in config.task.classes] == [
        c.hue_bands_deg for c in default_classes()
    ]
    assert (config.vision.saturation_min, config.vision.value_min) == (0.3, 0.25)


def test_reversed_gripper_pulses() -> None:
    """A gripper that closes towards shorter pulses gets direction +1, pulses exact."""
    data = v1_file("configs/sim.yaml")
    data["servo"]["gripper"] = {"channel": 5, "open_us": 2300, "closed_us": 550}
    servo = config_from_dict(migrate_v1_config(data)).arm.tool.gripper.servo
    assert servo.direction == 1
    assert servo.pulse_us(4.0) == pytest.approx(2300.0) and servo.pulse_us(1.0) == pytest.approx(
        550.0
    )
    assert (servo.min_us, servo.max_us) == (550, 2400)


def test_current_layout_is_returned_unchanged() -> None:
    """A mapping in the current layout (no format-1 key) comes back equal, as a copy."""
    data = Config().model_dump(mode="json")
    out = migrate_v1_config(data)
    assert out == data and out is not data
    assert not is_v1_config(data) and not is_v1_config({})
    assert migrate_v1_config({"servo": {"backend": "serial"}}) == {"servo": {"backend": "serial"}}


def test_format_1_is_detected_by_its_keys() -> None:
    assert is_v1_config({"robot": {}})
    assert is_v1_config({"servo": {"error_model": {"offset_deg": [0.0, 0.0, 0.0]}}})
    assert is_v1_config({"task": {"color_order": ["red"]}})
    assert not is_v1_config({"servo": {"error_model": {"offset_deg": {"base": 1.0}}}})


def test_input_is_not_modified() -> None:
    data = v1_file("configs/sim.yaml")
    before = copy.deepcopy(data)
    migrate_v1_config(data)
    assert data == before


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"arm": {}}, "mixes format-1 keys (robot) with current ones (arm)"),
        ({"servo": {"gripper": {"open_us": 1200, "closed_us": 1200}}}, "are both 1200 µs"),
        ({"vision": {"preset": "fancy"}}, "vision.preset: 'fancy' is not a format-1 preset"),
        ({"task": {"color_order": ["red", "cyan"]}}, "task.bins_cm: has no bin for 'cyan'"),
        ({"robot": {"dh": [{"a_cm": 1.0}]}}, "robot.dh: must be a list of 4 values"),
        ({"robot": {"home_deg": 90}}, "robot.home_deg: must be a list of 3 values"),
        ({"robot": {"gripper": {"a6_cm": 1.0}}}, "robot.gripper: unknown keys ['a6_cm']"),
        ({"robot": {"reach": 1}}, "robot: unknown keys ['reach']"),
        ({"servo": {"joints": {"joint9": {"channel": 9}}}}, "servo.joints: unknown joints"),
        ({"servo": {"error_model": {"offset_deg": [1.0]}}}, "offset_deg: must be a list of 3"),
        ({"task": "sort"}, "task: must be a mapping, got str"),
    ],
)
def test_bad_format_1_values_are_named(change: dict[str, Any], message: str) -> None:
    data: dict[str, Any] = {"robot": {}}
    for key, value in change.items():
        data[key] = value if key != "robot" else {**data["robot"], **value}
    with pytest.raises(ConfigError) as info:
        migrate_v1_config(data, source="old.yaml")
    assert message in str(info.value) and str(info.value).startswith("old.yaml: ")


def test_not_a_mapping() -> None:
    with pytest.raises(ConfigError, match="top level must be a mapping, got list"):
        migrate_v1_config([1, 2])  # type: ignore[arg-type]


def test_bad_values_left_for_validation_name_the_new_key() -> None:
    """A value migration only moves is checked by the config, at its new place."""
    data = v1_file("configs/sim.yaml")
    data["robot"]["joint_limits_deg"]["joint1"] = {"min": 170.0, "max": 160.0}
    with pytest.raises(ConfigError, match=r"arm\.joints\.joint1\.limits"):
        config_from_dict(migrate_v1_config(data))
