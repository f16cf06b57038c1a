"""A random table whose bins' walls stop even one object says so, not ``fewer than 0``.

The MeArm v1 with its links halved and its bins 2.25 cm wide, its 1.5 cm objects gripped
1 cm up kept at their size: every bin's walls stand 3 cm tall (two objects, for one as
for none), over the bottom of a red held at its release 3 cm up, and the arm has no way
into the red bin. ``--random 12 --seed 31001`` was refused ``at most 3 fit …, of which
the bins' walls take 0 …; ask for fewer than 0 (0 asked for does not lay out …)``: a
count no table has. Now it names what stops every object, and the way out (walls set
lower), which lays the three out.
"""

from __future__ import annotations

import pytest
from test_scene_none_fit_why import HALF

from mearm.config import load_config
from mearm.task.scene import SceneError, random_scene

COLORS = ("red", "green", "blue")
SMALL = [*HALF, *(f"task.classes.{c}.bin_width_cm=2.25" for c in COLORS)]
SHUT = "class red: its bin's walls, built 3 cm tall to hold its 1 objects stacked, leave "


@pytest.mark.parametrize("n", [12, 2])
def test_walls_that_stop_one_object_name_no_count(n: int) -> None:
    config = load_config("configs/sim_mearm_v1.yaml", SMALL)
    with pytest.raises(SceneError) as err:
        random_scene(config, n, seed=31001, max_tries=2000)
    text = str(err.value)
    assert "fewer than" not in text and "ask for" not in text, text
    if n == 12:  # the table holds some; the walls, none
        assert "fit in 2000 draws with seed 31001, but the bins' walls take none: " in text
    assert SHUT in text and "the arm no way in with one held, even from home" in text
    assert text.endswith(
        "): no number of objects fits; set the class's bin_height_cm (task.classes)"
    ), text
    # the way out it names works
    lower = [*SMALL, *(f"task.classes.{c}.bin_height_cm=1.5" for c in COLORS)]
    assert len(random_scene(load_config("configs/sim_mearm_v1.yaml", lower), 3, seed=31001)) == 3
