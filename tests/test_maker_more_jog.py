"""``mearm jog`` stops on the end of a servo's pulse range, as on a joint's limit.

The MeArm v1's elbow servo turns the forearm's angle to the table, shoulder + elbow, and
its 544..2400 µs hold that angle within ±75.0002°: a bound on the combination, which a
shoulder step reaches inside every joint's limits. A step that would cross it must stop
on it (or that end is out of reach whenever the step does not divide the room to it),
and only a step from it onwards is refused. In-process on the ``sim`` backend, and once
through a pseudo-terminal as ``test_maker_jog`` drives the command.
"""

from __future__ import annotations

import io
import re

import pytest
from test_maker_calibrate import ROOT, PtyCommand
from test_maker_jog import readout

from mearm.config import Config, load_config
from mearm.hardware import ServoBus, ServoMap
from mearm.maker.calibrate_servos import open_arm_bus
from mearm.maker.jog import JOINT_STEPS, Jogger, Refused

MEARM = ROOT / "configs" / "sim_mearm_v1.yaml"
CONFIG = load_config(MEARM)
FOREARM = ServoMap.from_arm(CONFIG.arm)["elbow"]  # its servo: shoulder + elbow
LOW_END, HIGH_END = FOREARM.pulse_limits  # -75.0002°, +75.0002°: 544 and 2400 µs
FOREARM_LINE = re.compile(
    r"  elbow's servo \(shoulder \+ elbow\): (-?[\d.]+) deg   to its pulse range "
    r"-(-?[\d.]+) / \+(-?[\d.]+) deg"
)


def _forearm_down(config: Config, bus: ServoBus) -> Jogger:
    """A jogger on the MeArm v1 (a cleared table) with the shoulder at 70° (2 steps of 10°
    down from home) and the elbow, selected, 5 steps of 10° down from -90°: -140°, the
    forearm at -70°."""
    jogger = Jogger(config, bus, io.StringIO())
    jogger.executor.home_pose()
    jogger.step_index = JOINT_STEPS.index(10.0)
    jogger.selected = 1  # the shoulder
    for _ in range(2):
        jogger.move_joint(-1)
    jogger.selected = 2  # the elbow
    for _ in range(5):
        jogger.move_joint(-1)
    joints = jogger.chain.named(jogger.executor.q_now())
    assert (joints["shoulder"], joints["elbow"]) == pytest.approx((70.0, -140.0))
    return jogger


def test_an_elbow_step_down_stops_on_the_forearm_servos_low_end_before_its_limit():
    """The elbow from -140° (the forearm at -70°) by 10° toward -150° (its own limit, the
    forearm at -80°) stops where the forearm reaches -75.0002° (544 µs), the elbow at
    -145.0002°; the next step down (2°: the elbow inside its limits) is refused naming the
    servo, nothing sent; a step back up goes."""
    with open_arm_bus(CONFIG) as bus:
        jogger = _forearm_down(CONFIG, bus)
        jogger.move_joint(-1)
        joints = jogger.chain.named(jogger.executor.q_now())
        forearm = joints["shoulder"] + joints["elbow"]
        assert forearm == pytest.approx(LOW_END, abs=1e-9) and forearm >= LOW_END
        assert joints["elbow"] == pytest.approx(LOW_END - 70.0, abs=1e-9)
        assert bus.state is not None
        assert FOREARM.command_us(FOREARM.servo_value(bus.state.joints)) == 544
        sent = bus.state
        jogger.step_index = JOINT_STEPS.index(2.0)  # to -147°: inside the elbow's limits
        past = r"elbow's servo \(shoulder \+ elbow\) = -7[5-9]"  # its path's first pose past
        with pytest.raises(Refused, match=past):
            jogger.move_joint(-1)
        assert bus.state == sent
        jogger.move_joint(+1)  # away from the end: not refused
        joints = jogger.chain.named(jogger.executor.q_now())
        assert joints["elbow"] == pytest.approx(LOW_END - 68.0, abs=1e-9)


def test_a_step_stops_on_whichever_bound_comes_first():
    """The same elbow step with the elbow's limit at -144° (short of the -145.0002° where
    the forearm reaches its end): it stops on that limit, the forearm at -74°; the next
    is refused by the limit."""
    config = load_config(MEARM, ["arm.joints.elbow.limits={min: -144, max: -20}"])
    with open_arm_bus(config) as bus:
        jogger = _forearm_down(config, bus)
        jogger.move_joint(-1)
        joints = jogger.chain.named(jogger.executor.q_now())
        assert joints["elbow"] == pytest.approx(-144.0, abs=1e-9)
        assert joints["shoulder"] + joints["elbow"] == pytest.approx(-74.0, abs=1e-9)
        with pytest.raises(Refused, match=r"elbow would be at -154 deg, outside its limits"):
            jogger.move_joint(-1)


@pytest.mark.heavy
def test_jog_lands_on_the_forearm_servos_end_then_refuses_past_it():
    """Through the terminal: the elbow 7 steps of 10° up (the forearm at +70°), then the
    shoulder up: the readout shows the forearm on +75.000°, no room left to the pulse
    range's end, the shoulder at 95.000°; the next step is refused naming the servo."""
    cmd = PtyCommand("jog", "--config", str(MEARM))
    try:
        readout(cmd)
        cmd.send("3]]" + "+" * 7)
        for _ in range(10):
            joints, _ = readout(cmd)
        assert joints["elbow"] == pytest.approx(-20.0, abs=1e-3)
        cmd.send("2+")
        readout(cmd)
        joints, _ = readout(cmd)
        assert joints["shoulder"] == pytest.approx(90.0 + HIGH_END - 70.0, abs=1e-3)
        assert FOREARM_LINE.findall(cmd.text)[-1] == ("75.000", "150.000", "0.000")
        cmd.send("+")
        cmd.expect(
            r"refused: elbow's servo \(shoulder \+ elbow\) = 7[5-9][.\d]* deg needs a [\d.]+ µs "
            r"pulse on channel 2, outside its \[544, 2400\] µs.*; nothing sent"
        )
        cmd.send("Q")
        assert cmd.wait() == 0, cmd.text[-2000:]
    finally:
        cmd.close()
