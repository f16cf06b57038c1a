"""docs/learning.md walked as a new user, in a folder of their own, not a checkout."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("gymnasium")

from mearm.config.files import resolve_config_path  # noqa: E402

PAGE = Path(__file__).resolve().parent.parent / "docs" / "learning.md"


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", PAGE.read_text(), flags=re.DOTALL)


def test_every_config_the_page_names_loads_from_another_folder(tmp_path, monkeypatch):
    """``--config configs/sim_mujoco.yaml`` was "config file not found" (exit 2) anywhere
    but in a checkout; the packaged name loads from any folder."""
    monkeypatch.chdir(tmp_path)
    configs = [c for block in _blocks("bash") for c in re.findall(r"--config (\S+)", block)]
    assert configs, "the page's commands name no config"
    for config in configs:
        assert resolve_config_path(config).is_file(), config


def test_the_page_s_example_reads_the_observation_by_its_keys(tmp_path, monkeypatch):
    """The page's first example, run as written: its picture is ``obs["pixels"]["table"]``
    (the page said ``pixels/table``, a key no observation has: KeyError)."""
    monkeypatch.chdir(tmp_path)
    example = _blocks("python")[0]
    scope: dict[str, object] = {}
    exec(example, scope)  # noqa: S102 - the page's own code
    frame = scope["frame"]
    assert isinstance(frame, np.ndarray)
    assert frame.dtype == np.uint8 and frame.shape == (96, 128, 3)
    scope["env"].close()  # type: ignore[attr-defined]
