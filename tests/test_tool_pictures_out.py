"""tools/calibration_pictures.py and tools/screenshots.py: where their pictures go.

An ``--out`` that is not a folder is refused in one line (exit 2), as the mearm commands
refuse it; a picture that cannot be written is said (not ``wrote``); calibration_pictures
replaces an earlier run's five pictures together, or leaves them as they were.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from badinput import exit_of, tool_module
from conftest import ROOT


@pytest.mark.parametrize(
    ("tool", "args"),
    [("calibration_pictures", []), ("screenshots", ["--only", "frames"])],
)
@pytest.mark.parametrize(
    ("where", "says"),
    [("afile", "exists and is not a folder"), ("afile/sub", "is a file, not a folder")],
)
def test_an_out_that_is_not_a_folder_is_refused_in_one_line(
    tmp_path, capsys, tool, args, where, says
):
    """It used to exit 1 with ``unexpected error: FileExistsError`` (a crash log)."""
    (tmp_path / "afile").write_text("mine")
    code = exit_of(tool_module(tool).main, [*args, "--out", str(tmp_path / where)])
    out, err = capsys.readouterr()
    (line,) = err.strip().splitlines()
    assert code == 2, line
    assert "--out" in line and says in line, line
    assert "unexpected" not in line and "wrote" not in out
    assert (tmp_path / "afile").read_text() == "mine"


def test_screenshots_says_a_picture_it_could_not_write(tmp_path, capsys):
    """A folder where a picture goes: exit 2, one line naming it, no ``wrote`` line for it
    (cv2.imwrite's False was ignored: exit 0 and ``wrote`` of a picture never written)."""
    (tmp_path / "frames_mearm_v1.png").mkdir()
    code = exit_of(tool_module("screenshots").main, ["--only", "frames", "--out", str(tmp_path)])
    out, err = capsys.readouterr()
    (line,) = err.strip().splitlines()
    assert code == 2, line
    assert f"cannot write {tmp_path / 'frames_mearm_v1.png'}: Is a directory" in line, line
    assert "frames_mearm_v1.png" not in out
    assert (tmp_path / "frames_mearm_v1.png").is_dir()


def test_screenshots_replaces_a_picture_in_one_step(tmp_path, capsys):
    """The new picture is renamed over the old one, not written into it: a second name
    of the old file (a hard link) keeps the old bytes, and no temporary file is left."""
    old = tmp_path / "frames_mearm_v1.png"
    old.write_bytes(b"the old picture")
    (tmp_path / "kept.png").hardlink_to(old)
    code = exit_of(tool_module("screenshots").main, ["--only", "frames", "--out", str(tmp_path)])
    assert code == 0, capsys.readouterr().err
    assert (tmp_path / "kept.png").read_bytes() == b"the old picture"
    assert old.read_bytes().startswith(b"\x89PNG")
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "frames_mearm_paper.png",
        "frames_mearm_v1.png",
        "kept.png",
    ]
    assert f"wrote {old}" in capsys.readouterr().out


CALIBRATION_PICTURES = (
    "calibration_board.png",
    "calibration_board_views.png",
    "calibration_sheet.png",
    "calibration_objects.png",
    "calibration_parallax.png",
)


def _earlier_run(out: Path) -> dict[str, bytes]:
    """An earlier run's five pictures (stand-ins) in ``out``, and a file of the user's."""
    out.mkdir()
    old = {name: f"earlier {name}".encode() for name in CALIBRATION_PICTURES}
    old["notes.txt"] = b"mine"
    for name, data in old.items():
        (out / name).write_bytes(data)
    return old


def test_calibration_pictures_sigterm_leaves_the_earlier_run_whole(tmp_path):
    """SIGTERM once the run has written its second picture: the earlier run's five stay, as
    they were, and no hidden folder (they were replaced one by one, a mix of two runs)."""
    out = tmp_path / "out"
    old = _earlier_run(out)
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.Popen(
        [sys.executable, str(ROOT / "tools" / "calibration_pictures.py"), "--out", str(out)],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    deadline = time.monotonic() + 120  # a hang only
    while proc.poll() is None and time.monotonic() < deadline:
        views = list(out.rglob("calibration_board_views.png"))
        if any(p.read_bytes().startswith(b"\x89PNG") for p in views if p.is_file()):
            break
        time.sleep(0.005)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == old


def test_calibration_pictures_replaces_the_earlier_run(tmp_path, capsys):
    """Without --force (as tools/screenshots.py), all five at once; the user's file stays."""
    out = tmp_path / "out"
    old = _earlier_run(out)
    code = exit_of(tool_module("calibration_pictures").main, ["--out", str(out)])
    text, err = capsys.readouterr()
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == sorted(old)
    for name in CALIBRATION_PICTURES:
        assert (out / name).read_bytes().startswith(b"\x89PNG")
        assert f"wrote {out / name} (" in text
    assert (out / "notes.txt").read_bytes() == b"mine"
