"""The count a random table's refusal names lays out, where the walls shut the table.

``mearm sort --config sim --random 500 --seed 43031 --set task.classes.green.height_cm=1.5``
said ``ask for fewer than 48 (…; 48 asked for does not lay out)``: the refusal laid out
48 (too full), then 47, whose 17 cm red walls (16 reds) leave the arm no way from home
to the table, and took that for a table that does not lay out. 47 and 46 were then
refused in turn, naming 36, which sorts whole. The count named is now the one the walls
of the table keep that way for, laid out; and where every try left objects with no way in
past the walls, the most a try kept with one is laid out too.
"""

from __future__ import annotations

import re

import pytest

from mearm.config import load_config
from mearm.task.scene import SceneError, random_scene

SETS = ("task.classes.green.height_cm=1.5",)
SEED = 43031


@pytest.mark.heavy
def test_the_refusal_of_500_names_a_count_that_lays_out() -> None:
    config = load_config("sim", SETS).with_scene([])
    with pytest.raises(SceneError) as info:
        random_scene(config, 500, seed=SEED)
    text = str(info.value)
    assert text.endswith(
        ": ask for 36 or fewer (the walls take 52, and no layout of those drawn with seed "
        "43031 held more than 48 on the table; 48 asked for does not lay out, and the walls "
        "of 47 leave the arm no way from home to the table, those of 36 leave one)"
    ), text
    assert re.search(r"ask for fewer than", text) is None, text


@pytest.mark.heavy
def test_a_refusal_whose_tries_each_leave_objects_with_no_way_in_names_what_lays_out() -> None:
    """``sim --random 500 --seed 45003``: the layouts of 47, 46 and 45 each held every
    object, but kept only 44 or so with a way in past the red walls and drew the rest
    again until their draws ran out; the refusal said ``ask for fewer than 47``, and 46
    was then refused naming 44. One more layout, of the most kept, names 44 at once."""
    config = load_config("sim").with_scene([])
    with pytest.raises(SceneError) as info:
        random_scene(config, 500, seed=45003)
    text = str(info.value)
    assert text.endswith(
        ": ask for 44 or fewer (the walls take 72, and no layout of those drawn with seed "
        "45003 held more than 47 on the table; 47 asked for does not lay out, 44 does)"
    ), text
