"""``--set`` on an item of an empty list says the list is empty and how to give it whole.

``--set twin.faults.0.at_s=1`` on a config with no faults said "no such item (0…-1)", a
range with no number in it; an empty list has no item to change, and the list is given
whole instead, the item the override set its one item.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import refused_line


def _fk(*args: str, cwd: Path) -> str:
    """``mearm fk ARGS`` run in ``cwd``: its one line of stderr (it must fail, exit 2)."""
    return refused_line(["fk", *args, "--joints", "120,93,-132"], cwd=cwd)


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("config", "override", "said"),
    [
        (
            "sim",
            "twin.faults.0.at_s=1",
            "twin.faults.0: no item 0: twin.faults is an empty list; set the whole list "
            "instead, e.g. --set 'twin.faults=[{at_s: 1}]'",
        ),
        (
            "sim",
            "twin.faults.0={kind: camera_black, at_s: 1}",
            "twin.faults.0: no item 0: twin.faults is an empty list; set the whole list "
            "instead, e.g. --set 'twin.faults=[{kind: camera_black, at_s: 1}]'",
        ),
        (
            "lab",
            "task.scene.red1.x_cm=3",
            "task.scene.red1: no item named 'red1': task.scene is an empty list; set the "
            "whole list instead, e.g. --set 'task.scene=[{x_cm: 3}]'",
        ),
        (
            "lab",
            "task.scene.0.pos.0=3",
            "task.scene.0: no item 0: task.scene is an empty list; set the whole list "
            "instead, e.g. --set 'task.scene=[{...}]'",
        ),
    ],
)
def test_an_item_of_an_empty_list_says_the_list_is_empty(
    tmp_path: Path, config: str, override: str, said: str
) -> None:
    assert _fk("--config", config, "--set", override, cwd=tmp_path) == (
        f"mearm fk: error: --set: {said}"
    )


@pytest.mark.heavy
def test_the_suggested_list_is_what_set_takes(tmp_path: Path) -> None:
    """Given whole as suggested, the fault is read: what is still wrong is the fault's own."""
    fault = "twin.faults=[{at_s: 1}]"
    assert _fk("--config", "sim", "--set", fault, cwd=tmp_path) == (
        "mearm fk: error: --set: twin.faults.0.kind: required but missing (one of: "
        "limp_servo, knock_object, camera_black, camera_frozen, camera_bump)"
    )


@pytest.mark.heavy
def test_an_index_past_a_lists_end_still_says_its_range(tmp_path: Path) -> None:
    assert _fk("--config", "sim", "--set", "arm.joints.9.home=1", cwd=tmp_path) == (
        "mearm fk: error: --set: arm.joints.9: no such item (0…3)"
    )
