"""calibrate-camera's homography mode refuses a bad fit and keeps what --force replaces;
init-config refuses a device before it says "wrote".

Found walking docs/calibration.md: a second fit written into ``--config`` itself replaced
the homography it held without a ``.bak`` (a better rms, so no ``--force`` was asked);
and an exact 4-pair fit recorded ``reprojection_error_cm: 0.0``, so it silently replaced
a measured calibration and then refused every measured fit after it as "worse".
"""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest
import yaml
from conftest import run_main

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
#: The four markers' centres and corners (20 pairs: a measured error).
CORNERS = ["--marker-side-cm", "4"]


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
    return run_main(capsys, module.main, *args)


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


@pytest.fixture
def config(tmp_path: Path) -> Path:
    """A copy of sim.yaml (no measured error recorded) to calibrate in place."""
    path = tmp_path / "lab.yaml"
    path.write_text((ROOT / "configs" / "sim.yaml").read_text())
    return path


def _fit(capsys, config: Path, image: Path, *extra: str) -> tuple[int, str, str]:
    """Run calibrate-camera on the four markers into ``config``: exit code, stdout, stderr."""
    argv = ["--config", str(config), "--image", str(image), *marker_args(MARKERS), *extra]
    return run_tool(capsys, calibrate_camera, *argv)


def _error_cm(config: Path) -> object:
    return yaml.safe_load(config.read_text())["calibration"]["reprojection_error_cm"]


def test_a_fit_in_place_keeps_the_config_it_replaces(capsys, config: Path, image: Path) -> None:
    """The first fit keeps the old config as .bak; a rerun that changes nothing keeps that."""
    before = config.read_bytes()
    code, out, _ = _fit(capsys, config, image, *CORNERS)
    assert code == 0
    backup = config.with_name("lab.yaml.bak")
    assert backup.read_bytes() == before
    assert out.splitlines()[-2:] == [
        f"wrote {backup} (the old {config})",
        f"wrote the calibration into {config}",
    ]
    fitted = config.read_bytes()
    code, out, _ = _fit(capsys, config, image, *CORNERS)  # the same fit, the same text
    assert code == 0 and ".bak" not in out
    assert config.read_bytes() == fitted and backup.read_bytes() == before


def test_an_exact_fit_records_no_error(capsys, config: Path, image: Path) -> None:
    """4 centres: the error is recorded as unknown (null), and the note says so; a
    measured fit then replaces it without --force."""
    code, out, err = _fit(capsys, config, image)
    assert code == 0, err
    assert _error_cm(config) is None
    # a note, on stderr (stdout holds the results), in one line
    assert "by construction" not in out
    (note,) = err.splitlines()
    assert note.endswith(": note: 4 pairs fit exactly, so the error is 0 by construction and "
                         "measures nothing (written as reprojection_error_cm: null); add points "
                         "(or --marker-side-cm) for an error that measures something")  # fmt: skip
    code, _, err = _fit(capsys, config, image, *CORNERS)
    assert code == 0, err
    assert isinstance(_error_cm(config), float)


def test_a_calibration_the_sort_would_refuse_is_written_with_a_warning(
    capsys, config: Path
) -> None:
    """Points typed in mm where cm are asked (every one ten times out): the fit was
    written, exit 0, and the next sort refused it; now a warning says so as it is written.
    A calibration the sort takes warns of nothing."""
    typed = [
        ("0,0", "-20.5,59"),
        ("640,0", "19.5,59"),
        ("0,480", "-20.5,29"),
        ("640,480", "19.5,29"),
    ]
    for scale, warned in ((10, True), (1, False)):
        points = []
        for px, cm in typed:
            x, y = (float(v) * scale for v in cm.split(","))
            points += ["--point", f"{px}:{x:g},{y:g}"]
        code, out, err = run_tool(capsys, calibrate_camera, "--config", str(config), *points)
        assert code == 0, err
        assert f"wrote the calibration into {config}" in out
        said = [ln for ln in err.splitlines() if ": warning: " in ln]
        if warned:
            (line,) = said
            assert f"warning: mearm sort --config {config} will refuse this calibration: " in line
            assert "holds no point the arm can pick from" in line
        else:
            assert said == [], err


def test_an_exact_fit_does_not_replace_a_measured_one(capsys, config: Path, image: Path) -> None:
    """Over a measured error, an exact fit is refused (exit 2, one line, nothing written);
    with --force it replaces it, the old config kept as .bak.1 beside the first .bak (the
    config as it was before any fit), which it does not replace."""
    assert _fit(capsys, config, image, *CORNERS)[0] == 0
    measured = config.read_bytes()
    backup = config.with_name("lab.yaml.bak")
    first_backup = backup.read_bytes()
    code, _, err = _fit(capsys, config, image)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "its error is unknown" in err
    assert config.read_bytes() == measured and backup.read_bytes() == first_backup
    code, _, err = _fit(capsys, config, image, "--force")
    assert code == 0, err
    assert _error_cm(config) is None and backup.read_bytes() == first_backup
    assert config.with_name("lab.yaml.bak.1").read_bytes() == measured


def test_the_pose_mode_keeps_the_config_it_points(tmp_path: Path) -> None:
    """--config pointed in place at the new files: the old config is kept as .bak, named
    before the line that says so; a rerun that changes nothing writes no .bak over it."""
    from badinput import run_in_process  # noqa: PLC0415

    from mearm.config import load_config  # noqa: PLC0415  (MuJoCo: this case)
    from mearm.sim.twin.calibration_scenes import (  # noqa: PLC0415
        SHEET_SIDE_CM,
        default_sheet_layout,
        render_sheet,
    )

    twin = load_config(ROOT / "configs" / "sim_mujoco_perspective.yaml")
    layout = default_sheet_layout(twin)
    sheet, pose, mine = tmp_path / "sheet.png", tmp_path / "pose.yaml", tmp_path / "my_twin.yaml"
    cv2.imwrite(str(sheet), render_sheet(twin, layout, noise_std=2, seed=0))
    mine.write_text("extends: sim_mujoco_perspective   # mine\n")
    before = mine.read_bytes()
    intrinsics = ROOT / "configs" / "calibration" / "twin_intrinsics.yaml"
    markers = [a for i, (x, y) in layout.items() for a in ("--marker", f"{i}:{x:g},{y:g}")]
    argv = ["calibrate-camera", "--intrinsics", intrinsics, "--out", pose, "--image", sheet,
            "--marker-side-cm", f"{SHEET_SIDE_CM:g}", *markers, "--config", mine]  # fmt: skip
    done = run_in_process(argv, within_s=60)
    assert done.code == 0, done.stderr
    backup = mine.with_name("my_twin.yaml.bak")
    assert backup.read_bytes() == before
    assert done.stdout.splitlines()[-2:] == [
        f"wrote {backup} (the old {mine})",
        f"pointed {mine} at {intrinsics} and {pose}",
    ]
    pointed = mine.read_bytes()
    again = run_in_process(argv, within_s=60)
    assert again.code == 0, again.stderr
    assert f"wrote {backup}" not in again.stdout
    assert mine.read_bytes() == pointed and backup.read_bytes() == before
