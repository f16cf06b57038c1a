"""The joints' limits in the keyboard commands: ``calibrate-servos`` warns past them,
``jog`` lands on them.

``calibrate-servos`` lets the keys range over the whole pulse range (the fit needs it),
so under the present calibration a joint can be jogged past its limits — the MeArm v1's
base reads 180.9° at 544 µs against its [45, 135]° (the simulated arm stops at 135°, as
the twin's does) — and the screen must say so, once each time it crosses. ``jog``
refuses a step past a limit; a step that would cross it must stop on it, or the limit is
out of reach whenever the step does not divide the room to it. Driven through a
pseudo-terminal as ``test_maker_calibrate`` and ``test_maker_jog`` do, on the ``sim``
backend (no board); the passive joint's case in-process.
"""

from __future__ import annotations

import io
import re

import pytest
from test_maker_calibrate import ROOT, PtyCommand
from test_maker_jog import SIM, readout

from mearm.config import load_config
from mearm.hardware import ServoMap
from mearm.maker.calibrate_servos import open_arm_bus
from mearm.maker.jog import JOINT_STEPS, Jogger, Refused

MEARM = ROOT / "configs" / "sim_mearm_v1.yaml"
WARNING = re.compile(r"warning: base is at ([\d.]+) deg, past its limits \[45, 135\] deg: "
                     r"the links may collide")  # fmt: skip


@pytest.mark.heavy
def test_calibrate_servos_warns_once_per_crossing_of_a_joints_limits(tmp_path):
    """The MeArm v1's base jogged in 20 µs steps from home (90°) up past 135°, on to the
    pulse range's end (180.9° by the calibration), back inside and out again: one warning
    naming the joint, its angle and its limits at each crossing out, one line back inside,
    none in between; the keys still reach the end of the pulse range, where the simulated
    arm stands at its stop (135°), and the screen says the pulse is past the limits."""
    base = ServoMap.from_arm(load_config(MEARM).arm)["base"]  # 2534 µs - 11 µs/deg
    cmd = PtyCommand("calibrate-servos", "--config", str(MEARM), "--actuators", "base",
                     "--output", str(tmp_path / "servos.yaml"))  # fmt: skip
    try:
        start = int(cmd.expect(r"base: pulse (\d+) µs").group(1))
        assert start == base.command_us(90.0) == 1544
        # 24 steps down: 1064 µs, 133.6°, inside; the 25th: 1044 µs, 135.45°, past
        cmd.send("3" + "-" * 24)
        cmd.expect(r"base: pulse 1064 µs  step 20 µs")
        assert "warning" not in cmd.text
        cmd.send("-")
        angle = float(cmd.expect(WARNING.pattern).group(1))
        assert angle == pytest.approx(base.value_of(1044), abs=0.05)  # 135.45°, shown 135.5
        cmd.send("-" * 30)  # on past the limit to the pulse range's end, and pressed on
        cmd.expect(r"base: pulse 544 µs .*simulated arm: 135\.00 deg  \(end of the pulse range\)"
                   r"  \(past the limits: base\)")  # fmt: skip
        cmd.send("+" * 26)  # back to 1064 µs
        cmd.expect(r"base is back inside its limits \[45, 135\] deg")
        cmd.expect(r"base: pulse 1064 µs")
        cmd.send("-")
        cmd.expect(WARNING.pattern)
        cmd.expect(r"base: pulse 1044 µs")
        cmd.send("q")
        assert cmd.wait() == 1, cmd.text[-2000:]
    finally:
        cmd.close()
    assert len(WARNING.findall(cmd.text)) == 2, cmd.text[-3000:]
    assert cmd.text.count("back inside") == 1


@pytest.mark.heavy
def test_jog_lands_on_a_joints_limit_then_refuses_past_it():
    """The shoulder from 93° in 10° steps: 133°, then 135° (its limit), not refused at
    143°; the next step is refused, nothing sent."""
    cmd = PtyCommand("jog", "--config", str(SIM))
    try:
        readout(cmd)
        cmd.send("2]]" + "+" * 5)
        for _ in range(7):
            joints, _ = readout(cmd)
        assert joints["shoulder"] == pytest.approx(133.0, abs=1e-3)
        joints, _ = readout(cmd)
        assert joints["shoulder"] == pytest.approx(135.0, abs=1e-9)
        assert re.search(
            r"\* shoulder +135\.000 deg   to limits -105\.000 / \+0\.000 deg", cmd.text
        )
        cmd.send("+")
        cmd.expect(r"refused: shoulder would be at 145 deg, outside its limits \[30, 135\] deg")
        cmd.send("Q")
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
    assert "refused: shoulder would be at 143" not in cmd.text


def test_jog_stops_where_a_passive_joint_reaches_its_limit():
    """The paper arm's wrist follows -(shoulder + elbow): with its limit at 45° (39° at
    home) a 10° shoulder step down stops after 6°, the wrist on 45°; the next is refused
    naming the wrist."""
    config = load_config(SIM, ["arm.joints.wrist.limits={min: -115, max: 45}"])
    with open_arm_bus(config) as bus:
        jogger = Jogger(config, bus, io.StringIO())
        jogger.executor.home_pose()
        jogger.step_index = JOINT_STEPS.index(10.0)
        jogger.selected = 1  # the shoulder
        jogger.move_joint(-1)
        joints = jogger.chain.named(jogger.executor.q_now())
        assert joints["shoulder"] == pytest.approx(87.0, abs=1e-9)
        assert joints["wrist"] == pytest.approx(45.0, abs=1e-9)
        sent = bus.state
        with pytest.raises(Refused, match=r"wrist would be at 55 deg, outside its limits"):
            jogger.move_joint(-1)
        assert bus.state == sent
