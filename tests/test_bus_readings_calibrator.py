"""``calibrate-servos`` reads where a simulated arm really is through the bus protocols.

:class:`~mearm.hardware.bus.MeasuresJoints` (``actual_joints``) and
:class:`~mearm.hardware.bus.MeasuresTool` (``actual_tool``) say a bus reports the joints
and tool actuators its arm realised; the session's readings, and the screen's
"simulated arm: …", come from them. On the kinematic sim and the MuJoCo twin the readings
are shown as before; a stand-in bus that reports them as read-only mappings (all the
protocols ask for) gets them too, where the session once looked for a ``dict`` under
those names and said nothing. In-process, on the status line a terminal would get.
"""

from __future__ import annotations

import io
import re
from collections.abc import Mapping
from types import MappingProxyType

import pytest
from test_maker_calibrate import ROOT

from mearm.config import Config, load_config
from mearm.hardware import ArmCommand, ServoBus
from mearm.hardware.bus import MeasuresJoints, MeasuresPulses, MeasuresTool
from mearm.maker.calibrate_servos import Calibrator, actuators_of
from mearm.maker.keyboard_calibration.pulse_session import PulseSession, open_arm_bus

SIM = load_config(ROOT / "configs" / "sim.yaml")
V1_TWIN = load_config(ROOT / "configs" / "sim_mearm_v1_mujoco.yaml")
READING = re.compile(r"simulated arm: (-?[\d.]+) (deg|cm)")
NO_READING = "simulated arm: no reading of gripper (not measured by this simulator)"


class Terminal(io.StringIO):
    """The screen of a terminal: the calibrator writes its live status line to it."""

    def isatty(self) -> bool:
        return True


def status_lines(config: Config, session: PulseSession) -> dict[str, str]:
    """Each actuator's status line as the calibrator shows it now, by name."""
    out = Terminal()
    calibrator = Calibrator(config, session, None, out)
    lines = {}
    for act in actuators_of(config):
        calibrator.status(act, act.references[0])
        lines[act.name] = out.getvalue().rsplit("\x1b[K", 1)[-1]
    return lines


def reading(line: str) -> float:
    found = READING.search(line)
    assert found is not None, line
    return float(found.group(1))


def test_the_kinematic_sim_shows_its_joints_and_tool_actuator():
    """The kinematic sim reports its joints and its tool actuator: each shows the value
    its pulse stands for (the sim realises it, to the µs); the gripper, only open or
    closed there, shows that it has no reading."""
    with open_arm_bus(SIM) as bus:
        assert isinstance(bus, MeasuresJoints) and isinstance(bus, MeasuresTool)
        assert not isinstance(bus, MeasuresPulses)
        session = PulseSession(SIM, bus)
        session.set_pulse("shoulder", session.pulses_us["shoulder"] + 50)
        session.set_pulse("gripper_arm", session.pulses_us["gripper_arm"] - 50)
        lines = status_lines(SIM, session)
        values = {**session.joint_values(), **session.actuator_values()}
    assert set(lines) == {"base", "shoulder", "elbow", "gripper_arm", "gripper"}
    for name in ("base", "shoulder", "elbow", "gripper_arm"):
        assert reading(lines[name]) == pytest.approx(values[name], abs=0.01), lines[name]
    assert NO_READING in lines["gripper"]


def test_the_twin_shows_its_joints():
    """The MuJoCo twin (the MeArm v1, cleared table) reports its joints: each joint
    servo's reading is where the twin's servo took it, within a degree of the pulse's
    value (the elbow servo's: shoulder + elbow); it has no tool actuators to report, and
    the gripper shows that it has no reading."""
    from mearm.sim.twin.twin_bus import TwinArm  # noqa: PLC0415  (MuJoCo: on use)

    scene = V1_TWIN.task.model_copy(update={"scene": []})
    with TwinArm(V1_TWIN.model_copy(update={"task": scene})) as twin:
        assert isinstance(twin, MeasuresJoints) and not isinstance(twin, MeasuresTool)
        session = PulseSession(V1_TWIN, twin)
        session.set_pulse("base", session.pulses_us["base"] + 100)
        twin.settle(1.0)
        lines = status_lines(V1_TWIN, session)
        values = session.joint_values()
    assert set(lines) == {"base", "shoulder", "elbow", "gripper"}
    assert abs(values["base"] - 90.0) > 5.0  # moved off home, where the twin followed
    for name in ("base", "shoulder", "elbow"):
        assert reading(lines[name]) == pytest.approx(values[name], abs=1.0), lines[name]
    assert NO_READING in lines["gripper"]


class ViewsArm(ServoBus):
    """A stand-in simulated arm that realises every command exactly and reports where it
    is as read-only views (:class:`~types.MappingProxyType`): the protocols' types, not a
    ``dict``."""

    def __init__(self, config: Config):
        super().__init__(config.arm, config.servo, paced=False)
        self._joints = config.arm.home()
        self._tool = {a.name: a.home for a in config.arm.tool.actuators}

    @property
    def actual_joints(self) -> Mapping[str, float]:
        return MappingProxyType(self._joints)

    @property
    def actual_tool(self) -> Mapping[str, float]:
        return MappingProxyType(self._tool)

    def _connect(self) -> None:
        pass

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        self._joints = dict(command.joints)
        self._tool = dict(command.tool)

    def _stop(self) -> None:
        pass

    def _close(self) -> None:
        pass


def test_a_bus_reporting_read_only_views_gets_the_readings():
    """The stand-in reports its joints and tool actuator as the protocols ask: the session
    counts it a simulated arm and every joint and the tool actuator shows its reading (the
    pulse's value); the gripper says it has none."""
    with ViewsArm(SIM) as bus:
        assert isinstance(bus, MeasuresJoints) and isinstance(bus, MeasuresTool)
        session = PulseSession(SIM, bus)
        session.set_pulse("elbow", session.pulses_us["elbow"] + 50)
        assert session.simulated
        lines = status_lines(SIM, session)
        values = {**session.joint_values(), **session.actuator_values()}
    for name in ("base", "shoulder", "elbow", "gripper_arm"):
        assert reading(lines[name]) == pytest.approx(values[name], abs=1e-6), lines[name]
    assert NO_READING in lines["gripper"]
