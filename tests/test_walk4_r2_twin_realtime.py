"""``servo.sim_realtime`` paces the twin's holds too, as it does the kinematic sim's.

A gripper setting is a hold (the jaws' travel and the tool's settling): with the twin the
physics ran the hold at once, so a paced sort of the paper's scene took 10 s of wall time
for 24.8 s of motion, 16.5 s of it gripper settings, while the kinematic sim (and a real
link) waits them out.
"""

from __future__ import annotations

import time

from conftest import ROOT

from mearm.config import load_config
from mearm.hardware.bus import ArmCommand
from mearm.sim.twin.mjcf import twin_model
from mearm.sim.twin.twin_bus import TwinArm

HOLD_S = 0.5


def _twin(*overrides: str) -> TwinArm:
    config = load_config(ROOT / "configs" / "sim.yaml", list(overrides))
    arm = TwinArm(config, twin_model(config))
    arm.connect()
    return arm


def test_a_paced_twin_waits_its_holds_out() -> None:
    """With sim_realtime a hold takes its time on the wall clock and in the twin's."""
    arm = _twin("servo.sim_realtime=true")
    assert arm.paced
    start_s, start = arm.time_s, time.monotonic()
    arm.hold(HOLD_S)
    assert time.monotonic() - start >= HOLD_S
    assert abs(arm.time_s - start_s - HOLD_S) < 1e-9


def test_an_unpaced_twin_only_runs_its_physics() -> None:
    """Without it the hold is the physics only (the sweeps' speed); the clock still moves."""
    arm = _twin()
    assert not arm.paced
    start_s = arm.time_s
    arm.hold(HOLD_S)
    assert abs(arm.time_s - start_s - HOLD_S) < 1e-9


def test_a_paced_twin_waits_for_arrival_on_the_wall_clock() -> None:
    """A 60° step's wait for arrival (its servo's datasheet time) takes that time too."""
    arm = _twin("servo.sim_realtime=true")
    joints = arm.config.arm.home()
    joints[arm.servos[0].name] -= 60.0
    tool = {a.name: a.home for a in arm.config.arm.tool.actuators}
    arm.move(ArmCommand(joints, tool, False))
    start = time.monotonic()
    waited = arm.await_arrival(2.0)
    assert waited > 0.1
    assert time.monotonic() - start >= waited - arm.period_s
