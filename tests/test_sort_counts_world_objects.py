"""A sort in simulation counts the objects the world laid out, not what the camera followed.

The twin's camera set well below the one its calibration was made for (``--set
twin.camera.height_cm=20`` on ``sim_mujoco_perspective``, 35 cm lower) sees each object
larger than one can be, and the detector split it into two: the sort followed four greens
where the world has three and said ``sorted 0 of 9 objects`` for eight (at 40 cm, ``2 of
11``). What the camera saw that was no object is now counted nowhere: the world's count
is the total, per class too.
"""

from __future__ import annotations

import re

import pytest
from conftest import run_main

from mearm import sort

pytestmark = pytest.mark.heavy


def test_a_low_camera_s_split_objects_do_not_inflate_the_count(
    capsys: pytest.CaptureFixture[str],
) -> None:
    code, out, err = run_main(
        capsys, sort.main, "--config", "sim_mujoco_perspective", "--random", "8", "--seed",
        "22801", "--set", "twin.camera.height_cm=20",
    )  # fmt: skip
    assert code == 1, err
    last = out.strip().splitlines()[-1]
    assert last.startswith("sorted 0 of 8 objects (simulated; "), out
    # the reasons given add up to the objects left, each object once
    assert sum(int(n) for n in re.findall(r"(\d+) [a-z]", last.split("(", 1)[1])) == 8, last
    # the scene's 3 red, 3 green and 2 blue, whatever the camera followed
    rows = dict(re.findall(r"^(red|green|blue)\s+\d+\s+\d+\s+(\d+)$", out, re.M))
    assert rows == {"red": "3", "green": "3", "blue": "2"}, out
    seen = dict(re.findall(r"^(red|green|blue)\s+(\d+)\s+\d+\s+\d+$", out, re.M))
    assert int(seen["green"]) <= 3, out
    # and it says so: what it followed that was no object, per class
    said = re.findall(r"^not objects \((\w+)\): the camera followed (\d+) where the world laid "
                      r"out (\d+); (\d+) of them, among the lines above, (?:was|were) no object",
                      out, re.M)  # fmt: skip
    assert said, out
    for name, followed, laid, extra in said:
        assert int(followed) - int(laid) == int(extra) > 0, said
        assert int(laid) == {"red": 3, "green": 3, "blue": 2}[name], said
