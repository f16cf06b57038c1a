"""``mearm servo-steps --degrees``: a step no joint can take is refused up front, by name.

The paper arm's shoulder (home 93°, limits 30 … 135°) has no room for 90° with the tool
above the table, nor for 70°. The command measured the joints before it and then stopped
on ``shoulder = 3 deg is outside its limits``: a value the user never gave, and no word
of ``--degrees`` or what it allows.
"""

from __future__ import annotations

import pytest

from mearm.errors import MearmError
from mearm.tools import servo_steps


@pytest.mark.parametrize(
    ("config", "degrees", "message"),
    [
        ("sim_mujoco", "90", "--degrees 90: shoulder cannot step 90 deg inside its limits"),
        ("sim_mujoco", "70", "--degrees 70: shoulder cannot step 70 deg inside its limits"),
    ],
)
def test_a_step_without_room_is_refused_naming_the_flag(tmp_path, config, degrees, message):
    out = tmp_path / "steps.csv"
    with pytest.raises(MearmError) as exc:
        servo_steps.main(["--config", config, "--degrees", "10", degrees, "--csv", str(out)])
    assert str(exc.value).startswith(message), str(exc.value)
    assert "at most" in str(exc.value)
    assert not out.exists()


def test_the_largest_step_named_is_one_the_joint_takes():
    """The room named (62.4° for the paper arm's shoulder, up to its upper limit with the
    tool above the table) is a step it takes, 0.1° more not."""
    from mearm.config import load_config

    config = load_config("sim_mujoco")
    with pytest.raises(MearmError, match="at most 62.4 here"):
        servo_steps.check_steps(config, [90.0])
    assert servo_steps.step_command(config, "shoulder", 62.4) is not None
    assert servo_steps.step_command(config, "shoulder", 62.5) is None


def test_no_step_puts_the_tool_below_the_table():
    """The paper arm's shoulder stepped 60° down from home (to 33°) drove its jaws into the
    table and stopped 40° short, plotted as its response: it now steps up from 75° to its
    upper limit, and every pose on the way keeps the tool above the table."""
    from mearm.config import load_config

    config = load_config("sim_mujoco")
    clear = servo_steps._Clearance(config)
    assert not clear.above({**config.arm.home(), "shoulder": 33.0})
    steps = servo_steps.step_command(config, "shoulder", 60.0, clear)
    assert steps is not None
    start, end = steps
    assert (start.joints["shoulder"], end.joints["shoulder"]) == (75.0, 135.0)
