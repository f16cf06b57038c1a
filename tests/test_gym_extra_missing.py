"""Without the ``gym`` extra, the ``python -m`` commands that need it say so in one line.

``python -m mearm.learn.bc`` and ``python -m mearm.envs.replay`` (docs/learning.md)
imported Gymnasium at the top of ``mearm.envs``, before their ``run`` could say anything:
a traceback ending ``ModuleNotFoundError: No module named 'gymnasium'``, exit 1 (a wheel
installed without ``[gym]``, 2026-12-06). A ``gymnasium`` package here that fails as a
missing one stands in for it (the venv has the extra).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

MISSING = 'raise ModuleNotFoundError("No module named \'gymnasium\'", name="gymnasium")\n'


@pytest.fixture
def no_gym(tmp_path: Path) -> dict[str, str]:
    (tmp_path / "gymnasium").mkdir()
    (tmp_path / "gymnasium" / "__init__.py").write_text(MISSING)
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}


@pytest.mark.parametrize("module", ["mearm.envs.replay", "mearm.learn.bc"])
def test_the_command_names_the_extra_in_one_line(module: str, no_gym, tmp_path) -> None:
    done = subprocess.run(
        [sys.executable, "-m", module, "rec"], env=no_gym, cwd=tmp_path,
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [
        f"python -m {module}: error: {module} needs Gymnasium, which is not installed: "
        "pip install 'mearm[gym]'"
    ]


def test_a_script_of_ones_own_gets_the_error_naming_the_extra(no_gym, tmp_path) -> None:
    """Imported by a user's script, the package raises (no exit): ModuleNotFoundError."""
    script = tmp_path / "mine.py"
    script.write_text(
        "try:\n    import mearm.envs\nexcept ModuleNotFoundError as exc:\n"
        "    print(exc.name, exc)\n"
    )
    done = subprocess.run(
        [sys.executable, str(script)], env=no_gym, cwd=tmp_path,
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == (
        "gymnasium mearm needs Gymnasium, which is not installed: pip install 'mearm[gym]'"
    )
