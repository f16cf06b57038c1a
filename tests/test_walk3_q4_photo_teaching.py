"""``vision-bench --photos --learn / --every-click``: which photo a source is taught from.

A source's first photo may label only some of its classes; taught from it, the other
classes kept the config's hue bands while the rows said "taught". Each source is now
taught from its first photo that shows every class it labels, and a source with no such
photo is refused (exit 2) by both modes, rather than taught in part or left out of
``--every-click``'s totals without a word.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from mearm.cli import run
from mearm.config import Config
from mearm.errors import InputFileError
from mearm.sim import TableRenderer, class_discs
from mearm.tools import photo_bench
from mearm.tools.vision_bench import main
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]


def _labels(keep: tuple[str, ...]) -> dict:
    """The layout's objects of the classes ``keep``, at their pixels in a 2x frame."""
    out: dict = {}
    for name, x, y in LAYOUT:
        if name in keep:
            ((u, v),) = CAL.table_to_pixel(np.array([[x, y]]))
            out.setdefault(name, {"centres": []})["centres"].append(
                [round(2 * float(u), 1), round(2 * float(v), 1)]
            )
    return out


def _folder(
    root: Path, entries: list[tuple[str, str, tuple[str, ...]]], cameras: dict | None = None
) -> Path:
    """Photos (file, source, classes labelled) of the paper's layout at 2x, and a manifest;
    ``cameras``: per file, its entry's ``camera``."""
    root.mkdir()
    frame = TableRenderer(CAL, 640, 480, table="grey").render(
        class_discs(CONFIG.task.classes, LAYOUT)
    )
    big = cv2.resize(frame, None, fx=2, fy=2, interpolation=cv2.INTER_LINEAR)
    images = []
    for file, source, keep in entries:
        cv2.imwrite(str(root / file), big)
        images.append(
            {
                "file": file,
                "source_repo": source,
                "shapes": "cylinder (~64 px)",
                "objects": _labels(keep),
                **({"camera": cameras[file]} if file in (cameras or {}) else {}),
            }
        )
    (root / "manifest.yaml").write_text(yaml.safe_dump({"images": images}))
    return root


ALL = ("red", "green", "blue")


def test_learn_teaches_from_the_first_photo_that_shows_every_class(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The first photo labels red only: the source is taught from the second, all 3 classes."""
    folder = _folder(tmp_path / "p", [("a.png", "x/y", ("red",)), ("b.png", "x/y", ALL)])
    taught_from: list[tuple[str, set[str]]] = []
    real = photo_bench.learned_config

    def spy(config, photo, clicks=None):
        taught_from.append((photo.name, set(photo.centres)))
        return real(config, photo, clicks)

    monkeypatch.setattr(photo_bench, "learned_config", spy)
    photo_bench.run_photo_bench(folder, CONFIG, learn=True)
    assert taught_from == [("b.png", set(ALL))]


def test_a_source_no_photo_can_teach_is_refused_by_learn(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Red on one photo, green and blue on the other: exit 2, one line naming the source."""
    folder = _folder(
        tmp_path / "p", [("a.png", "x/y", ("red",)), ("b.png", "x/y", ("green", "blue"))]
    )
    with pytest.raises(SystemExit) as info:
        run(main, ["--photos", str(folder), "--learn"])
    out, err = capsys.readouterr()
    assert info.value.code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert "source x/y: no photo shows every class it labels (blue, green, red)" in err


def test_every_click_does_not_leave_such_a_source_out(tmp_path: Path) -> None:
    """One source teachable, one not: refused, not scored over the teachable one alone."""
    folder = _folder(
        tmp_path / "p",
        [("a.png", "bad/one", ("red",)), ("b.png", "bad/one", ("blue",)), ("c.png", "ok/one", ALL)],
    )
    with pytest.raises(InputFileError, match="source bad/one: no photo shows every class"):
        photo_bench.run_click_study(folder, CONFIG)


def test_each_camera_of_a_source_is_taught_from_its_own_photo(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """One repository, two cameras (``camera:``): taught twice, each from its own camera's
    first photo, and scored as two sources; a photo naming no camera stays the repo's."""
    folder = _folder(
        tmp_path / "p",
        [("a.png", "x/y", ALL), ("b.png", "x/y", ALL), ("c.png", "x/y", ALL)],
        cameras={"a.png": "phone", "b.png": "webcam"},
    )
    taught_from: list[tuple[str, str]] = []
    real = photo_bench.learned_config

    def spy(config, photo, clicks=None):
        taught_from.append((photo.name, photo.source))
        return real(config, photo, clicks)

    monkeypatch.setattr(photo_bench, "learned_config", spy)
    rows = photo_bench.run_photo_bench(folder, CONFIG, learn=True)
    assert taught_from == [("a.png", "x/y (phone)"), ("b.png", "x/y (webcam)"), ("c.png", "x/y")]
    scopes = {r["scope"] for r in rows if r["scope"].startswith("source ")}
    assert scopes == {"source x/y (phone)", "source x/y (webcam)", "source x/y"}


@pytest.mark.parametrize("camera", [3, "", "  ", ["phone"]])
def test_a_camera_that_is_not_a_name_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], camera: object
) -> None:
    """``camera:`` of a number, a list or blank text: exit 2, one line naming the entry."""
    folder = _folder(tmp_path / "p", [("a.png", "x/y", ALL)], cameras={"a.png": camera})
    with pytest.raises(SystemExit) as info:
        run(main, ["--photos", str(folder), "--learn"])
    out, err = capsys.readouterr()
    assert info.value.code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert "images[0] (a.png): its 'camera' is" in err and "give the camera's name" in err
