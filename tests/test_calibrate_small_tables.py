"""The kit twin calibrates its servos by the camera over a table of a few objects too.

``mearm sort --config sim_mujoco_kits`` with two reds (also ``--random 4`` to ``7`` on
several seeds, one red, a green and two blues) stopped before any pick: "no point over
the view passes the moves' checks while the servos' errors are unknown (… the final move:
gripper_jaw_right_pad comes within 16.19 cm of bin_red_wall_px (closer than the 16.19 cm
it started at) …)". A visit's clearance is ``task.clearance_cm`` plus the doubt's reach
where it is largest on the way (at home: some 16 cm); a wall within it where the final
move starts may come no closer, and over a table whose bins' walls stand low (few
objects) the final move to every point came 0.01 cm nearer one. The final move keeps the
doubt's reach along itself, which is what the tool may stray by there.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import mearm_here

TWO_REDS = "task.scene=[{color: red, x: -5, y: 45}, {color: red, x: 6, y: 50}]"


@pytest.mark.slow
def test_two_reds_on_the_kit_twin_are_calibrated_for_then_sorted(tmp_path: Path) -> None:
    done = mearm_here("sort", "--config", "sim_mujoco_kits", "--set", TWO_REDS, "--quiet",
                      cwd=tmp_path)  # fmt: skip
    assert done.returncode == 0, done.stdout[-600:] + done.stderr[-600:]
    assert done.stdout.strip().splitlines()[-1] == "sorted 2 of 2 objects (simulated)"
