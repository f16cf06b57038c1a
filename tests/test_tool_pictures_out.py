"""tools/calibration_pictures.py and tools/screenshots.py: where their pictures go.

An ``--out`` that is not a folder is refused in one line (exit 2), as the mearm commands
refuse it; a picture that cannot be written is said (not ``wrote``).
"""

from __future__ import annotations

import importlib.util
import sys
from types import ModuleType

import pytest
from conftest import ROOT

from mearm.cli import run


def _tool(name: str) -> ModuleType:
    """A developer script of tools/ (not a package), imported from its file."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def _exit_of(main, argv: list[str]) -> int:
    """Run ``main`` under :func:`mearm.cli.run`, as its script does: the exit status."""
    with pytest.raises(SystemExit) as stop:
        run(main, argv)
    return int(stop.value.code or 0)


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
    code = _exit_of(_tool(tool).main, [*args, "--out", str(tmp_path / where)])
    out, err = capsys.readouterr()
    (line,) = err.strip().splitlines()
    assert code == 2, line
    assert "--out" in line and says in line, line
    assert "unexpected" not in line and "wrote" not in out
    assert (tmp_path / "afile").read_text() == "mine"
