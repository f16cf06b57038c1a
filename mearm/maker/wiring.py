"""Which servo goes on which pin: an arm's wiring table and diagram, read from its config.

Every servo of the arm (its joints', its tool actuators', its gripper's) has a
``channel`` in the arm's description; the board maps a channel to a pin. On the Uno
firmware channels 0..4 are pins D3, D5, D6, D9 and D10 (``SERVO_PIN_<i>`` in
tools/arduino/mearm_servo/mearm_servo.ino); on an SSC-32 the channel is the pin's number
printed on the board. Each row also gives the servo's pulse at the arm's home pose, the
pulse the arm is sent first: the horns go on with the joints in that pose. ::

    print(wiring_text(load_config("sim_mearm_v1").arm, board="uno"))
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from mearm.config.arm import ArmDescription, ServoCalibration

#: The Uno firmware's pins by channel (``SERVO_PIN_0`` .. ``SERVO_PIN_4`` of
#: tools/arduino/mearm_servo/mearm_servo.ino; tests/test_init_config.py reads them there).
UNO_PINS: tuple[str, ...] = ("D3", "D5", "D6", "D9", "D10")

Board = Literal["uno", "ssc32"]


@dataclass(frozen=True)
class WireRow:
    """One servo's wiring.

    Attributes:
        channel: The servo's channel in the arm's description.
        pin: Where its signal wire goes on the board (``"D3"``, ``"ch 3"``).
        actuator: What it moves: a joint, a tool actuator or the gripper.
        turns: What its angle is (``"base"``, ``"shoulder + elbow"``, ``"opening"``).
        home: The value it is sent first, at the arm's home pose, with its unit.
        home_us: That value's pulse under the description's calibration [µs].
    """

    channel: int
    pin: str
    actuator: str
    turns: str
    home: str
    home_us: float


def _pin(channel: int, board: Board) -> str:
    if board == "ssc32":
        return f"ch {channel}"
    return UNO_PINS[channel] if channel < len(UNO_PINS) else f"none (channel {channel})"


def wiring_rows(arm: ArmDescription, board: Board = "uno") -> list[WireRow]:
    """The arm's servos, one row each, in channel order."""
    home = arm.full_values(arm.home())
    raw: list[tuple[int, str, str, float, str, ServoCalibration]] = []
    for joint in arm.actuated_joints():
        assert joint.servo is not None  # an actuated joint has one
        combo = joint.servo.combination(joint.name)
        value = combo.offset + sum(c * home[name] for name, c in combo.terms.items())
        raw.append((joint.servo.channel, joint.name, combo.text(), value, joint.unit, joint.servo))
    for actuator in arm.tool.actuators:
        value = actuator.setting("home")
        raw.append(
            (actuator.servo.channel, actuator.name, actuator.name, value, "deg", actuator.servo)
        )
    gripper = arm.tool.gripper
    if gripper is not None:
        raw.append(
            (gripper.servo.channel, gripper.name, "opening", gripper.open_cm, "cm", gripper.servo)
        )
    rows = [
        WireRow(ch, _pin(ch, board), name, turns, f"{value:g} {unit}", servo.pulse_us(value))
        for ch, name, turns, value, unit, servo in raw
    ]
    return sorted(rows, key=lambda r: r.channel)


def wiring_table(arm: ArmDescription, board: Board = "uno") -> str:
    """The wiring as a Markdown table (channel, pin, servo, its angle, home and its pulse)."""
    head = (
        "| channel | pin | servo | its angle | at home | home pulse |\n|---|---|---|---|---|---|\n"
    )
    body = "".join(
        f"| {r.channel} | {r.pin} | {r.actuator} | {r.turns} | {r.home} | {r.home_us:.0f} µs |\n"
        for r in wiring_rows(arm, board)
    )
    return head + body


def wiring_diagram(arm: ArmDescription, board: Board = "uno") -> str:
    """The wiring as a plain-text diagram: each signal wire, the supply and the ground."""
    rows = wiring_rows(arm, board)
    if board == "ssc32":
        width = max(len(r.pin) for r in rows)
        lines = ["  SSC-32 header   servo lead (signal, +, − on the header's three pins)"]
        lines += [f"  {r.pin:<{width}} ◄──────── {r.actuator}" for r in rows]
        lines += [
            "  VS terminal ◄── the servo supply (+ and −), its own supply",
            "  USB or DB9  ◄── the computer",
        ]
        return "\n".join(lines) + "\n"
    width = max(3, *(len(r.pin) for r in rows))
    pad = " " * (width + 5)
    lines = ["  Arduino Uno    servo (signal wire: orange, yellow or white)"]
    lines += [f"  {r.pin:<{width}} ─────── {r.actuator} (channel {r.channel})" for r in rows]
    lines += [
        f"  {'GND':<{width}} ──┬──── every servo's ground (brown or black)",
        f"{pad}└──── the servo supply's −  (one common ground)",
        f"{pad}┌──── every servo's + (red)",
        f"{pad}└──── the servo supply's +  (its own supply, never the Uno's 5 V pin)",
        f"  {'USB':<{width}} ─────── the computer",
    ]
    return "\n".join(lines) + "\n"


def wiring_text(arm: ArmDescription, board: Board = "uno") -> str:
    """The table and the diagram, as ``init-config`` prints them."""
    rows = wiring_rows(arm, board)
    width = max(len(r.actuator) for r in rows)
    table = "".join(
        f"  channel {r.channel}  {r.pin:<5} {r.actuator:<{width}}  turns {r.turns}; "
        f"home {r.home} = {r.home_us:.0f} µs\n"
        for r in rows
    )
    return table + "\n" + wiring_diagram(arm, board)


__all__ = ["UNO_PINS", "WireRow", "wiring_diagram", "wiring_rows", "wiring_table", "wiring_text"]
