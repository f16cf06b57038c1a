"""An empty path on the command line is refused as empty, not taken for ``.``.

``Path("")`` is ``.``: ``--log=`` was refused as "``.``: is not a regular file", naming a
folder nobody typed, and a command that reads a folder would have read the current one.
Every path option of the shared parser (``type=Path``) now refuses the empty value.
"""

from __future__ import annotations

import pytest
from badinput import check_bad_input


@pytest.mark.bad_input
@pytest.mark.parametrize(
    "argv",
    [
        ["sort", "--config", "sim", "--log="],
        ["sort", "--config", "sim", "--save-mjcf="],
        ["experiment", "--config", "sim", "--trials", "1", "--log="],
        ["analyze", ""],
    ],
    ids=["sort-log", "sort-save-mjcf", "experiment-log", "analyze-log"],
)
def test_an_empty_path_is_refused_as_empty(argv, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = check_bad_input(argv, within_s=5, keep=[tmp_path])
    assert "the value is empty: give a path" in out.line, out.line
    assert list(tmp_path.iterdir()) == []
