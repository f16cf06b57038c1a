"""Edges of three tools' command lines: find-camera, camera-accuracy, aruco-sheet.

- ``find-camera --out`` into a folder nothing can be written to is refused before any
  camera is read (it read each camera first and failed at the first snapshot);
- ``camera-accuracy``'s counts are refused each in its own words, naming the option, its
  range and the value given (one line named all three options and no value);
- ``aruco-sheet --side-cm`` is bounded by what fits the page: the refusal names the
  largest side that fits, and that side is printed (20 cm was allowed and never fitted).

Each runs in this process (:func:`badinput.check_bad_input`); only the camera is a stand-in.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import check_bad_input, run_in_process

from mearm.maker import find_camera
from mearm.vision.aruco import detect_markers

# ------------------------------------------------------------------------- find-camera


def _unwritable_folder(tmp_path: Path) -> tuple[Path, list[Path]]:
    """A folder this process cannot write in, and what to check is left intact.

    Root writes through permission bits: a read-only kernel folder stands in then.
    """
    if os.geteuid() == 0:
        target = Path("/sys/kernel")
        if not target.is_dir():
            pytest.skip("no /sys/kernel to stand for a folder root cannot write")
        return target, []
    target = tmp_path / "locked"
    target.mkdir(mode=0o500)
    return target, [target]


@pytest.mark.parametrize("below", ["", "snaps"], ids=["the-folder", "a-new-folder-in-it"])
def test_find_camera_refuses_an_unwritable_out_before_reading_a_camera(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, below: str
) -> None:
    read: list[object] = []

    def grab_frame(source: object, timeout_s: float) -> tuple[np.ndarray, str]:
        read.append(source)  # a camera that gives a frame: the stand-in for the hardware
        return np.zeros((48, 64, 3), np.uint8), ""

    monkeypatch.setattr(find_camera, "grab_frame", grab_frame)
    locked, keep = _unwritable_folder(tmp_path)
    out = locked / below if below else locked
    result = check_bad_input(["find-camera", "--out", out, "--camera", "0"], keep=keep)
    assert read == [], "a camera was read before the output was checked"
    assert result.stdout == ""
    assert f"--out {out}: " in result.line and "not writable" in result.line
    assert not (locked / "snaps").exists()


# ---------------------------------------------------------------------- camera-accuracy


@pytest.mark.parametrize(
    ("option", "value", "words"),
    [
        ("--scenes", "0", "--scenes must be a whole number in 1 … 100, got 0"),
        ("--scenes", "101", "--scenes must be a whole number in 1 … 100, got 101"),
        ("--objects", "0", "--objects must be a whole number in 1 … 40, got 0"),
        ("--views", "5", "--views must be a whole number in 6 … 60, got 5"),
    ],
)
def test_camera_accuracy_names_the_count_it_refuses(option: str, value: str, words: str) -> None:
    out = check_bad_input(["camera-accuracy", option, value])
    assert out.line.endswith(words), out.line


# -------------------------------------------------------------------------- aruco-sheet

LARGEST = re.compile(r"the largest side that fits is ([0-9.]+) cm")


@pytest.mark.heavy  # a page written and its markers detected, at each bound
@pytest.mark.parametrize(("ids", "dpi"), [("0,1,2,3", "300"), ("0", "72"), ("0,1,2,3,4,5", "150")])
def test_aruco_sheet_refuses_a_side_beyond_the_page_and_prints_the_largest(
    tmp_path: Path, ids: str, dpi: str
) -> None:
    """20 cm never fits A4 (two columns); the side the refusal names does, and prints at
    its size; a hundredth of a centimetre more is refused again."""
    out = tmp_path / "sheet.png"
    base = ["aruco-sheet", "--output", out, "--ids", ids, "--dpi", dpi]
    refused = check_bad_input([*base, "--side-cm", "20"], keep=[tmp_path])
    assert "fit on one A4 page" in refused.line
    found = LARGEST.search(refused.line)
    assert found is not None, refused.line
    largest = float(found.group(1))
    assert 1.0 <= largest < 20.0
    assert not out.exists()

    beyond = check_bad_input([*base, "--side-cm", f"{largest + 0.01:.2f}"], keep=[tmp_path])
    assert LARGEST.search(beyond.line).group(1) == found.group(1)

    done = run_in_process([*base, "--side-cm", str(largest)], within_s=10)
    assert done.code == 0, done.stderr
    page = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    markers = detect_markers(page)
    assert sorted(markers) == [int(i) for i in ids.split(",")]
    side_px = np.linalg.norm(markers[0][1] - markers[0][0])
    assert side_px == pytest.approx(largest / 2.54 * int(dpi), abs=1.5)
    # nothing in the half centimetre along the page's edges, where printers print nothing
    # (the scale bar began at the very edge at the largest side)
    edge = round(0.5 / 2.54 * int(dpi))
    for strip in (page[:edge], page[-edge:], page[:, :edge], page[:, -edge:]):
        assert strip.min() == 255


def test_aruco_sheet_names_how_many_markers_fit_at_the_least_side(tmp_path: Path) -> None:
    """Too many ids for any printable side: the refusal says how many fit."""
    out = tmp_path / "sheet.png"
    many = ",".join(str(i) for i in range(30))
    refused = check_bad_input(["aruco-sheet", "--output", out, "--ids", many, "--side-cm", "1"])
    found = re.search(r"30 markers do not fit on one A4 page at any --side-cm .*at most (\d+) fit",
                      refused.line)  # fmt: skip
    assert found is not None, refused.line
    most = int(found.group(1))
    fewer = ",".join(str(i) for i in range(most))
    assert (
        run_in_process(["aruco-sheet", "--output", out, "--ids", fewer, "--side-cm", "1"]).code == 0
    )
    more = ",".join(str(i) for i in range(most + 1))
    again = check_bad_input(["aruco-sheet", "--output", out, "--ids", more, "--side-cm", "1",
                             "--force"], keep=[out])  # fmt: skip
    assert f"at most {most} fit" in again.line


def test_aruco_sheet_says_how_many_ids_fit_in_its_help_and_refusals(tmp_path: Path) -> None:
    """The page holds 10 markers (2 columns of 5 at the least side): the help says so, and
    65 ids are refused in the words 30 are, not as "up to 64" that never fitted."""
    shown = run_in_process(["aruco-sheet", "--help"])
    assert shown.code == 0
    assert "at most 10 fit one A4 page" in " ".join(shown.stdout.split())
    out = tmp_path / "sheet.png"
    many = ",".join(str(i % 50) for i in range(65))
    refused = check_bad_input(["aruco-sheet", "--output", out, "--ids", many])
    assert refused.line.endswith(
        "65 markers do not fit on one A4 page at any --side-cm (the least is 1 cm); at most "
        "10 fit: split them over sheets"
    ), refused.line
    assert "64" not in refused.line
    from mearm.tools.aruco_sheet import most_that_fit  # noqa: PLC0415

    assert {most_that_fit(dpi) for dpi in (72, 150, 300, 600, 1200, 2400)} == {10}  # as said
