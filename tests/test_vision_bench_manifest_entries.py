"""``mearm vision-bench --photos``: a manifest entry's ``partial`` regions and ``shapes``
size that cannot be read are refused naming the entry (exit 2, one line), not a
traceback, an OpenCV assertion or regions silently dropped."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import yaml

from mearm.cli import run
from mearm.tools.vision_bench import main


def folder(root: Path, **entry: Any) -> Path:
    """One blank 640x480 photo and a manifest entry for it, with ``entry``'s keys."""
    cv2.imwrite(str(root / "a.png"), np.full((480, 640, 3), 128, np.uint8))
    given = {"file": "a.png", "source_repo": "x/y", "shapes": "cube (~32 px)"} | entry
    (root / "manifest.yaml").write_text(yaml.safe_dump({"images": [given]}))
    return root


def bench(root: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """``mearm vision-bench --photos ROOT`` in process: exit status, stdout, stderr."""
    with pytest.raises(SystemExit) as info:
        run(main, ["--photos", str(root)])
    out, err = capsys.readouterr()
    return int(info.value.code or 0), out, err


@pytest.mark.parametrize("partial", ["x 1-5, y 1-3", [5], ["x 1-5, y 1-3"], {"region": 1}])
def test_a_partial_that_is_not_a_list_of_regions_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], partial: Any
) -> None:
    """``partial: "x 1-5, y 1-3"`` or ``[5]`` stopped the bench on an AttributeError."""
    code, out, err = bench(folder(tmp_path, partial=partial), capsys)
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1, err
    assert "images[0] (a.png)" in err and "partial" in err, err
    assert "{region: 'x A-B, y C-D'}" in err, err


def test_a_size_wider_than_the_photo_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``shapes: "~100000 px"`` scaled the photo to nothing: an OpenCV assertion, exit 1."""
    code, out, err = bench(folder(tmp_path, shapes="~100000 px"), capsys)
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1, err
    assert "images[0] (a.png)" in err and "wider than the photo (640x480 px)" in err, err
    assert "1 <= N <= 480" in err, err


@pytest.mark.parametrize(
    "region", ["x 0-639; y 0-479", "x 0-639, y 0-479 and x 5-6, y 5-6", "y 0-479, x 0-639"]
)
def test_a_region_not_of_the_form_is_named_not_dropped(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], region: str
) -> None:
    """A region the pattern did not read was dropped: its detections all scored as false
    positives (12 on the twin's frame), exit 0."""
    code, out, err = bench(folder(tmp_path, partial=[{"region": region}]), capsys)
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1, err
    assert "images[0] (a.png): partial[0] is region" in err and region in err, err
    assert "{region: 'x A-B, y C-D'}" in err, err


def test_an_empty_region_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``x 600-10`` keeps no pixel: the detections it was meant to leave out would count."""
    code, _, err = bench(folder(tmp_path, partial=[{"region": "x 600-10, y 0-479"}]), capsys)
    assert code == 2 and "partial[0] region 'x 600-10, y 0-479' is empty" in err, err


def test_a_region_of_the_form_is_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The form as the docs give it (spaces free) is read, and the run goes on."""
    regions = [{"colour": "red", "region": "x 0-639, y 0-479"}, {"region": " x 1 - 5 ,y 2-3 "}]
    code, _, err = bench(folder(tmp_path, partial=regions), capsys)
    assert code == 0, err
