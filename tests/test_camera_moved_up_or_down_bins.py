"""A camera higher or lower than its calibration is caught by the bins' feet.

``mearm sort --config sim_mujoco_perspective --random 12 --seed 35075 --set
twin.camera.height_cm=49.3`` (found by a fresh-seed sweep of the twin's variants: the
camera 5.7 cm lower than its calibration says): the bins' +x feet appeared 2 cm inside
their places, alike, but the -y feet of the green and blue bins 0.2 and -0.95 cm: a view
scaled about the point under the camera moves each foot by its distance from there, and
the check took feet facing one way that moved each by its own amount for the arm's body
in front of them. The sort went on picking where the objects were not (10 picks failed,
2 objects left); with a kit of servos calibrated at the start (``sim_mujoco_kits``,
``--random 7 --seed 35113``) the fit to that view sent the jaws into the red bin's wall.
Frames and sorts here are the MuJoCo twin's (simulated).
"""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.sim.twin.twin_bus import TwinArm
from mearm.sim.twin.twin_camera import TwinCamera
from mearm.task.table_tracking import check_bins
from mearm.vision.bin_edges import BinFeet, BinSide
from mearm.vision.calibration import camera_geometry
from mearm.vision.errors import CameraError

CONFIG = ROOT / "configs" / "sim_mujoco_perspective.yaml"
SCENE = "task.scene=[{color: red, x: 5, y: 40}]"


def _sides(height_cm: float | None) -> list[BinSide]:
    """The bins' feet in a frame of the twin's camera at ``height_cm`` (``None``: where
    its calibration has it), measured by that calibration."""
    sets = [SCENE] + ([] if height_cm is None else [f"twin.camera.height_cm={height_cm}"])
    config = load_config(CONFIG, sets)
    with TwinCamera(config, TwinArm(config)) as camera:
        frame = camera.read()
    geometry = camera_geometry(config.calibration, config.camera)
    size = (config.camera.width_px, config.camera.height_px)
    return BinFeet(geometry, list(config.task.classes), size).measure(frame)


@pytest.mark.parametrize("height_cm", [49.3, 61.0])
def test_a_camera_moved_up_or_down_is_a_moved_view(height_cm: float) -> None:
    with pytest.raises(CameraError, match=r"the view moved: the bins of red, green, blue"):
        check_bins(_sides(height_cm), {}, "twin")


def test_the_camera_where_its_calibration_has_it_is_not() -> None:
    sides = _sides(None)
    assert len(sides) >= 5, sides
    check_bins(sides, {}, "twin")


def test_feet_a_scale_cannot_explain_are_not_one_view_change() -> None:
    """Five feet, each moved by its own amount (the arm's body before them): no fault,
    where the same feet moved as one scale and shift would be."""
    eye = (-16.5, -16.5, -5.5, -16.5, -15.5)
    normals = ((1.0, 0.0), (1.0, 0.0), (0.0, -1.0), (1.0, 0.0), (0.0, -1.0))
    names = ("red", "green", "green", "blue", "blue")

    def sides(offsets: tuple[float, ...]) -> list[BinSide]:
        return [
            BinSide(n, v, cm, 9, e)
            for n, v, cm, e in zip(names, normals, offsets, eye, strict=True)
        ]

    check_bins(sides((-2.0, -1.2, 0.2, -1.6, -0.95)), {}, "test")
    with pytest.raises(CameraError, match="the view moved"):
        check_bins(sides((-2.0, -1.95, 0.2, -2.0, -0.95)), {}, "test")
