"""What a new user met with the maker's first commands (find-camera, find-port, init-config).

- ``mearm find-camera`` run twice (the maker's path takes a second snapshot with the
  markers on the table by the same command) replaced the first snapshot silently, and
  named no snapshot in a ``wrote`` line: the old one is now kept as ``.bak`` and both
  files are named.
- ``find-camera`` and ``find-port`` that found nothing ended with ``find-camera: …`` /
  ``find-port: …``, not the ``mearm COMMAND: error: …`` line every other failure ends
  with (docs/troubleshooting.md).
- ``init-config --of ../my_arm.yaml`` said the twin "extends my_arm.yaml" while the file
  it wrote extends ``../my_arm.yaml``.

The camera is a still image (OpenCV reads it as it reads a camera), the board a silent
pseudo-terminal: the only stand-ins.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import yaml
from conftest import mearm_cli, one_stderr_line

from mearm.maker import find_camera, init_config


def _image(path: Path, bgr: tuple[int, int, int]) -> Path:
    cv2.imwrite(str(path), np.full((60, 80, 3), bgr, np.uint8))
    return path


def test_find_camera_twice_keeps_the_first_snapshot_and_names_every_file(tmp_path, capsys):
    out = tmp_path / "snapshots"
    first = _image(tmp_path / "first.png", (0, 0, 200))
    second = _image(tmp_path / "second.png", (200, 0, 0))
    # the same source name both times, as camera 0 is on a second run
    source = tmp_path / "table.png"
    first.rename(source)
    assert find_camera.main(["--camera", str(source), "--out", str(out)]) == 0
    snap = out / find_camera.snapshot_name(str(source))
    assert f"wrote {snap}" in capsys.readouterr().out.splitlines()
    kept = snap.read_bytes()

    second.rename(source)
    assert find_camera.main(["--camera", str(source), "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    bak = snap.with_name(snap.name + ".bak")
    assert lines.index(f"wrote {bak} (the old {snap})") < lines.index(f"wrote {snap}"), lines
    assert bak.read_bytes() == kept
    assert cv2.imread(str(snap))[0, 0].tolist() == [200, 0, 0]


def test_find_camera_that_finds_none_ends_with_the_commands_error_line(tmp_path):
    proc = mearm_cli("find-camera", "--camera", "/dev/null", "--out", tmp_path / "s", cwd=tmp_path)
    line = one_stderr_line(proc, code=1)
    assert line.startswith("mearm find-camera: error: no cameras found (tried /dev/null)"), line
    assert not (tmp_path / "s").exists()


def test_init_config_twin_says_what_it_extends_as_the_file_does(tmp_path, monkeypatch, capsys):
    mine = tmp_path / "my_arm.yaml"
    assert init_config.main(["--arm", "mearm_v1", "--rig", "sim", str(mine)]) == 0
    (tmp_path / "twins").mkdir()
    monkeypatch.chdir(tmp_path / "twins")
    capsys.readouterr()
    assert init_config.main(["--of", "../my_arm.yaml", "--rig", "sim", "twin.yaml"]) == 0
    said = capsys.readouterr().out.splitlines()[0]
    extends = yaml.safe_load(Path("twin.yaml").read_text(encoding="utf-8"))["extends"]
    assert extends == "../my_arm.yaml"
    assert (
        said
        == "wrote twin.yaml: your my_arm.yaml on the sim rig (it extends ../my_arm.yaml). Next:"
    )
