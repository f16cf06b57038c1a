"""The view of the kinematic rig draws the object the jaws hold, moving with them.

The joints there are drawn as commanded and the objects where the camera last saw them,
so a carried object stayed drawn on the table while the jaws went to the bin empty, and
vanished at the next look. Now it leaves the table's drawing when the jaws close on it
and rides at the grip point until they open. Real meshcat server, real kinematic sorts.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from conftest import ROOT
from viewscene import scene

from mearm.config import SceneObject, load_config
from mearm.exceptions import ViewInputError
from mearm.task.rig import open_rig
from mearm.task.sorter import Sorter
from mearm.view import ArmView

#: The desk 5-DOF arm: its grip point is its TCP, straight below the wrist at a pick.
DESK = load_config(ROOT / "configs" / "sim_5dof.yaml")
RED = SceneObject(color="red", x=6.0, y=20.0)


class RecordingView(ArmView):
    """The real view; at each drawing of the arm, what the scene holds in the jaws."""

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.pushes: list[tuple[np.ndarray, dict[str, np.ndarray], set[str]]] = []

    def show_joints(self, q: Any, opening_cm: float | None = None) -> None:
        super().show_joints(q, opening_cm)
        tree = scene(self)
        held = {
            p.rsplit("/", 1)[1]: node["transform"]
            for p, node in tree.items()
            if p.startswith("/meshcat/held/")
        }
        table = {p.rsplit("/", 1)[1] for p in tree if p.startswith("/meshcat/objects/")}
        self.pushes.append((self.model.fk_cm(self.joints), held, table))


def _sort(config, objects):
    with open_rig(config, objects) as rig:
        with RecordingView(rig.model, config) as view:
            sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, view=view, echo=None)
            report = sorter.run()
            final = scene(view)
    return report, view.pushes, final


def test_the_held_object_rides_at_the_grip_point_from_the_grip_to_the_bin():
    report, pushes, final = _sort(DESK, [RED])
    assert report.outcome.sorted["red"] == 1
    carried = [(tcp, held) for tcp, held, _ in pushes if held]
    assert len(carried) > 5  # drawn all along the carry, not once
    assert all(set(held) == {"red1"} for _, held in carried)
    # at the grip: where the object stood, at the height the jaws close at (the TCP's)
    first = carried[0][1]["red1"][:3, 3] * 100
    np.testing.assert_allclose(first[:2], [RED.x, RED.y], atol=0.3)
    # on the way: at the TCP (this arm's grip point), the cylinder's axis along the tool's
    for tcp, held in carried:
        np.testing.assert_allclose(held["red1"][:3, 3] * 100, tcp, atol=1e-6)
    far = max(float(np.linalg.norm(tcp[:2] - [RED.x, RED.y])) for tcp, _ in carried)
    assert far > 10  # it went to the bin with the jaws
    # never on the table and in the jaws at once; and not in the jaws once they let go
    assert not any("red1" in table for _, held, table in pushes if held)
    assert not any(p.startswith("/meshcat/held/") for p in final)


def test_a_missed_grip_draws_nothing_in_the_jaws():
    """The paper arm's jaws must land within 0.01 cm of the object: each grip misses."""
    paper = load_config(ROOT / "configs" / "sim.yaml", overrides=["servo.grip_tolerance_cm=0.01"])
    report, pushes, _ = _sort(paper, [SceneObject(color="red", x=-5.0, y=45.0)])
    assert report.outcome.sorted["red"] == 0
    assert not any(held for _, held, _ in pushes)


def test_hold_refuses_a_class_the_config_does_not_have():
    with open_rig(DESK, [RED]) as rig, ArmView(rig.model, DESK) as view:
        with pytest.raises(ViewInputError, match="held"):
            view.hold(("purple1", "purple"))
        assert view.held is None
        view.hold(("red1", "red"))
        assert view.held == ("red1", "red")
        assert any(p.startswith("/meshcat/held/red1") for p in scene(view))
        view.hold(None)
        assert not any(p.startswith("/meshcat/held/") for p in scene(view))
