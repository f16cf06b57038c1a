"""``detect --annotate``: a picture already there is replaced only with ``--force``.

A second run, or a name shared with the user's own file, must not write over it
silently (the project's other writers refuse the same way, before any work).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import pytest
from conftest import run_main

from mearm import detect
from mearm.config import Config
from mearm.sim import TableRenderer, class_discs
from mearm.vision import Calibration


@pytest.fixture(scope="module")
def layout(tmp_path_factory) -> Path:
    """A rendered frame of the paper's 12 objects."""
    config = Config()
    frame = TableRenderer(Calibration.from_config(config.calibration)).render(
        class_discs(config.task.classes, [(o.color, o.x, o.y) for o in config.task.scene])
    )
    path = tmp_path_factory.mktemp("frames") / "layout.png"
    cv2.imwrite(str(path), frame)
    return path


def run_cli(capsys, *args: str) -> tuple[int, str, str]:
    return run_main(capsys, detect.main, *args)


def test_existing_picture_is_refused_before_any_work(capsys, tmp_path, layout) -> None:
    """Without --force: exit 2, one line naming the flag, nothing printed, file kept."""
    mine = tmp_path / "found.png"
    mine.write_bytes(b"the user's own picture")
    code, out, err = run_cli(capsys, str(layout), "--annotate", str(mine))
    assert code == 2
    assert out == ""
    assert err.count("\n") == 1
    assert f"--annotate {mine}: exists; pass --force to replace it" in err
    assert mine.read_bytes() == b"the user's own picture"


def test_one_of_several_pictures_there_refuses_them_all(capsys, tmp_path, layout) -> None:
    """With two images the second's OUT-1.png already there: none is written."""
    (tmp_path / "found-1.png").write_bytes(b"kept")
    out_path = tmp_path / "found.png"
    code, out, err = run_cli(capsys, str(layout), str(layout), "--annotate", str(out_path))
    assert code == 2 and out == ""
    assert "found-1.png: exists; pass --force" in err
    assert not (tmp_path / "found-0.png").exists()
    assert (tmp_path / "found-1.png").read_bytes() == b"kept"


def test_force_replaces_it(capsys, tmp_path, layout) -> None:
    """With --force the picture is written over, and said so."""
    target = tmp_path / "found.png"
    target.write_bytes(b"old")
    code, out, _ = run_cli(capsys, str(layout), "--annotate", str(target), "--force")
    assert code == 0
    assert out.splitlines()[-1] == f"wrote {target}"
    assert cv2.imread(str(target)) is not None
