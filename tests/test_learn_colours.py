"""``mearm learn-colours``: the config it writes, detection with it, and its refusals."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_guarded as call

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
        (["red=12"], "expected CLASS=U,V, or CLASS=U,V@I for the I-th image from 0"),
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


def _ignoring_what_is_taught(config: Config) -> dict:
    """A config's data without what learn-colours teaches (colours, reference, work area)."""
    data = config.model_dump(mode="json")
    data["vision"].update(reference_bgr=None, work_area_px=None)
    for c in data["task"]["classes"]:
        c["learned_colour"] = None
    return data


def test_set_changes_the_config_taught_with_and_the_one_written(
    frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--set`` (refused as an unrecognized argument, though ``mearm --help`` promises it
    to every command that reads a config): NEW.yaml, written in another folder, extends
    the config given and keeps each value set, a class's by its name, a list whole."""
    mine = tmp_path / "rig" / "mine.yaml"
    mine.parent.mkdir()
    mine.write_text("extends: sim\nservo: {rate_hz: 40}\n")
    out = tmp_path / "taught" / "new.yaml"
    sets = ["task.classes.0.shape=cube", "task.classes.blue.bin_cm=[-20,60,20]",
            "camera.noise_std=0", "calibration.homography.0.2=-20.5"]  # fmt: skip
    argv = [str(frame_png), "--sample", first("red"), "--config", str(mine), "--out", str(out)]
    code, _, err = call(main, [*argv, *(a for s in sets for a in ("--set", s))], capsys)
    assert code == 0, err
    assert "extends: ../rig/mine.yaml\n" in out.read_text()
    taught = load_config(out)
    assert taught.task.class_named("red").learned_colour is not None
    assert taught.servo.rate_hz == 40 and taught.task.class_named("red").shape == "cube"
    assert _ignoring_what_is_taught(taught) == _ignoring_what_is_taught(load_config(mine, sets))


@pytest.mark.parametrize(("sets", "grey"), [([], False), (["--set", "camera.table=grey"], True)])
def test_set_changes_the_camera_taught_from(
    sets: list[str], grey: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--camera --set camera.table=grey`` teaches on the grey table the value draws, not
    on sim's wooden one (the table's colour printed: a*, b* near 0 on grey only)."""
    out = tmp_path / "x.yaml"
    argv = ["--camera", "--sample", first("red"), "--config", "sim", "--out", str(out), *sets]
    code, text, err = call(main, argv, capsys)
    assert code == 0, err
    _, a, b = (float(v) for v in text.split("table L*a*b* (")[1].split(")")[0].split(", "))
    assert (abs(a) < 3 and abs(b) < 3) == grey, text
    assert (load_config(out).camera.table == "grey") == grey


@pytest.mark.parametrize("joined", [False, True])
def test_a_work_area_past_the_frame_is_clipped(
    joined: bool, frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Points left of or above the frame, as ``--work-area -50,-50 ...`` or
    ``--work-area=-50,-50 ...`` (argparse took them for options: "unrecognized
    arguments"), are written as given, and detect finds every object inside the frame."""
    out = tmp_path / "x.yaml"
    points = ["-50,-50", "700,-50", "700,600", "-50,600"]
    area = [f"--work-area={points[0]}", *points[1:]] if joined else ["--work-area", *points]
    samples = [a for n in ("red", "green", "blue") for a in ("--sample", first(n))]
    argv = [str(frame_png), *samples, *area, "--config", "sim", "--out", str(out)]
    code, _, err = call(main, argv, capsys)
    assert code == 0, err
    assert load_config(out).vision.work_area_px == [(-50, -50), (700, -50), (700, 600), (-50, 600)]
    code, text, err = call(detect_main, ["--config", str(out), str(frame_png), "--json"], capsys)
    assert sorted(d["color"] for d in json.loads(text)) == sorted(c for c, _, _ in LAYOUT)


@pytest.mark.parametrize("point", ["9000,0", "0,-5000"])
def test_a_work_area_point_out_of_range_names_the_option(
    point: str, frame_png: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A point past what a config holds is refused naming ``--work-area`` and the range
    (it named NEW.yaml and the key vision.work_area_px.1.0); nothing is written."""
    out = tmp_path / "x.yaml"
    argv = [str(frame_png), "--sample", first("red"), "--config", "sim", "--out", str(out),
            "--work-area", "0,0", point, "600,400"]  # fmt: skip
    code, _, err = call(main, argv, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"error: --work-area {point}: U and V must be from -4096 to 8192 px" in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    ("point", "said"),
    [("640,nan", "U and V must be finite"), ("100,x", "expected U,V pixels"),
     ("inf,3", "U and V must be finite")],
)  # fmt: skip
@pytest.mark.parametrize("first_arg", [False, True])
def test_a_work_area_point_typed_wrong_is_named_not_taken_for_an_image(
    point: str, said: str, first_arg: bool, frame_png: Path, tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    """``640,nan`` after ``--work-area`` was left as a positional: "unrecognized arguments"
    at the end, or taken for the IMAGE before it; a picture's name with a comma stays one."""
    out = tmp_path / "x.yaml"
    area = ["--work-area", "0,0", "600,0", point]
    rest = ["--sample", first("red"), "--config", "sim", "--out", str(out)]
    argv = [*area, str(frame_png), *rest] if first_arg else [str(frame_png), *rest, *area]
    code, _, err = call(main, argv, capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert f"error: --work-area {point!r}: {said}" in err, err
    assert not out.exists()
    comma = tmp_path / "shot,1.png"
    comma.write_bytes(frame_png.read_bytes())
    argv = ["--work-area", "0,0", "640,0", "640,480", "0,480", str(comma), *rest]
    code, _, err = call(main, argv, capsys)
    assert code == 0, err


@pytest.mark.heavy
def test_a_frame_four_times_the_calibrations_finds_its_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """On a frame 4 times the calibration's size the table's colour was read 32-80 px from
    the clicks, inside the objects (now 4 times that): a table darker than the grey one
    and part of it for the work area; with the table found, detect finds all 12 objects."""
    k = 4
    r = TableRenderer(CAL, 640, 480, table="grey")
    small = r.render(class_discs(CONFIG.task.classes, LAYOUT))
    frame = tmp_path / "big.png"
    cv2.imwrite(str(frame), cv2.resize(small, None, fx=k, fy=k, interpolation=cv2.INTER_NEAREST))
    samples = []
    for n in ("red", "green", "blue"):
        u, v = (float(t) for t in first(n).split("=")[1].split(","))
        samples += ["--sample", f"{n}={u * k:.0f},{v * k:.0f}"]
    out = tmp_path / "big.yaml"
    code, text, err = call(
        main, [str(frame), *samples, "--config", "sim", "--out", str(out)], capsys
    )
    assert code == 0, err
    table = [float(v) for v in text.split("table L*a*b* (")[1].split(")")[0].split(", ")]
    assert np.allclose(table, [50, 0, 0], atol=2), text
    corners = [(2559, 1919), (0, 1919), (0, 0), (2559, 0)]
    assert np.allclose(load_config(out).vision.work_area_px, corners, atol=1), text  # all of it
    code, text, err = call(detect_main, ["--config", str(out), str(frame), "--json"], capsys)
    assert sorted(d["color"] for d in json.loads(text)) == sorted(c for c, _, _ in LAYOUT)


def test_a_whole_frame_not_asked_for_says_why(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A frame whose table shows only around the object: the table's colour covers under
    5 % of it, so no work area is found, and the line says so (it said "whole frame" as
    for ``--whole-frame``)."""
    frame = np.full((480, 640, 3), (40, 160, 40), np.uint8)  # a green field
    cv2.circle(frame, (320, 240), 65, (128, 128, 128), -1)  # the table, 4.3 % of the frame
    cv2.circle(frame, (320, 240), 16, (40, 40, 200), -1)  # a red object on it
    path = tmp_path / "f.png"
    cv2.imwrite(str(path), frame)
    argv = [
        str(path),
        "--sample",
        "red=320,240",
        "--config",
        "sim",
        "--out",
        str(tmp_path / "x.yaml"),
    ]
    code, text, err = call(main, argv, capsys)
    assert code == 0, err
    assert "work area: whole frame (no table found: " in text and "under 5%" in text, text
    code, text, err = call(main, [*argv, "--force", "--whole-frame"], capsys)
    assert code == 0 and "work area: whole frame\n" in text, err
