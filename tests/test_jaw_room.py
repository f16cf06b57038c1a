"""The open jaws keep room each side of an object: a class that leaves less is refused.

In the twin a jaw came down on the rim of discs nearly as wide as the open jaws: a 3.96
cm disc in the paper arm's 4 cm jaws was carried, jammed, to another class's bin with its
place said released (``sim_mujoco_lamp --random 8 --seed 35082``), and the MeArm v1's
shoulder stalled on 2.44, 2.3 and 2.2 cm discs in its 3 cm jaws. The config took any
object less wide than the open jaws.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.config.root import JAW_ROOM_CM
from mearm.errors import ConfigError


@pytest.mark.parametrize(
    ("config", "setting", "room"),
    [
        ("sim_mearm_v1", "task.classes.blue.diameter_cm=2.2", "0.4"),
        ("sim", "task.classes.red.diameter_cm=3.96", "0.02"),
        ("sim_shapes", "task.classes.red_cube.diameter_cm=2.2", "0.44"),  # its diagonal
    ],
)
def test_a_class_that_leaves_the_jaws_too_little_room_is_refused(
    config: str, setting: str, room: str
) -> None:
    with pytest.raises(ConfigError) as caught:
        load_config(config, [setting])
    said = str(caught.value)
    name = setting.split("=")[0]
    assert f"{name}: a " in said and f" {room} cm each side, less than 0.5 cm" in said, said
    assert "wider-opening gripper" in said and len(said.splitlines()) == 1


def test_the_largest_object_with_the_room_is_taken() -> None:
    """At exactly the room each side (the v1's 3 cm jaws, 2 cm discs) the config loads."""
    config = load_config("sim_mearm_v1", [f"task.classes.blue.diameter_cm={3.0 - 2 * JAW_ROOM_CM}"])
    assert config.task.class_named("blue").diameter_cm == pytest.approx(2.0)
