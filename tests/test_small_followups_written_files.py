"""What two commands say about the files they write, and what a failed write leaves.

- ``render-calibration --raised-height-cm`` wrote ``raised_markers.txt`` without naming it
  on its summary line: every file the command writes is named there now.
- ``find-camera``: a snapshot that cannot be written once ``--out`` passed its check (a
  disk that fills mid-run) exited 2, bad input; it is a failure of the run (exit 1), one
  line naming the file, with nothing half-written and no folder made for nothing left.
"""

from __future__ import annotations

import errno
import os
import re
from pathlib import Path

import numpy as np
import pytest
from badinput import ROOT, check_bad_input, run_in_process

from mearm.maker import find_camera

CONFIG = ROOT / "configs" / "sim_mujoco_perspective.yaml"


@pytest.mark.heavy
def test_render_calibration_names_every_file_it_writes(tmp_path: Path) -> None:
    """With every option that adds files, each file in --out is named on stdout (the board
    views by the count and the first one's path)."""
    out = tmp_path / "calib"
    res = run_in_process(
        ["render-calibration", "--config", CONFIG, "--out", out, "--views", "1",
         "--raised-height-cm", "15", "--truth"],
        within_s=60,
    )  # fmt: skip
    assert res.code == 0, res.stderr
    written = sorted(p.name for p in out.iterdir())
    assert "raised_markers.txt" in written and "truth_pose.yaml" in written
    assert f"wrote 1 board views ({out / 'board_00.png'} …)" in res.stdout
    unnamed = [
        name
        for name in written
        if not re.fullmatch(r"board_\d+\.png", name) and str(out / name) not in res.stdout
    ]
    assert unnamed == [], f"written but not named: {unnamed}; stdout: {res.stdout!r}"


# --------------------------------------------------------------------------- find-camera


def _cameras_and_a_disk_that_fills(monkeypatch: pytest.MonkeyPatch, full_from: int) -> None:
    """Cameras 0, 1, … that each give a frame (the stand-in for the hardware), and a disk
    that refuses to make a file durable (ENOSPC at fsync, as a full ext4 reports delayed
    writes) once camera ``full_from`` has been read: the snapshot is on disk, unfinished."""
    full = {"now": False}

    def grab_frame(source: object, timeout_s: float) -> tuple[np.ndarray, str]:
        full["now"] = full["now"] or source == full_from
        frame = np.zeros((48, 64, 3), np.uint8)
        frame[:, :32] = (0, 0, 200)
        return frame, ""

    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        if full["now"]:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real_fsync(fd)

    monkeypatch.setattr(find_camera, "grab_frame", grab_frame)
    monkeypatch.setattr(os, "fsync", fsync)


@pytest.mark.parametrize("given", ["new", "existing"])
def test_a_snapshot_the_disk_refuses_is_a_failure_of_the_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, given: str
) -> None:
    """Exit 1, one line naming the snapshot; no snapshot or temporary file left, the
    folders the run made removed, an existing folder's files kept."""
    if given == "new":
        out = tmp_path / "made" / "snaps"
    else:
        out = tmp_path / "snaps"
        out.mkdir()
        (out / "notes.txt").write_text("mine\n")
    _cameras_and_a_disk_that_fills(monkeypatch, full_from=0)
    res = check_bad_input(["find-camera", "--out", out, "--camera", "0"], code=1, keep=[tmp_path])
    assert res.line.endswith(
        f"error: cannot write the snapshot {out / 'camera0.png'}: No space left on device"
    ), res.line
    if given == "new":
        assert list(tmp_path.iterdir()) == []
    else:
        assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


def test_the_snapshots_written_before_the_disk_filled_are_kept(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Camera 0's snapshot, written whole, stays (and so does the folder made for it);
    camera 1's, refused, is not left half-written."""
    out = tmp_path / "snaps"
    _cameras_and_a_disk_that_fills(monkeypatch, full_from=1)
    res = check_bad_input(["find-camera", "--out", out, "--camera", "0", "--camera", "1"], code=1)
    assert f"cannot write the snapshot {out / 'camera1.png'}" in res.line
    assert f"snapshot {out / 'camera0.png'}" in res.stdout
    assert [p.name for p in out.iterdir()] == ["camera0.png"]
