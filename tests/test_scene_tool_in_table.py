"""A class whose pick puts the open jaws in the table is named, not drawn 20,000 times.

With ``grip_height_cm: 0`` the jaws close at the table's top, and the open jaws of the
paper's arm hang below it wherever the object stands: every draw of the random layout was
refused, and after its 20,000 draws (some 7 s) it said only ``none fit``.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.task.scene import TABLE_ONLY_DRAWS, SceneError, random_scene


@pytest.mark.parametrize("color", ["red", "blue"])
def test_a_pick_height_that_puts_the_jaws_in_the_table_is_named(color: str) -> None:
    config = load_config("sim", overrides=[f"task.classes.{color}.grip_height_cm=0"])
    with pytest.raises(SceneError) as err:
        random_scene(config, 6, seed=4)
    text = str(err.value)
    assert text.startswith(f"task.classes.{color}: picked at grip_height_cm 0 ")
    assert f"reaches the table at {TABLE_ONLY_DRAWS} places drawn with seed 4" in text
    assert "jaw" in text and text.endswith("raise grip_height_cm")


def test_the_shipped_pick_heights_lay_scenes_out_as_before() -> None:
    """The count of a class's picks in the table stops once one of the class stands."""
    config = load_config("sim")
    for seed in (0, 1, 2):
        scene = random_scene(config, 12, seed=seed)
        assert len(scene) == 12
