"""``mearm learn-colours``: the config it writes, detection with it, and its refusals."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from mearm.cli import run
from mearm.config import Config, load_config
from mearm.detect import main as detect_main
from mearm.maker.learn_colours import main
from mearm.sim import TableRenderer, class_discs
from mearm.sim.kinematic.renderer import Disc
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]
ORANGE = Disc((30, 130, 240), 16.0, 56.0)


def pixel(x_cm: float, y_cm: float) -> str:
    ((u, v),) = CAL.table_to_pixel(np.array([[x_cm, y_cm]]))
    return f"{u:.0f},{v:.0f}"


def first(name: str) -> str:
    _, x, y = next(o for o in LAYOUT if o[0] == name)
    return f"{name}={pixel(x, y)}"


@pytest.fixture(scope="module")
def frame_png(tmp_path_factory: pytest.TempPathFactory) -> Path:
    r = TableRenderer(CAL, 640, 480, extras=(ORANGE,), table="grey")
    path = tmp_path_factory.mktemp("frames") / "frame.png"
    cv2.imwrite(str(path), r.render(class_discs(CONFIG.task.classes, LAYOUT)))
    return path


def call(fn, argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    with pytest.raises(SystemExit) as info:
        run(fn, argv)
    out, err = capsys.readouterr()
    return int(info.value.code or 0), out, err


def test_learned_config_is_used_by_detect(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The config written extends the old one with the learned colours; detect finds the
    12 objects with it and takes the orange disc for no class."""
    out = tmp_path / "learned.yaml"
    samples = [a for n in ("red", "green", "blue") for a in ("--sample", first(n))]
    code, text, err = call(
        main, [str(frame_png), *samples, "--config", "sim", "--out", str(out)], capsys
    )
    assert code == 0, err
    assert "wrote" in text and "red: a*b*" in text
    config = load_config(out)
    assert all(c.learned_colour is not None for c in config.task.classes)
    assert config.vision.reference_bgr is not None
    assert "extends: sim" in out.read_text()
    code, text, err = call(detect_main, ["--config", str(out), str(frame_png), "--json"], capsys)
    assert code == 0, err
    found = json.loads(text)
    assert sorted(d["color"] for d in found) == sorted(c for c, _, _ in LAYOUT)


def test_unsampled_classes_keep_their_bands(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A class not sampled keeps its hue bands, and its objects are still found."""
    out = tmp_path / "red_only.yaml"
    code, _, err = call(
        main,
        [str(frame_png), "--sample", first("red"), "--config", "sim", "--out", str(out)],
        capsys,
    )
    assert code == 0, err
    config = load_config(out)
    assert config.task.class_named("red").learned_colour is not None
    assert config.task.class_named("blue").learned_colour is None
    code, text, _ = call(detect_main, ["--config", str(out), str(frame_png), "--json"], capsys)
    assert sorted(d["color"] for d in json.loads(text)) == sorted(c for c, _, _ in LAYOUT)


@pytest.mark.parametrize(
    ("samples", "words"),
    [
        (["red=700,100"], "outside the image (640x480 px)"),
        (["red=1e9,-1e9"], "outside the image (640x480 px)"),
        (["purple=100,100"], "no class 'purple'"),
        (
            [first("red"), first("red").replace("red=", "green=")],
            "classes 'red' and 'green' were sampled on the same colour",
        ),
        (["red=5,5"], "grey or black pixel"),
        (["red=12"], "expected CLASS=U,V"),
        (["red=1,2@3"], "no image 3"),
    ],
)
def test_refusals(
    samples: list[str],
    words: str,
    frame_png: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Bad samples are refused with exit 2 and one line saying what is wrong; nothing is written."""
    out = tmp_path / "x.yaml"
    argv = [str(frame_png), "--config", "sim", "--out", str(out)]
    for s in samples:
        argv += ["--sample", s]
    code, text, err = call(main, argv, capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and words in err, err
    assert not out.exists()


def test_a_click_on_the_table_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """On a wooden table, coloured enough to pass for a class, a click on the table is
    refused with exit 2 and one line (a class taught there took the whole table), while
    the objects' clicks on the same frame teach."""
    frame = tmp_path / "wood.png"
    renderer = TableRenderer(CAL, 640, 480, table="wood")
    cv2.imwrite(str(frame), renderer.render(class_discs(CONFIG.task.classes, LAYOUT)))
    out = tmp_path / "x.yaml"
    argv = [str(frame), "--config", "sim", "--out", str(out), "--sample"]
    code, _, err = call(main, [*argv, "red=5,5"], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "on the table's colour" in err and not out.exists()
    code, _, err = call(main, [*argv, first("red")], capsys)
    assert code == 0 and out.exists(), err


def test_usage_refusals(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """No sample, images and --camera together, a two-point work area: exit 2, one line."""
    out = str(tmp_path / "x.yaml")
    for argv, words in [
        ([str(frame_png), "--config", "sim", "--out", out], "at least one --sample"),
        (
            [str(frame_png), "--camera", "--sample", "red=1,1", "--config", "sim", "--out", out],
            "one of the two",
        ),
        (
            [
                str(frame_png),
                "--sample",
                "red=1,1",
                "--work-area",
                "0,0",
                "5,5",
                "--config",
                "sim",
                "--out",
                out,
            ],
            "at least 3 points",
        ),
    ]:
        code, _, err = call(main, argv, capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1 and words in err, err


def _has_gui() -> bool:
    """Whether this OpenCV was built with a GUI (the headless wheels say ``GUI: NONE``)."""
    info = cv2.getBuildInformation()
    line = next((ln for ln in info.splitlines() if ln.strip().startswith("GUI:")), "GUI: NONE")
    return line.split(":", 1)[1].strip() != "NONE"


@pytest.mark.skipif(_has_gui(), reason="OpenCV has a GUI here: --pick would open a window")
def test_pick_without_a_display(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--pick`` where OpenCV cannot open a window: exit 2, one line saying what to do."""
    argv = [str(frame_png), "--pick", "--config", "sim", "--out", str(tmp_path / "x.yaml")]
    code, _, err = call(main, argv, capsys)
    assert code == 2 and "--pick needs a display" in err and len(err.strip().splitlines()) == 1


def test_a_config_already_written_is_not_lost(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--out`` the ``--config`` it extends was written over with a config that extends
    itself (then refused: the maker's config lost); any other existing file is replaced
    only with ``--force``."""
    mine = tmp_path / "mine.yaml"
    mine.write_text("extends: sim\nservo: {rate_hz: 40}\n")
    before = mine.read_text()
    red = ["--sample", first("red")]
    for extra in ([], ["--force"]):
        argv = [str(frame_png), *red, "--config", str(mine), "--out", str(mine), *extra]
        code, _, err = call(main, argv, capsys)
        assert code == 2 and "is the config it extends" in err, err
        assert mine.read_text() == before
    out = tmp_path / "taught.yaml"
    out.write_text("# kept\n")
    argv = [str(frame_png), *red, "--config", str(mine), "--out", str(out)]
    code, _, err = call(main, argv, capsys)
    assert code == 2 and f"--out {out} exists: pass --force" in err, err
    assert out.read_text() == "# kept\n"
    code, _, err = call(main, [*argv, "--force"], capsys)
    assert code == 0, err
    assert load_config(out).servo.rate_hz == 40
