"""docs/troubleshooting.md's opening and its list of reasons are what the code does.

Found walking the page as a new user: its list of the reasons a sort leaves an object
stopped short of ``cut``, ``missed_belt`` and ``unseen`` (kinds :data:`LEFT_REASONS` holds
and the sorters report); it named two of the three places an unexpected error's traceback
goes (not ``$XDG_STATE_HOME/mearm/crash.log``) and not the line that says so; and it gave
Ctrl-C's exit status only, where a SIGTERM or a SIGHUP, taken as Ctrl-C, exit 143 and 129.
It said plain ``mearm find-camera`` wrote ``snapshots/camera0.png``: without ``--out`` the
snapshots go to ``camera_snapshots/``.
"""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from badinput import run_guarded

from mearm.cli import crash_log_path
from mearm.interrupts import STOP_SIGNALS
from mearm.maker.find_camera import main as find_camera
from mearm.task.report import LEFT_REASONS

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "troubleshooting.md"


def _page() -> str:
    """The page's text, with its lines joined (a quoted form may wrap)."""
    return " ".join(PAGE.read_text(encoding="utf-8").split())


def test_the_page_lists_every_left_reason() -> None:
    page = _page()
    start = page.index("the run log counts them per reason:")
    listed = set(re.findall(r"`([a-z_]+)`", page[start : page.index("What each means", start)]))
    listed.discard("task")  # `task.pick_retries`, not a reason
    assert listed == set(LEFT_REASONS)


def test_an_unexpected_error_is_the_line_the_page_shows(tmp_path, monkeypatch, capsys) -> None:
    monkeypatch.setenv("MEARM_STATE_DIR", str(tmp_path))
    monkeypatch.delenv("MEARM_DEBUG", raising=False)

    def broken(_argv: object) -> int:
        raise RuntimeError("boom")

    code, out, err = run_guarded(broken, ["sort"], capsys)
    assert (code, out) == (1, "")
    match = re.fullmatch(r"[^:]+: unexpected error: (\w+): (.+) \(traceback in (.+); (.+)\)\n", err)
    assert match, err
    assert match.groups() == ("RuntimeError", "boom", str(tmp_path / "crash.log"),
                              "--debug prints it")  # fmt: skip
    assert "RuntimeError: boom" in (tmp_path / "crash.log").read_text(encoding="utf-8")
    form = "`mearm COMMAND: unexpected error: TYPE: … (traceback in PATH; --debug prints it)`"
    assert form in _page()


def test_an_unexpected_error_with_a_name_that_is_not_utf8_is_one_line(
    tmp_path, monkeypatch, capsys
) -> None:
    """An argument whose bytes are not UTF-8 (a Linux file name; surrogates to Python)
    made the crash log's own write fail: a second traceback, not the one line."""
    monkeypatch.setenv("MEARM_STATE_DIR", str(tmp_path))
    monkeypatch.delenv("MEARM_DEBUG", raising=False)

    def broken(_argv: object) -> int:
        raise RuntimeError("boom")

    code, out, err = run_guarded(broken, ["analyze", "run\udcff.jsonl"], capsys)
    assert (code, out) == (1, "")
    assert len(err.splitlines()) == 1 and "unexpected error: RuntimeError: boom" in err, err
    assert "run\\udcff.jsonl" in (tmp_path / "crash.log").read_text(encoding="utf-8")


@pytest.mark.parametrize(
    ("env", "named"),
    [
        ({"MEARM_STATE_DIR": "/s", "XDG_STATE_HOME": "/x"}, "`$MEARM_STATE_DIR/crash.log`"),
        ({"XDG_STATE_HOME": "/x"}, "`$XDG_STATE_HOME/mearm/crash.log`"),
        ({}, "`~/.local/state/mearm/crash.log`"),
    ],
)
def test_the_page_names_each_place_of_the_crash_log(monkeypatch, env, named) -> None:
    for name in ("MEARM_STATE_DIR", "XDG_STATE_HOME"):
        monkeypatch.delenv(name, raising=False)
    for name, value in env.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setenv("HOME", "/h")
    expected = named.strip("`").replace("$MEARM_STATE_DIR", "/s")
    expected = expected.replace("$XDG_STATE_HOME", "/x").replace("~", "/h")
    assert crash_log_path() == Path(expected)
    assert named in _page()


def test_the_pages_give_each_stop_signals_exit_status() -> None:
    """Both pages that list the exit statuses name 128 + N for each signal taken as Ctrl-C."""
    assert {s.name for s in STOP_SIGNALS} == {"SIGTERM", "SIGHUP"}
    started = " ".join((ROOT / "docs" / "getting-started.md").read_text(encoding="utf-8").split())
    for sig in STOP_SIGNALS:
        status = 128 + int(sig)
        assert f"{status} on a {sig.name}" in _page(), sig.name
        assert re.search(rf"{sig.name}[^;)]*?exits {status}\b", started), sig.name


def test_find_cameras_snapshots_go_where_the_page_says(tmp_path, monkeypatch, capsys) -> None:
    """The page named ``snapshots/`` as where they go; that is ``--out snapshots``'s folder."""
    video = cv2.VideoWriter(str(tmp_path / "cam.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 10,
                            (64, 48))  # fmt: skip
    for value in (40, 80, 120):
        video.write(np.full((48, 64, 3), value, np.uint8))
    video.release()
    monkeypatch.chdir(tmp_path)
    code, out, err = run_guarded(find_camera, ["--camera", "cam.avi"], capsys)
    assert (code, err) == (0, "")
    assert "wrote camera_snapshots/camera-cam-avi.png" in out.splitlines()
    page = _page()
    assert "`mearm find-camera --out snapshots` lists the cameras" in page
    assert "without `--out` they go to `camera_snapshots/`" in page
