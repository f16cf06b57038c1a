"""A ``MUJOCO_GL`` MuJoCo cannot use is bad input: one line, exit 2.

From a wheel walk (2026-12-06): ``MUJOCO_GL=foo`` ended "unexpected error: RuntimeError:
invalid value for environment variable MUJOCO_GL: foo" (exit 1, a crash log), MuJoCo
refusing it as it is imported, without saying what it takes; ``MUJOCO_GL=glfw`` with no
display printed GLFW's four lines of warnings before the twin camera's own.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from conftest import ROOT


def _sort(gl: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    return subprocess.run(
        [sys.executable, "-m", "mearm", "sort", "--config", "sim_mujoco", "--quiet"],
        env={**env, "MUJOCO_GL": gl}, cwd=ROOT, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_a_value_mujoco_does_not_take_is_named_with_what_it_takes() -> None:
    done = _sort("foo")
    assert done.returncode == 2, done.stderr
    assert done.stderr.splitlines() == [
        "mearm sort: error: MUJOCO_GL='foo' is not a value MuJoCo takes: egl or osmesa render "
        "without a display, glfw (or glx) with one; unset it, or set MUJOCO_GL=egl"
    ]
    assert done.stdout == ""


def test_glfw_without_a_display_is_the_cameras_one_line() -> None:
    pytest.importorskip("glfw")
    done = _sort("glfw")
    assert done.returncode == 2, done.stderr
    [line] = done.stderr.splitlines()
    assert line.startswith("mearm sort: error: camera (twin): cannot render offscreen (")
    assert line.endswith("set MUJOCO_GL=egl or MUJOCO_GL=osmesa")
