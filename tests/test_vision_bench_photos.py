"""``mearm vision-bench --photos``: recall and precision on a folder of labelled photos."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from mearm.cli import run
from mearm.config import Config
from mearm.sim import TableRenderer, class_discs
from mearm.sim.kinematic.renderer import Disc
from mearm.tools import photo_bench
from mearm.tools.photo_bench import load_photos, object_px_of, run_click_study, run_photo_bench
from mearm.tools.vision_bench import main
from mearm.vision import Calibration

CONFIG = Config()
CAL = Calibration.from_config(CONFIG.calibration)
LAYOUT = [(o.color, o.x, o.y) for o in CONFIG.task.scene]


def centres(objects) -> dict:
    out: dict = {c.name: {"count": 0, "centres": []} for c in CONFIG.task.classes}
    for name, x, y in objects:
        ((u, v),) = CAL.table_to_pixel(np.array([[x, y]]))
        out[name]["centres"].append([round(float(u), 1), round(float(v), 1)])
        out[name]["count"] += 1
    return out


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two photos of one source at 2x (objects 64 px), one with a label moved off its object."""
    root = tmp_path_factory.mktemp("photos")
    r = TableRenderer(CAL, 640, 480, extras=(Disc((30, 130, 240), 16.0, 56.0),), table="grey")
    frame = r.render(class_discs(CONFIG.task.classes, LAYOUT))
    big = cv2.resize(frame, None, fx=2, fy=2, interpolation=cv2.INTER_LINEAR)
    cv2.imwrite(str(root / "a.png"), big)
    cv2.imwrite(str(root / "b.png"), big)
    labels = centres(LAYOUT)
    moved = centres(LAYOUT)
    moved["blue"]["centres"][0] = [5.0, 5.0]  # a blue object said to be where none is
    for entry in (labels, moved):
        for obj in entry.values():
            obj["centres"] = [[2 * u, 2 * v] for u, v in obj["centres"]]
    manifest = {
        "images": [
            {
                "file": "a.png",
                "source_repo": "x/y",
                "shapes": "cylinder (~64 px)",
                "objects": labels,
            },
            {
                "file": "b.png",
                "source_repo": "x/y",
                "shapes": "cylinder (~64 px)",
                "objects": moved,
                "partial": [{"colour": "red", "region": "x 0-10, y 0-10"}],
            },
        ]
    }
    (root / "manifest.yaml").write_text(yaml.safe_dump(manifest))
    return root


def by(rows: list[dict], scope: str, who: str) -> dict:
    return next(r for r in rows if r["scope"] == scope and r["who"] == who)


def test_photos_are_scaled_to_the_calibration(folder: Path) -> None:
    """Each photo is scaled so its objects are 32 px, its labels with it."""
    assert object_px_of(CONFIG) == pytest.approx(32.0)
    a, b = load_photos(folder, object_px_of(CONFIG))
    assert a.frame.shape[:2] == (480, 640)
    assert b.ignore == [pytest.approx((0.0, 5.0, 0.0, 5.0))]
    np.testing.assert_allclose(
        a.centres["red"][0], CAL.table_to_pixel(np.array([LAYOUT[0][1:]]))[0], atol=0.1
    )


def test_a_nearer_cameras_calibration_scores_the_photos_larger(folder: Path) -> None:
    """A calibration of 20 px/cm (a nearer camera) scales the photos so that objects are
    40 px; taught and scored there, every object on the true labels is found."""
    near = Config.model_validate(
        {"calibration": {"homography": [[0.05, 0, -20.5], [0, -0.05, 59.0], [0, 0, 1]]}}
    )
    assert object_px_of(near) == pytest.approx(40.0)
    a, _ = load_photos(folder, object_px_of(near))
    assert a.frame.shape[:2] == (600, 800)
    rows = run_photo_bench(folder, near, learn=True)
    a_row = by(rows, "a.png", "mearm")
    assert (a_row["found"], a_row["missed"], a_row["false"]) == (12, 0, 0)


@pytest.mark.parametrize("learn", [False, True])
def test_counts_per_photo_and_class(folder: Path, learn: bool) -> None:
    """All 12 found on the true labels; with a label moved, one blue missed and one false."""
    rows = run_photo_bench(folder, CONFIG, learn=learn)
    a, b = by(rows, "a.png", "mearm"), by(rows, "b.png", "mearm")
    assert (a["found"], a["missed"], a["false"]) == (12, 0, 0)
    assert (b["found"], b["missed"], b["false"]) == (11, 1, 1)
    blue = by(rows, "all photos, blue", "mearm")
    assert (blue["found"], blue["missed"], blue["false"]) == (7, 1, 1)
    total = by(rows, "all photos", "inRange")
    assert total["recall"] == pytest.approx(23 / 24) and total["precision"] == pytest.approx(
        23 / 24
    )


