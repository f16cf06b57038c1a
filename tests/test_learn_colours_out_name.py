"""``mearm learn-colours --config NAME --out`` where ``extends: NAME`` would read another
file: refused before the camera is read, and nothing is written or replaced."""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import run_guarded as call

from mearm.maker.learn_colours import main


def test_an_out_named_as_the_packaged_config_is_refused_and_not_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--out DIR/sim`` would extend itself (``extends: sim``): exit 2, no file left."""
    out = tmp_path / "sim"
    argv = ["--config", "sim", "--out", str(out), "--camera", "--sample", "red=316,84"]
    code, _, err = call(main, argv, capsys)
    assert code == 2 and "extends itself" in err and str(out) in err, err
    assert not out.exists()


def test_an_old_file_of_that_name_is_kept_as_it_was(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """With ``--force`` over a file of that name: refused, the file untouched."""
    out = tmp_path / "sim"
    out.write_text("servo: {rate_hz: 40}\n")
    argv = ["--config", "sim", "--out", str(out), "--force", "--camera", "--sample", "red=316,84"]
    code, _, err = call(main, argv, capsys)
    assert code == 2 and "extends itself" in err, err
    assert out.read_text() == "servo: {rate_hz: 40}\n"


def test_a_file_of_that_name_beside_out_is_not_extended_instead(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``extends: sim`` would read ``DIR/sim``, not the packaged sim: refused, none written."""
    (tmp_path / "sim").write_text("servo: {rate_hz: 40}\n")
    out = tmp_path / "learned.yaml"
    argv = ["--config", "sim", "--out", str(out), "--camera", "--sample", "red=316,84"]
    code, _, err = call(main, argv, capsys)
    assert code == 2 and "would be read instead" in err, err
    assert not out.exists()
