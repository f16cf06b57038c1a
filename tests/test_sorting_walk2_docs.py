"""docs/sorting.md's shapes picture names only what the twin's shapes table holds.

Found walking the page: its caption said "red cubes, red cylinders and green prisms on
the twin's table", but ``configs/sim_shapes_mujoco.yaml`` left the prisms out then (they
slipped out of the twin's jaws) and the rendered picture showed none.
"""

from __future__ import annotations

import re

from conftest import ROOT

from mearm.config import load_config


def _picture_alt_text(page: str, image: str) -> str:
    match = re.search(r"!\[([^\]]*)\]\(images/" + re.escape(image) + r"\)", page)
    assert match, f"no picture {image} on the page"
    return match.group(1).lower()


def test_the_shapes_picture_names_no_class_its_table_leaves_out():
    page = (ROOT / "docs" / "sorting.md").read_text(encoding="utf-8")
    alt = _picture_alt_text(page, "twin_shapes.png")
    config = load_config(ROOT / "configs" / "sim_shapes_mujoco.yaml")
    on_table = {o.color for o in config.task.scene}
    for cls in config.task.classes:
        colour, shape = cls.name.split("_")
        named = re.search(rf"\b{colour} {shape}", alt) is not None
        assert named == (cls.name in on_table), (cls.name, alt)
