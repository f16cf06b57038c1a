"""``mearm servo-steps --degrees``: a step no joint can take is refused up front, by name.

The paper arm's shoulder (home 93°, limits 30 … 135°) has no room for 90° either way;
the MeArm v1's base (home 90°, 45 … 135°) none for the default 60°. The command measured
the joints before it and then stopped on ``shoulder = 3 deg is outside its limits``: a
value the user never gave, and no word of ``--degrees`` or what it allows.
"""

from __future__ import annotations

import pytest

from mearm.errors import MearmError
from mearm.tools import servo_steps


@pytest.mark.parametrize(
    ("config", "degrees", "message"),
    [
        ("sim_mujoco", "90", "--degrees 90: shoulder cannot step 90 deg either way"),
        ("sim_mearm_v1_mujoco", "60", "--degrees 60: base cannot step 60 deg either way"),
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
    """The room named (63° for the paper arm's shoulder) is a step it takes, 0.1° more not."""
    from mearm.config import load_config

    config = load_config("sim_mujoco")
    assert servo_steps.step_command(config, "shoulder", 63.0) is not None
    assert servo_steps.step_command(config, "shoulder", 63.1) is None
