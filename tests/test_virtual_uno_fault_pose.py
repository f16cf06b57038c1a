"""A collision on a simulated bus names the last pose the bus confirmed, not "none".

The safety rule: a fault stops motion and keeps the last confirmed pose, and the fault's
message names it. The virtual Uno (the real firmware in simavr) moves its simulated arm by
the measured pulses, so the arm that runs into a bin's wall is not the bus that confirmed
the moves; the kinematic simulator is both. On each, two moves are acknowledged and the
third runs the gripper into the red bin (the paper arm's jaws, hanging below the TCP,
from above the bin down to shoulder 40°).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_virtual_uno import cache_home  # noqa: F401  (a fixture)

from mearm.backends import open_bus
from mearm.config import Config, config_from_dict
from mearm.exceptions import ServoFaultedError, SimCollisionError
from mearm.hardware import ArmCommand, ArmState
from mearm.hardware.bus import ServoBus
from mearm.sim import World
from mearm.sim.kinematic.servo_bus import SimArm
from mearm.sim.virtual_uno import VirtualUnoBus


def _config(backend: str) -> Config:
    """The paper's rig, no objects (the bins stay), on ``backend``."""
    return config_from_dict(
        {
            "task": {"scene": []},
            "servo": {
                "backend": backend,
                # generous: simavr beside other work on a loaded machine answers late
                "ack_timeout_s": 10.0,
                "virtual_uno": {"speed": 0},
            },
        }
    )


def _into_the_red_bin(bus: ServoBus, config: Config) -> None:
    """Home, then over the red bin (both acknowledged), then down into it: the
    fault carries the second pose, the one confirmed last, and so does every refusal
    after it."""
    home = ArmCommand.home(config.arm)

    def to(shoulder: float) -> ArmCommand:
        joints = {"base": 120.0, "shoulder": shoulder, "elbow": -120.0}
        return ArmCommand(joints=joints, tool=home.tool, gripper_closed=False)

    bus.move(home)
    bus.move(to(80.0))  # (at 60° the jaws, hanging 11 cm below the TCP, are in the bin)
    confirmed = ArmState.from_command(to(80.0))
    assert bus.state == confirmed
    with pytest.raises(SimCollisionError, match="touches bin_red_") as info:
        bus.move(to(40.0))
    assert info.value.last_state == confirmed
    assert str(info.value).endswith(f"; last acknowledged pose: {confirmed}")
    assert bus.state == confirmed and bus.fault is info.value
    with pytest.raises(ServoFaultedError) as refused:
        bus.move(home)
    assert refused.value.last_state == confirmed


@pytest.mark.heavy
def test_a_collision_on_the_virtual_uno_names_the_last_confirmed_pose(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The firmware acknowledged two moves; the third's pulses put the gripper in the bin's
    bin: the fault names the second pose, and the simulated arm stays there."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _config("virtual_uno")
    bus = open_bus(config, World.from_config(config))
    assert isinstance(bus, VirtualUnoBus)
    with bus:
        _into_the_red_bin(bus, config)
        tolerance = config.servo.virtual_uno.pulse_tolerance_us
        for j in bus.servo_map.joints:  # where the second move's pulses put it
            assert bus.state is not None
            sent = bus.state.joints[j.name]
            assert bus.actual_joints[j.name] == pytest.approx(sent, abs=tolerance / j.us_per_unit)


def test_a_collision_on_the_kinematic_simulator_names_the_last_confirmed_pose() -> None:
    """The same on the kinematic simulator, whose arm is its own bus."""
    config = _config("sim")
    bus = SimArm(config, World.from_config(config))
    with bus:
        _into_the_red_bin(bus, config)
