"""A random table of tall objects is laid out as the sort picks them, or refused for why.

``mearm sort --config sim --random 10 --seed 22405 --set task.classes.green.height_cm=4.5``
was refused ``could not place 10 objects 1.5 cm apart …: at most 1 fit``, where the sort
picks such greens (the config's own table: 12 of 12). The layout keeps each pick's tool
``task.clearance_cm`` plus a margin for the camera's error from everything; a pick goes
where the camera places its object, so that margin is nothing to its own object, and the
hand above a 4.5 cm green's top was within it at every place. A 5 cm green meets the hand
at the sort's clearance too: no place fits it, and the refusal now says so.
"""

from __future__ import annotations

import pytest

from mearm.config import load_config
from mearm.task.scene import TABLE_ONLY_DRAWS, SceneError, random_scene

TALL = "task.classes.green.height_cm"


def test_tall_objects_the_sort_picks_are_laid_out() -> None:
    config = load_config("sim", overrides=[f"{TALL}=4.5"])
    scene = random_scene(config, 10, seed=22405)
    assert len(scene) == 10
    assert sum(o.color == "green" for o in scene) >= 3


def test_objects_too_tall_for_the_hand_are_refused_for_it() -> None:
    config = load_config("sim", overrides=[f"{TALL}=5"])
    with pytest.raises(SceneError) as err:
        random_scene(config, 10, seed=22405)
    text = str(err.value)
    assert text.startswith("task.classes.green: an object 5 cm tall picked at grip_height_cm 1.5 ")
    assert f"at its own pick, at {TABLE_ONLY_DRAWS} places drawn with seed 22405" in text
    assert text.endswith("lower height_cm or raise grip_height_cm"), text
    # the remedy it names works
    raised = load_config("sim", overrides=[f"{TALL}=5", "task.classes.green.grip_height_cm=3"])
    assert len(random_scene(raised, 10, seed=22405)) == 10
