"""calibrate-camera's homography mode: markers whose fit turns them on the table are refused.

Ids swapped diagonally (0↔2, 1↔3) turn the fit half a turn; shifted round by one
(0→1→2→3), a quarter. Either keeps the map's orientation, so the mirror check passes it,
and on the four centres alone the fit is exact. But ArUco reads each marker's corners in
its own order, so each marker's picture says which way it lies: mapped by the fit, its top
edge must face +y, as the markers are laid. Rendered pictures, the real command in-process.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import ROOT, check_bad_input, run_in_process

from mearm.config import Config, load_config
from mearm.sim import TableRenderer
from mearm.vision import Calibration
from mearm.vision.aruco import draw_marker_on_table

LAB = Calibration.from_config(Config().calibration)
#: Where the picture's markers (4 cm) lie on the table [cm].
MARKERS = {0: (-17.0, 56.0), 1: (16.0, 56.0), 2: (16.0, 32.0), 3: (-17.0, 32.0)}


@pytest.fixture(scope="module")
def pictures(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The lab camera's picture of the four markers, and the same camera turned a quarter."""
    frame = TableRenderer(LAB, table="wood").render([])
    for marker_id, center in MARKERS.items():
        draw_marker_on_table(frame, LAB, marker_id, center, 4.0)
    folder = tmp_path_factory.mktemp("markers")
    paths = {"upright": folder / "table.png", "camera turned": folder / "turned.png"}
    cv2.imwrite(str(paths["upright"]), frame)
    cv2.imwrite(str(paths["camera turned"]), cv2.rotate(frame, cv2.ROTATE_90_CLOCKWISE))
    return paths


def fit(config: Path, image: Path, ids: dict[int, int], *extra: str) -> list[str]:
    """calibrate-camera's arguments: marker ``i`` given ``MARKERS[ids[i]]`` as its place."""
    places = [
        a for i, j in ids.items() for a in ("--marker", f"{i}:{MARKERS[j][0]:g},{MARKERS[j][1]:g}")
    ]
    return ["calibrate-camera", "--config", str(config), "--image", str(image), *extra, *places]


def lab_config(tmp_path: Path) -> Path:
    config = tmp_path / "lab.yaml"
    config.write_text((ROOT / "configs" / "sim.yaml").read_text())
    return config


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("ids", "said"),
    [
        ({0: 2, 1: 3, 2: 0, 3: 1}, ["half a turn", "swapped diagonally"]),
        ({0: 1, 1: 2, 2: 3, 3: 0}, ["marker 0 by -90 deg", "marker 3 by -90 deg"]),
    ],
    ids=["diagonal", "round-by-one"],
)
def test_ids_that_turn_the_exact_fit_are_refused(
    tmp_path: Path, pictures: dict[str, Path], ids: dict[int, int], said: list[str]
) -> None:
    """Centres alone, an exact fit turned on the table: exit 2, one line, nothing written."""
    config = lab_config(tmp_path)
    out = check_bad_input(fit(config, pictures["upright"], ids), keep=[tmp_path])
    assert all(s in out.line for s in said), out.line
    assert out.line.endswith("nothing written")
    assert not config.with_name("lab.yaml.bak").exists()


@pytest.mark.parametrize("picture", ["upright", "camera turned"])
@pytest.mark.parametrize("side", [[], ["--marker-side-cm", "4"]], ids=["centres", "corners"])
def test_a_right_layout_still_fits_whatever_the_camera_s_turn(
    tmp_path: Path, pictures: dict[str, Path], picture: str, side: list[str]
) -> None:
    """The markers as laid, seen upright or by a camera turned a quarter: written, exit 0.

    The turn is the markers' on the table, through the fit, not in the picture."""
    config = lab_config(tmp_path)
    if picture == "camera turned":  # its frames are the turned picture's, 480x640
        config.write_text(config.read_text().replace("width_px: 640", "width_px: 480", 1))
        config.write_text(config.read_text().replace("height_px: 480", "height_px: 640", 1))
    out = run_in_process(fit(config, pictures[picture], {i: i for i in MARKERS}, *side))
    assert out.code == 0, out.stderr
    written = Calibration(np.array(load_config(config).calibration.homography))
    centres = np.array(list(MARKERS.values()))
    u, v = LAB.table_to_pixel(centres).T  # where the upright picture shows them
    if picture == "camera turned":  # turned clockwise: (u, v) → (h - 1 - v, u)
        u, v = cv2.imread(str(pictures["upright"])).shape[0] - 1 - v, u
    seen = written.pixel_to_table(np.column_stack([u, v]))
    assert np.abs(seen - centres).max() < 0.05


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("place", "side", "said"),
    [
        ((16.0, 32.0), [], "--marker 2 and --marker 3 are both at (16, 32) cm"),
        ((16.0, 32.0), ["--marker-side-cm", "4"], "--marker 2 and --marker 3 are both at"),
        ((14.0, 32.0), ["--marker-side-cm", "4"], "are 2 cm apart, less than --marker-side-cm 4"),
    ],
    ids=["same-place", "same-place-corners", "overlapping"],
)
def test_a_mistyped_place_is_told_by_the_markers_ids(
    tmp_path: Path,
    pictures: dict[str, Path],
    place: tuple[float, float],
    side: list[str],
    said: str,
) -> None:
    """Marker 3 typed at marker 2's place, or too near it for two printed markers: exit 2,
    one line naming both ids. The fit's check named the points by its own numbering
    instead ("table points 10 and 15 are the same point"), a marker's corners counted."""
    config = lab_config(tmp_path)
    argv = fit(config, pictures["upright"], {0: 0, 1: 1, 2: 2}, *side)
    argv += ["--marker", f"3:{place[0]:g},{place[1]:g}"]
    out = check_bad_input(argv, keep=[tmp_path])
    assert said in out.line, out.line
    assert "table points" not in out.line
