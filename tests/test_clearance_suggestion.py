"""The clearance a refusal at home suggests is one the config then takes.

A ``task.clearance_cm`` more than the arm at home keeps from a bin is refused, naming the
most it may be. The figure was the distance rounded to two decimals, which rounds up as
often as down: the paper's arm keeps 3.308 cm from its red bin, ``mearm sort --config sim
--set task.clearance_cm=5`` said ``at most 3.31 cm``, and ``--set
task.clearance_cm=3.31`` was refused in turn, with ``3.31 cm is more than the arm keeps
… (3.31 cm): at most 3.31 cm``.
"""

from __future__ import annotations

import re

import pytest

from mearm.config import load_config
from mearm.errors import ConfigError
from mearm.task.check import check_consistency


@pytest.mark.parametrize("name", ["sim", "sim_4colours", "sim_shapes"])
def test_the_most_clearance_named_at_home_is_taken(name: str) -> None:
    with pytest.raises(ConfigError) as info:
        check_consistency(load_config(name, ["task.clearance_cm=9"]))
    text = str(info.value)
    named = re.findall(r"bin at home \(\w+, [\d.]+ cm\): at most ([\d.]+) cm", text)
    assert named, text
    # one line per bin too near: the least of their figures is the one that holds for all
    check_consistency(load_config(name, [f"task.clearance_cm={min(named, key=float)}"]))
