"""``mearm config-docs --check PATH`` where PATH exists but is not a file: said as it is."""

from __future__ import annotations

from pathlib import Path

import pytest

from mearm.tools.config_docs import main


def check(path: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Exit status and stderr of ``config-docs --check PATH``."""
    with pytest.raises(SystemExit) as info:
        main(["--check", str(path)])
    return int(info.value.code or 0), capsys.readouterr().err


def test_a_folder_is_named_a_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A folder was said to be "no such file"."""
    code, err = check(tmp_path, capsys)
    assert code == 2 and "is a folder, not a file" in err and "no such" not in err, err


def test_a_device_is_not_a_regular_file(capsys: pytest.CaptureFixture[str]) -> None:
    """``/dev/null`` was said to be "no such file"."""
    code, err = check(Path("/dev/null"), capsys)
    assert code == 2 and "is not a regular file" in err and "no such" not in err, err


def test_a_missing_file_is_still_no_such_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, err = check(tmp_path / "none.md", capsys)
    assert code == 2 and "no such file" in err, err


def test_a_file_not_text_is_named(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Bytes that are not UTF-8 stopped on a UnicodeDecodeError."""
    page = tmp_path / "page.md"
    page.write_bytes(b"\xff\xfe\x00")
    code, err = check(page, capsys)
    assert code == 2 and "not a text file" in err, err