def test_command_prints_the_table(folder: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``--photos DIR --learn`` prints one row per photo, class and detector; bad folders exit 2."""
    with pytest.raises(SystemExit) as info:
        run(main, ["--photos", str(folder), "--learn"])
    out, _ = capsys.readouterr()
    assert info.value.code == 0
    assert "all photos" in out and "inRange" in out and "95.8%" in out
    (folder / "empty").mkdir(exist_ok=True)
    for where, words in [("nowhere", "no such folder"), ("empty", "no manifest.yaml")]:
        with pytest.raises(SystemExit) as info:
            run(main, ["--photos", str(folder / where)])
        _, err = capsys.readouterr()
        assert info.value.code == 2 and words in err and len(err.strip().splitlines()) == 1
    with pytest.raises(SystemExit) as info:
        run(main, ["--learn"])
    _, err = capsys.readouterr()
    assert info.value.code == 2 and "--learn needs --photos" in err


@pytest.mark.heavy
def test_click_study_teaches_every_way(folder: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each photo showing all classes teaches once per combination of clicked objects; a
    click on a label off its object (b's first blue) is refused and counted; each teaching
    scores both photos (23 of 24 found, 1 false: b's moved label)."""
    monkeypatch.setattr(photo_bench, "CLICKS_PER_CLASS", 2)
    source, everything = run_click_study(folder, CONFIG)
    assert source["scope"] == "source x/y" and everything["scope"] == "all sources"
    assert (source["teachings"], source["refused"]) == (12, 4)  # 2·2·2 from a, 4 from b
    assert everything["teachings"] == 12 and everything["refused"] == 4
    for row in (source, everything):
        assert row["recall"]["min"] == row["recall"]["max"] == pytest.approx(23 / 24)
        assert row["precision"]["min"] == row["precision"]["max"] == pytest.approx(23 / 24)


def test_every_click_command(
    folder: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--photos DIR --every-click`` prints the spread per source and over all; it needs
    ``--photos`` and is not given with ``--learn`` (exit 2, one line)."""
    monkeypatch.setattr(photo_bench, "CLICKS_PER_CLASS", 1)
    with pytest.raises(SystemExit) as info:
        run(main, ["--photos", str(folder), "--every-click"])
    out, _ = capsys.readouterr()
    assert info.value.code == 0
    lines = out.strip().splitlines()
    assert lines[0].startswith("taught every way") and "median" in lines[0]
    assert lines[1].startswith("source x/y") and lines[2].startswith("all sources")
    assert lines[2].split()[2:4] == ["1", "1"] and lines[2].count("95.8%") == 8
    lone = folder.parent / "lone"  # each photo labels one class: none shows all of them
    lone.mkdir(exist_ok=True)
    manifest = yaml.safe_load((folder / "manifest.yaml").read_text())
    for entry, keep in zip(manifest["images"], ("red", "blue"), strict=True):
        entry["file"] = str(folder / entry["file"])
        entry["objects"] = {keep: entry["objects"][keep]}
    (lone / "manifest.yaml").write_text(yaml.safe_dump(manifest))
    with pytest.raises(SystemExit) as info:
        run(main, ["--photos", str(lone), "--every-click"])
    _, err = capsys.readouterr()
    assert info.value.code == 2 and "source x/y: no photo shows every class it labels" in err
    for argv in (["--every-click"], ["--photos", str(folder), "--every-click", "--learn"]):
        with pytest.raises(SystemExit) as info:
            run(main, argv)
        _, err = capsys.readouterr()
        assert info.value.code == 2 and len(err.strip().splitlines()) == 1
        assert "--every-click" in err


def _edited(folder: Path, name: str, edit) -> Path:  # noqa: ANN001
    """A copy of the folder's manifest, its photos by absolute path, with ``edit`` applied."""
    copy = folder.parent / name
    copy.mkdir(exist_ok=True)
    manifest = yaml.safe_load((folder / "manifest.yaml").read_text())
    for entry in manifest["images"]:
        entry["file"] = str(folder / entry["file"])
    edit(manifest["images"])
    (copy / "manifest.yaml").write_text(yaml.safe_dump(manifest))
    return copy


def test_a_missing_photo_is_named_with_its_entry(folder: Path) -> None:
    """The error named the photo's path, not which of the manifest's entries lists it."""

    def lose(images: list[dict]) -> None:
        images[1]["file"] = str(folder / "missing.png")

    with pytest.raises(photo_bench.InputFileError) as info:
        load_photos(_edited(folder, "lost", lose), 32.0)
    assert "manifest.yaml" in info.value.path
    assert info.value.reason.startswith("images[1] (") and "missing.png" in info.value.reason


def test_an_entry_without_a_source_is_a_named_source(folder: Path) -> None:
    """Scored under a blank source (a row reading ``source `` and nothing more)."""

    def unsourced(images: list[dict]) -> None:
        for entry in images:
            del entry["source_repo"]

    photos = load_photos(_edited(folder, "unsourced", unsourced), 32.0)
    assert {p.source for p in photos} == {photo_bench.NO_SOURCE}

    def blank(images: list[dict]) -> None:
        images[0]["source_repo"] = " "

    with pytest.raises(photo_bench.InputFileError, match=r"images\[0\].*'source_repo'"):
        load_photos(_edited(folder, "blank", blank), 32.0)
