"""``mearm vision-bench --photos``: labels a teaching refuses are named as the manifest
gives them (rendered frames only)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from mearm.cli import run
from mearm.config import Config
from mearm.sim import TableRenderer, class_discs
from mearm.tools.vision_bench import main
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]


def labels(scale: float) -> dict:
    """Each class's labelled centres, in the pixels of the frame scaled by ``scale``."""
    out: dict = {c.name: {"centres": []} for c in CONFIG.task.classes}
    for name, x, y in LAYOUT:
        ((u, v),) = CAL.table_to_pixel(np.array([[x, y]]))
        out[name]["centres"].append([round(scale * float(u), 1), round(scale * float(v), 1)])
    return out


def photo_folder(root: Path, objects: dict) -> Path:
    """One rendered photo at 2x (objects ~64 px) and its manifest listing ``objects``."""
    frame = TableRenderer(CAL, 640, 480, table="grey").render(
        class_discs(CONFIG.task.classes, LAYOUT)
    )
    cv2.imwrite(str(root / "a.png"), cv2.resize(frame, None, fx=2, fy=2))
    entry = {"file": "a.png", "source_repo": "x/y", "shapes": "cylinder (~64 px)"}
    manifest = {"images": [entry | {"objects": objects}]}
    (root / "manifest.yaml").write_text(yaml.safe_dump(manifest))
    return root


def bench(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``mearm vision-bench ARGV`` in process: exit status, stdout, stderr."""
    with pytest.raises(SystemExit) as info:
        run(main, argv)
    out, err = capsys.readouterr()
    return int(info.value.code or 0), out, err


@pytest.fixture()
def grey_label(tmp_path: Path) -> Path:
    """The first red label on the grey table, (10, 900) in the photo's own pixels."""
    objects = labels(2.0)
    objects["red"]["centres"][0] = [10.0, 900.0]
    return photo_folder(tmp_path, objects)


def test_learn_names_the_label_it_cannot_teach_from(
    grey_label: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--learn`` with a label on the table said ``sample red=5,450: is on a grey ...``:
    a click in the scaled photo's pixels, in no manifest. It names the entry and the
    label as given, exit 2, one line."""
    code, out, err = bench(["--photos", str(grey_label), "--learn"], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1, err
    assert "manifest.yaml: images[0] (a.png)" in lines[0], err
    assert "objects.red centre [10, 900]" in lines[0] and "grey or black" in lines[0], err


def test_shipped_bands_do_not_teach(grey_label: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Without ``--learn`` the photos were taught all the same, so a label the teacher
    refuses stopped a run of the shipped hue bands; they are scored as they are."""
    code, out, err = bench(["--photos", str(grey_label)], capsys)
    assert code == 0, err
    rows = {tuple(line.split()[:2]): line.split() for line in out.splitlines()}
    assert rows["a.png", "mearm"][3] == "1", out  # the label on the table: missed


def test_every_click_says_why_no_teaching_was_left(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Green labelled on a red object: every teaching is refused, and ``--every-click``
    said "no photo shows all its source's classes", which it does. It names the refusal."""
    objects = labels(2.0)
    objects["red"]["centres"] = objects["red"]["centres"][:1]
    objects["green"]["centres"] = objects["red"]["centres"]  # the same red object
    folder = photo_folder(tmp_path, objects)
    code, out, err = bench(["--photos", str(folder), "--every-click"], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1, err
    u, v = objects["red"]["centres"][0]
    assert "source x/y: each of its 4 teachings was refused" in lines[0], err
    assert f"centre [{u:g}, {v:g}]" in lines[0] and "same colour" in lines[0], err
