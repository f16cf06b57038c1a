"""``mearm servo-steps``: each response starts at the command, t = 0, sampled every 4 ms.

Its first sample was taken after ``arm.move``, which runs one 20 ms command period: every
response in the CSV and the plot began at t = 0.0200 s, already 1.7° into a 10° step,
though the command says it samples every 4 ms for 0.6 s.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.tools import servo_steps


def test_a_response_starts_at_the_command_and_is_sampled_every_4_ms():
    config = load_config("sim_mujoco")
    rows = servo_steps.responses(config, [10.0])
    joints = [j.name for j in config.arm.actuated_joints()]
    assert sorted({r[0] for r in rows}) == sorted(joints)
    n = round(servo_steps.LENGTH_S / servo_steps.SAMPLE_S)
    for joint in joints:
        times = [t for j, _, t, _ in rows if j == joint]
        angles = [abs(a) for j, _, _, a in rows if j == joint]
        assert times == pytest.approx([k * servo_steps.SAMPLE_S for k in range(n)])
        assert angles[0] == 0.0  # the angle before the command
        assert 0.0 < angles[1] < 0.5  # 4 ms in: under way, far from there
        assert angles[:6] == sorted(angles[:6])  # the first command period, rising
        assert angles[-1] == pytest.approx(10.0, abs=1.0)
