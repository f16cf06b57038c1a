"""``calibrate-servos`` and ``jog`` on the virtual Uno stand on a cleared table.

Calibration turns each servo alone across its range, where the arm sweeps low over the
table: on the ``sim`` backend its simulated arm stood on a cleared table, but the virtual
Uno laid out its own (bins and objects), so the paper arm's shoulder jogged to its first
reference (50°) with the base left at its second (130°) ran the gripper into the red
bin's wall, and the session ended with a servo fault.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_virtual_uno import cache_home  # noqa: F401  (a fixture)

from mearm.config import load_config
from mearm.maker.keyboard_calibration.pulse_session import PulseSession, open_arm_bus
from mearm.maker.keyboard_calibration.references import (
    actuators_of,
    reference_pose,
    table_lowest,
)

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.heavy
def test_the_shoulder_at_its_reference_with_the_base_at_its_own_touches_no_bin(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Base at 130° (1900 µs), the elbow where the calibration puts it for the shoulder's
    references (its jaws, hanging 11 cm below the TCP, kept off the table), then the
    shoulder down to its reference, 50° (1100 µs), as the keys take it: no fault, and the
    board's simulated arm has no bin or object to touch."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = load_config(ROOT / "configs" / "virtual_uno.yaml", ["servo.ack_timeout_s=10"])
    bus = open_arm_bus(config)
    with bus:
        session = PulseSession(config, bus)
        session.send()
        session.set_pulse("base", 1900)
        smap = session.servo_map
        (shoulder,) = [a for a in actuators_of(config) if a.name == "shoulder"]
        present = {n: v for n, v in session.joint_values().items() if n != "shoulder"}
        pose = reference_pose(
            smap, shoulder, present, session.home_values, table_lowest(config, smap)
        )
        for name, value in pose.items():
            session.set_pulse(name, smap[name].command_us(value))
        for pulse in [*range(session.pulses_us["shoulder"], 1100, -20), 1100]:
            session.set_pulse("shoulder", pulse)
        assert (session.pulses_us["base"], session.pulses_us["shoulder"]) == (1900, 1100)
    world = bus.world  # type: ignore[attr-defined]
    assert not world.bins and not world.objects
