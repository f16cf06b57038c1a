"""A script that records at its top level: the spawned encoder dies importing it.

The encoder is a process of its own, started by ``spawn``, which imports the ``__main__``
script first; a script without ``if __name__ == "__main__":`` records again in the child,
which stops with Python's bootstrapping error, and the run said only "the video encoder
process stopped (exit code 1)" (a library walk, 2026-12-06). It names the guard now, for
a script outside mearm whose encoder never answered.
"""

from __future__ import annotations

import sys
import types
from pathlib import Path

import pytest

from mearm.dataset import video_encoder


def _main_at(monkeypatch: pytest.MonkeyPatch, path: Path) -> None:
    main = types.ModuleType("__main__")
    main.__file__ = str(path)
    monkeypatch.setitem(sys.modules, "__main__", main)


def test_a_script_of_ones_own_is_told_the_guard(monkeypatch, tmp_path: Path) -> None:
    _main_at(monkeypatch, tmp_path / "rec.py")
    hint = video_encoder._script_hint(heard=False)
    assert hint.startswith("; if rec.py is your own script, put what it runs under ")
    assert '`if __name__ == "__main__":`' in hint
    assert video_encoder._script_hint(heard=True) == ""  # it started: something else


def test_mearms_own_commands_are_not(monkeypatch) -> None:
    _main_at(monkeypatch, Path(video_encoder.__file__).parents[1] / "sort.py")
    assert video_encoder._script_hint(heard=False) == ""
