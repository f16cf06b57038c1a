"""A miss is not repeated at the height that missed: the claw may be low as well as high.

The looks' mean height has the wrong sign either way (kit 82, simulated: a claw 0.5 cm high
seen 0.01 cm low, one 0.45 cm low, its jaws' tips stalled open on the table round the
object, seen 0.09 cm high; docs/twin.md), so a miss with the object unmoved and the claw
not seen high tries the other height next.
"""

from __future__ import annotations

import pytest

from mearm.task.claw_loop import GRIP_CARRY_CM, GRIP_HOLD_CM, UNMOVED_CM, GripDrops

SEEN_LOW = [-0.32, 0.41, -0.13]  # (kit 82, seed 906: a claw 0.5 cm high, seen so)


def test_a_miss_at_the_planned_height_seen_low_lowers_the_next_attempt():
    """Unmoved and not seen high, at the planned height: the next attempt goes lower, by
    what a miss of a high claw lowers it."""
    drops = GripDrops()
    retry = drops.missed("red1", 0.0, 0.2, SEEN_LOW, overlap_cm=0.55)
    assert retry == pytest.approx(0.55 - GRIP_HOLD_CM + GRIP_CARRY_CM)
    assert drops.drop_cm("red1", [0.0, 48.0]) == pytest.approx(retry)
    assert "red1" not in drops.below_cm  # the table is not checked lower: nothing measured


def test_a_lowered_attempt_that_missed_seen_low_goes_back_to_the_planned_height():
    """Unmoved and not seen high after a lowered attempt (the drop the picks nearby kept,
    or a retry's): the claw may be low, the jaws stalled on the table; the next attempt
    goes at the planned height, and one more miss there lowers it again."""
    drops = GripDrops()
    assert drops.missed("blue4", 0.4, 0.0, [-0.14, -0.01, 0.0], overlap_cm=0.95) == 0.0
    assert drops.drop_cm("blue4", [0.0, 35.0]) == 0.0
    assert drops.missed("blue4", 0.0, 0.0, [-0.1], overlap_cm=0.55) > 0.0


def test_a_pushed_object_or_a_claw_seen_high_keeps_the_rules_it_had():
    """Moved by the jaws: nothing about the height is known, the drop stays; seen high: the
    next attempt goes lower (tests/test_grip_drops.py)."""
    drops = GripDrops()
    assert drops.missed("red1", 0.4, UNMOVED_CM + 0.5, SEEN_LOW, overlap_cm=0.95) == 0.4
    assert drops.missed("red2", 0.4, 0.0, [0.2, 0.3], overlap_cm=0.95) > 0.4
