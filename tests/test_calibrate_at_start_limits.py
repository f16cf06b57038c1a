"""After the servos' calibration at a sort's start, an arm outside the limits it narrowed.

``hand_over`` re-reads the pose the arm holds in the new calibration's joints. Where that
lay outside the joints' limits as calibrated, it sent nothing and said nothing: the sort's
path home then started from the old calibration's joints, where the arm was not (and
raised ``ValueError`` where those lay outside the new limits). Now the sort stops there,
naming the joint and its limits; nothing is sent and the bus keeps its calibration.
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.maker.calibrate_servos import open_arm_bus
from mearm.maker.camera_calibration.at_start import hand_over
from mearm.task import Executor
from mearm.task.sorter import StartCalibrationFailed

SIM = ROOT / "configs" / "sim.yaml"


def test_a_pose_outside_the_calibrated_limits_stops_the_sort_and_sends_nothing() -> None:
    config = load_config(SIM)
    # the fit reaches less: the base's limits narrowed below where the arm stands (120°)
    narrowed = load_config(SIM, overrides=["arm.joints.base.limits.max=110",
                                           "arm.joints.base.home=100"])  # fmt: skip
    with open_arm_bus(config) as bus:
        Executor(config, bus, ArmModel(config.arm)).home_pose()
        state, servo_map = bus.state, bus.servo_map
        with pytest.raises(StartCalibrationFailed, match=r"base = 120\.00 \(limits \[20, 110\]\)"):
            hand_over(bus, ArmModel(narrowed.arm), narrowed)
        assert bus.state == state and bus.servo_map is servo_map


def test_a_pose_inside_them_is_handed_over_without_a_move() -> None:
    config = load_config(SIM)
    with open_arm_bus(config) as bus:
        Executor(config, bus, ArmModel(config.arm)).home_pose()
        pulses = bus.servo_map.pulses_us(bus.state)
        hand_over(bus, ArmModel(config.arm), config)
        assert bus.servo_map.pulses_us(bus.state) == pulses
