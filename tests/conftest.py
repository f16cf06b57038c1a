"""Shared fixtures."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mearm.config import Config, load_config
from mearm.kinematics import ArmModel

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="session")
def config() -> Config:
    return Config()


@pytest.fixture(scope="session")
def lab_config() -> Config:
    return load_config(ROOT / "configs" / "lab.yaml")


@pytest.fixture(scope="session")
def model(config: Config) -> ArmModel:
    return ArmModel(config.robot)


def run_cli(*args: str, timeout: float = 60, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    """Run ``python <args>`` as a user would, capturing text output."""
    return subprocess.run(
        [sys.executable, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd
    )


def require_tool(*names: str) -> str:
    """Path of the first tool found; skip (or fail in CI, MEARM_REQUIRE_TOOLS=1) if none."""
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    msg = f"none of {names} is installed"
    if os.environ.get("MEARM_REQUIRE_TOOLS") == "1":
        pytest.fail(f"{msg}, and MEARM_REQUIRE_TOOLS=1 says it must be")
    pytest.skip(msg)
