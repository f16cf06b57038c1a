"""calibrate-camera's homography mode refuses a bad fit and keeps what --force replaces;
init-config refuses a device before it says "wrote"."""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest

from mearm.config import Config
from mearm.maker import init_config
from mearm.sim import TableRenderer
from mearm.tools import calibrate_camera
from mearm.vision import Calibration
from mearm.vision.aruco import draw_marker_on_table

ROOT = Path(__file__).resolve().parent.parent
LAB = Calibration.from_config(Config().calibration)
#: Where the picture's markers (4 cm) lie on the table [cm].
MARKERS = {0: (-17.0, 56.0), 1: (16.0, 56.0), 2: (16.0, 32.0), 3: (-17.0, 32.0)}


@pytest.fixture(scope="module")
def image(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The lab camera's picture of the four markers."""
    frame = TableRenderer(LAB, table="wood").render([])
    for marker_id, center in MARKERS.items():
        draw_marker_on_table(frame, LAB, marker_id, center, 4.0)
    path = tmp_path_factory.mktemp("markers") / "table.png"
    cv2.imwrite(str(path), frame)
    return path


def marker_args(centers: dict[int, tuple[float, float]]) -> list[str]:
    return [a for i, (x, y) in centers.items() for a in ("--marker", f"{i}:{x},{y}")]


def run_tool(capsys: pytest.CaptureFixture[str], module, *args: str) -> tuple[int, str, str]:
    """Run a command as ``mearm`` does (mearm.cli.run): exit code, stdout, stderr."""
    with pytest.raises(SystemExit) as info:
        module.run(module.main, list(args))
    out, err = capsys.readouterr()
    return int(info.value.code), out, err


@pytest.mark.parametrize(
    "swap",
    [{0: 1, 1: 0, 2: 3, 3: 2}, {0: 3, 3: 0, 1: 2, 2: 1}],
    ids=["left-for-right", "near-for-far"],
)
@pytest.mark.parametrize("side", [[], ["--marker-side-cm", "4"]], ids=["centres", "corners"])
def test_swapped_ids_are_refused_as_mirrored(
    tmp_path: Path, capsys, image: Path, swap: dict[int, int], side: list[str]
) -> None:
    """Ids swapped into a mirror image fit (with centres only, exactly): exit 2, nothing written."""
    config = tmp_path / "lab.yaml"
    config.write_text((ROOT / "configs" / "sim.yaml").read_text())
    before = config.read_bytes()
    swapped = {i: MARKERS[swap[i]] for i in MARKERS}
    code, _, err = run_tool(
        capsys, calibrate_camera, "--config", str(config), "--image", str(image),
        *side, *marker_args(swapped),
    )  # fmt: skip
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "mirrored" in err and "swapped" in err
    assert config.read_bytes() == before
    assert not config.with_name("lab.yaml.bak").exists()


def test_a_fit_over_the_bound_is_refused_even_with_force(tmp_path: Path, capsys, image: Path):
    """A wrong --marker-side-cm (5 for 4) fits to over 0.5 cm rms: exit 2, nothing written."""
    config = tmp_path / "lab.yaml"
    config.write_text((ROOT / "configs" / "sim.yaml").read_text())
    before = config.read_bytes()
    code, _, err = run_tool(
        capsys, calibrate_camera, "--config", str(config), "--image", str(image),
        "--marker-side-cm", "5", *marker_args(MARKERS), "--force",
    )  # fmt: skip
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert "refused above 0.5 cm" in err and "--marker-side-cm" in err
    assert config.read_bytes() == before


def test_force_keeps_the_replaced_config_as_bak(tmp_path: Path, capsys, image: Path) -> None:
    """--force replaces a better homography in --config itself; the old file is the .bak."""
    config = tmp_path / "lab.yaml"
    text = (ROOT / "configs" / "sim.yaml").read_text()
    config.write_text(text.replace("reprojection_error_cm: null", "reprojection_error_cm: 0.0"))
    before = config.read_bytes()
    args = ["--config", str(config), "--image", str(image), "--marker-side-cm", "4"]
    code, _, err = run_tool(capsys, calibrate_camera, *args, *marker_args(MARKERS))
    assert code == 2 and "holds a better calibration" in err  # the fit is not exactly 0
    code, _, _ = run_tool(capsys, calibrate_camera, *args, *marker_args(MARKERS), "--force")
    assert code == 0
    assert config.read_bytes() != before
    assert config.with_name("lab.yaml.bak").read_bytes() == before


def test_init_config_refuses_a_device_before_writing(capsys) -> None:
    """--force /dev/null: exit 2 with one line, and no "wrote" or next steps on stdout."""
    code, out, err = run_tool(
        capsys, init_config, "--arm", "mearm_v1", "--rig", "uno", "--force", "/dev/null"
    )
    assert code == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1 and "not a regular file" in err
