"""A random table that holds none of its objects says why, with the share of the field.

The MeArm v1 with its links halved (a maker's scaled arm; the camera's field, the bins'
places and the config's own table halved to match, the objects and the bins kept at
their size) refused ``--random 12 --seed 31001`` in half a second with ``none fit in
20000 draws`` and nothing more: the 4.5 cm bins, each kept 1.75 cm from, cover 65 % of
the camera's field, the arm reaches only a sliver outside them, and there every pick
brings the jaws within the clearance of a bin's wall. Bins half as wide leave room
(three objects laid out).
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.task.scene import SceneError, random_scene

HALF = [
    "arm.joints.base.dh.d_cm=2.75",
    "arm.joints.shoulder.dh.a_cm=4.0",
    "arm.joints.elbow.dh.a_cm=4.0",
    "arm.joints.wrist.dh.a_cm=3.4",
    "arm.target_box.x_cm={min: -11.0, max: 11.0}",
    "arm.target_box.y_cm={min: 0.0, max: 11.5}",
    "arm.target_box.z_cm={min: 0.25, max: 12.5}",
    "calibration.homography=[[0.01875, 0.0, -6.0], [0.0, -0.01875, 12.0], [0.0, 0.0, 1.0]]",
    "task.classes.red.bin_cm=[-7.5, 8.0, 3.0]",
    "task.classes.green.bin_cm=[7.5, 8.0, 3.0]",
    "task.classes.blue.bin_cm=[0.0, 11.25, 3.0]",
    "task.scene=[{color: red, x: 4.35, y: 7.535}, {color: red, x: -2.875, y: 8.845},"
    " {color: green, x: 0.9, y: 8.555}, {color: green, x: -4.35, y: 7.535},"
    " {color: blue, x: 2.875, y: 8.845}, {color: blue, x: -0.9, y: 8.555}]",
]

SMALL_BINS = ("bin_width_cm=2.25", "bin_height_cm=1.5")


def test_none_fit_names_the_bins_and_the_reach() -> None:
    config = load_config("configs/sim_mearm_v1.yaml", HALF)
    with pytest.raises(SceneError) as err:
        random_scene(config, 12, seed=31001, max_tries=2000)
    text = str(err.value)
    assert "none fit in 2000 draws with seed 31001: of the camera's table field" in text
    assert "(centres x -4.5…4.5, y 4.5…10.5 cm), 6" in text  # 6x %: the bins'
    assert "% lies within 1.75 cm of a bin's square, where no object stands" in text
    assert "and the arm reaches 0." in text  # a sliver outside them
    assert "at every pick there the tool comes within 0.6 cm" in text
    assert "at bin_" in text
    assert text.endswith("smaller bins leave the arm room (task.classes' bin_width_cm, now 4.5 cm)")
    assert "\n" not in text
    # the remedy it names works (walls lowered too: 3 cm walls stand over the release of a
    # 1.5 cm object, which the refusal of those says, test_scene_walls_take_none.py)
    small = [
        *HALF,
        *(f"task.classes.{c}.{key}" for c in ("red", "green", "blue") for key in SMALL_BINS),
    ]
    assert len(random_scene(load_config("configs/sim_mearm_v1.yaml", small), 3, seed=31001)) == 3
