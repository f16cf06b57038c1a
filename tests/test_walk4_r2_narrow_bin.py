"""A twin's bin narrower than its class's objects is refused before the sort starts.

``task.classes.<name>.bin_width_cm`` accepted any size from 0.1 cm: the twin built a
0.1 cm bin for 2 cm discs, and the sort ran, dropped them on its walls and ended
``sorted 8 of 12`` (exit 1) with no word of why. Such a bin can hold none of them: bad
input, exit 2 with one line naming the class and the width it needs.
"""

from __future__ import annotations

from badinput import check_bad_input

from mearm.config import load_config
from mearm.sim.twin.mjcf import generate_mjcf


def test_a_bin_as_wide_as_its_objects_is_built() -> None:
    """The bound: a bin exactly one object wide still holds one."""
    config = load_config("sim_mujoco", ["task.classes.red.bin_width_cm=2.0"])
    assert "red" in generate_mjcf(config)


def test_a_bin_narrower_than_its_objects_is_refused() -> None:
    out = check_bad_input(
        ["sort", "--config", "sim_mujoco", "--quiet", "--set", "task.classes.red.bin_width_cm=1.5"]
    )
    assert "class red: its bin is 1.5 cm wide inside (bin_width_cm)" in out.stderr
    assert "make it at least 2 cm" in out.stderr
