"""The virtual Uno's arm stops at its joints' limits, as the twin's joints do.

A pulse that sends a joint past its limits (``calibrate-servos`` may send any pulse in the
servo's range; a miswired board anything) leaves the joint at its stop, and what reports
the arm (its joints, its TCP, the calibration screen's reading) says where it is. A servo
that turns a combination of joints keeps turning it when another joint of it is stopped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from test_virtual_uno import cache_home  # noqa: F401  (a fixture)

from mearm.config import Config, config_from_dict, load_config
from mearm.hardware import ServoMap
from mearm.maker.keyboard_calibration.pulse_session import PulseSession
from mearm.sim import World
from mearm.sim.kinematic.joint_stops import joints_at_stops
from mearm.sim.kinematic.servo_bus import ee_from_joints_cm
from mearm.sim.virtual_uno import VirtualUnoBus

ROOT = Path(__file__).resolve().parent.parent


def _mearm_v1() -> Config:
    return load_config(ROOT / "configs" / "sim_mearm_v1.yaml")


def test_a_servo_over_its_own_joint_stops_it_at_the_limit() -> None:
    """The paper arm (each servo turns its joint): past a limit, the limit; inside, the value."""
    arm = config_from_dict({}).arm
    smap, stops = ServoMap.from_arm(arm), arm.joint_limits()
    assert joints_at_stops(smap, {"base": 0.0, "shoulder": 93.0, "elbow": -170.0}, stops) == {
        "base": 20.0,
        "shoulder": 93.0,
        "elbow": -160.0,
    }
    inside = {"base": 20.0, "shoulder": 134.9, "elbow": -20.5}
    assert joints_at_stops(smap, inside, stops) == smap.joints_of(inside)


def test_the_mearm_elbow_servo_keeps_the_forearm_when_the_shoulder_is_stopped() -> None:
    """Shoulder sent to 160° (stop 150°), forearm level: the shoulder stops at 150° and the
    elbow servo still puts the forearm (shoulder + elbow) at 0°."""
    arm = _mearm_v1().arm
    smap, stops = ServoMap.from_arm(arm), arm.joint_limits()
    q = joints_at_stops(smap, {"base": 90.0, "shoulder": 160.0, "elbow": 0.0}, stops)
    assert q["shoulder"] == 150.0
    assert q["shoulder"] + q["elbow"] == pytest.approx(0.0, abs=1e-8)


def test_the_mearm_elbow_at_its_stop_turns_the_shoulder_instead() -> None:
    """Forearm sent to -75° with the shoulder at 90°: the elbow would be -165°, past its
    -150° stop; the elbow servo then pulls the shoulder down against the shoulder's servo,
    each by its error in µs (11 and 12.37 µs/deg): the shoulder at
    (11²·90 + 12.37²·75) / (11² + 12.37²)."""
    arm = _mearm_v1().arm
    smap, stops = ServoMap.from_arm(arm), arm.joint_limits()
    q = joints_at_stops(smap, {"base": 90.0, "shoulder": 90.0, "elbow": -75.0}, stops)
    k1, k2 = smap["shoulder"].us_per_unit, smap["elbow"].us_per_unit
    assert q["elbow"] == -150.0
    assert q["shoulder"] == pytest.approx((k1**2 * 90 + k2**2 * 75) / (k1**2 + k2**2), abs=1e-7)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(-200.0, 200.0), min_size=3, max_size=3))
@example([45.0, 0.0, 0.0])  # the base at its stop, where SciPy's answer is 8.5e-6 off
def test_the_stopped_joints_are_scipys_bounded_least_squares(values: list[float]) -> None:
    """Any servo values: no joint past its stops, and the joints are the bounded
    least-squares solution SciPy finds for the servos' errors in µs."""
    lsq_linear = pytest.importorskip("scipy.optimize").lsq_linear
    arm = _mearm_v1().arm
    smap, stops = ServoMap.from_arm(arm), arm.joint_limits()
    servo = dict(zip(smap.joint_names, values, strict=True))
    q = joints_at_stops(smap, servo, stops)
    lower = np.array([stops[n].min for n in smap.joint_names])
    upper = np.array([stops[n].max for n in smap.joint_names])
    got = np.array([q[n] for n in smap.joint_names])
    assert np.all((lower <= got) & (got <= upper))
    combination = smap.combination
    assert combination is not None
    A, a = combination
    k = np.array([j.us_per_unit for j in smap.joints])
    M, b = k[:, None] * A, k * (np.array(values) - a)
    # SciPy's answer is itself within its tolerance (at values [45, 0, 0] its base was
    # 45.0000085 where the stop is 45): the two must agree to that, and ours must be at
    # least as good a solution, which holds it to what the function promises exactly
    want = lsq_linear(M, b, bounds=(lower, upper), tol=1e-12)
    np.testing.assert_allclose(got, want.x, atol=1e-4)
    cost = np.sum((M @ got - b) ** 2)
    assert cost <= np.sum((M @ want.x - b) ** 2) + 1e-9 * max(1.0, cost)


@pytest.mark.heavy
def test_a_pulse_past_the_base_limit_leaves_the_arm_at_its_stop(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """``calibrate-servos`` sends the base 600 µs (0° under its calibration, limits
    [20, 160]°): the pin carries 600 µs, the arm's base stands at 20°, and its TCP and the
    calibration screen's reading say so."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = config_from_dict(
        {
            "task": {"scene": []},
            "servo": {"backend": "virtual_uno", "ack_timeout_s": 10.0, "virtual_uno": {"speed": 0}},
        }
    )
    with VirtualUnoBus(config, World.from_config(config)) as bus:
        session = PulseSession(config, bus)
        session.send()
        session.set_pulse("base", 600)
        base = session.servo_map["base"]
        assert bus.measured_pulses_us()[base.channel] == pytest.approx(600, abs=10)
        assert bus.actual_joints["base"] == 20.0
        assert session.simulated_value("base") == 20.0
        np.testing.assert_allclose(bus.ee_cm, ee_from_joints_cm(bus.arm.model, bus.actual_joints))
        tolerance = config.servo.virtual_uno.pulse_tolerance_us / base.us_per_unit
        assert bus.actual_joints["shoulder"] == pytest.approx(93.0, abs=tolerance)
