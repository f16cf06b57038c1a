"""Inputs that cannot teach a colour, or score a photo, are refused up front (exit 2, one
line); those that can (samples only on a later frame) teach as the first frame's do."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from badinput import run_guarded as call

from mearm.config import Config
from mearm.detect import main as detect_main
from mearm.maker.learn_colours import main as learn_main
from mearm.tools.vision_bench import main as bench_main
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]


def pixel(x_cm: float, y_cm: float) -> tuple[float, float]:
    ((u, v),) = CAL.table_to_pixel(np.array([[x_cm, y_cm]]))
    return float(u), float(v)


def nth(name: str, n: int = 0) -> str:
    """``CLASS=U,V`` on the n-th object of class ``name``."""
    _, x, y = [o for o in LAYOUT if o[0] == name][n]
    u, v = pixel(x, y)
    return f"{name}={u:.0f},{v:.0f}"


def refused(code: int, err: str, *words: str) -> bool:
    lines = err.strip().splitlines()
    return code == 2 and len(lines) == 1 and all(w in lines[0] for w in words)


def test_samples_only_on_a_later_image_teach(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``CLASS=U,V@1`` with no sample on image 0 crashed (an empty ring around no samples);
    the same frame twice, sampled on the second, now teaches what the first teaches."""
    base = [str(frame_png), "--config", "sim"]
    code, _, err = call(
        learn_main, [*base, "--sample", nth("red"), "--out", str(tmp_path / "a.yaml")], capsys
    )
    assert code == 0, err
    argv = [str(frame_png), *base, "--sample", nth("red") + "@1", "--out", str(tmp_path / "b.yaml")]
    code, _, err = call(learn_main, argv, capsys)
    assert code == 0, err
    first, later = (yaml.safe_load((tmp_path / f).read_text()) for f in ("a.yaml", "b.yaml"))
    assert later == first


def test_an_image_without_table_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 1 x 1 image (no table around the sample to read its colour from) crashed; now
    exit 2 and one line saying the image shows no table."""
    one = tmp_path / "one.png"
    cv2.imwrite(str(one), np.full((1, 1, 3), (0, 0, 200), np.uint8))
    out = tmp_path / "x.yaml"
    argv = [str(one), "--sample", "red=0,0", "--config", "sim", "--out", str(out)]
    code, _, err = call(learn_main, argv, capsys)
    assert refused(code, err, "shows no table around the samples"), err
    assert not out.exists()


def test_one_class_on_two_colours_is_refused(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A class sampled on a red and a green object taught a colour between them that
    finds neither (exit 0 before); two red objects still teach red."""
    out = tmp_path / "x.yaml"
    base = [str(frame_png), "--config", "sim", "--out", str(out)]
    red, green = nth("red"), nth("green").replace("green=", "red=")
    code, _, err = call(learn_main, [*base, "--sample", red, "--sample", green], capsys)
    assert refused(code, err, "class 'red' was sampled on two different colours", red, green)
    assert not out.exists()
    code, _, err = call(learn_main, [*base, "--sample", red, "--sample", nth("red", 1)], capsys)
    assert code == 0, err


@pytest.mark.parametrize(
    ("area", "words"),
    [
        (["0,0", "10,0", "10,10", "0,10"], "class 'red' has no sample inside --work-area"),
        (["0,0", "0,0", "0,0"], "--work-area encloses 0 px²"),
        (["0,0", "100,100", "300,300"], "--work-area encloses 0 px²"),
    ],
)
def test_a_work_area_that_cannot_hold_the_samples_is_refused(
    area: list[str],
    words: str,
    frame_png: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A work area away from a class's samples, or with no area, wrote a config that
    detects nothing (exit 0 before)."""
    out = tmp_path / "x.yaml"
    argv = [str(frame_png), "--sample", nth("red"), "--config", "sim", "--out", str(out)]
    code, _, err = call(learn_main, [*argv, "--work-area", *area], capsys)
    assert refused(code, err, words), err
    assert not out.exists()


def test_out_is_never_an_input_image(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--out`` the frame taught from replaced it with YAML under ``--force``; now
    refused, by any name (a hard link too), and the frame is kept."""
    frame = tmp_path / "frame.png"
    frame.write_bytes(frame_png.read_bytes())
    link = tmp_path / "link.png"
    link.hardlink_to(frame)
    before = frame.read_bytes()
    for out in (frame, link):
        argv = [str(frame), "--sample", nth("red"), "--config", "sim", "--out", str(out)]
        code, _, err = call(learn_main, [*argv, "--force"], capsys)
        assert refused(code, err, "is one of the images it learns from"), err
        assert frame.read_bytes() == before


def _manifest(root: Path, frame_png: Path, entry: dict | None, raw: bytes | None = None) -> Path:
    folder = root / "photos"
    folder.mkdir()
    (folder / "s.png").write_bytes(frame_png.read_bytes())
    if raw is None:
        images = [] if entry is None else [{"file": "s.png", "source_repo": "me/x", **entry}]
        raw = yaml.safe_dump({"images": images}).encode()
    (folder / "manifest.yaml").write_bytes(raw)
    return folder


def _red(centres: object) -> dict:
    return {"shapes": "cube (~32 px)", "objects": {"red": {"centres": centres}}}


@pytest.mark.parametrize(
    ("entry", "raw", "words"),
    [
        (
            {"shapes": "cube (~32 px)", "objects": {"purple": {"centres": [[316, 85]]}}},
            None,
            "images[0] (s.png): class 'purple' is not one of the config's (red, green, blue)",
        ),
        (_red([[99999, -5]]), None, "images[0] (s.png): objects.red centre [99999, -5] is outside"),
        (_red("abc"), None, "images[0] (s.png): objects.red must be {centres: [[u, v], ...]}"),
        (_red([["a", 5]]), None, "objects.red must be {centres"),
        (
            {"shapes": "cube (~32 px)", "objects": {"red": {"count": 2, "centres": [[316, 85]]}}},
            None,
            "images[0] (s.png): objects.red has count 2 but 1 centre: ",
        ),
        ({**_red([[316, 85]]), "shapes": "cube (~0 px)"}, None, "objects 0 px wide"),
        (None, None, "'images' is empty"),
        (None, b"images:\n- file: s.png\n  shapes: '\xff'\n", "save the manifest file as UTF-8"),
    ],
)
def test_a_bad_manifest_is_refused(
    entry: dict | None,
    raw: bytes | None,
    words: str,
    frame_png: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Each crashed (cvtColor, ZeroDivisionError, ValueError) or scored nothing with exit
    0; now exit 2, one line naming the manifest entry and what is allowed, no table."""
    folder = _manifest(tmp_path, frame_png, entry, raw)
    for extra in ([], ["--learn"], ["--every-click"]):
        code, out, err = call(
            bench_main, ["--photos", str(folder), "--config", "sim", *extra], capsys
        )
        assert refused(code, err, "manifest.yaml", words), err
        assert out == ""


def test_a_grayscale_image_is_detected_with_a_warning(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A single-channel image gave "0 object(s)" with no word that it has no colour."""
    gray = tmp_path / "gray.png"
    cv2.imwrite(str(gray), cv2.imread(str(frame_png), cv2.IMREAD_GRAYSCALE))
    code, out, err = call(detect_main, ["--config", "sim", str(gray)], capsys)
    assert code == 0 and "0 object(s)" in out
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "has no colour" in lines[0], err
    code, out, err = call(detect_main, ["--config", "sim", str(frame_png)], capsys)
    assert code == 0 and err == "" and "12 object(s)" in out
