"""Anything the config validator accepts must not crash a command later (issue 12).

Every numeric field is set to each end of its range (the bound itself, or the nearest
float inside an open bound); each config that still validates runs through the commands.
A run may succeed, fail to converge (exit 1) or refuse the combination (exit 2, one line);
it may never end in an unexpected error, a traceback or a hang.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from badinput import run_in_process
from test_bad_input_config import FIELDS

from mearm.config import load_config
from mearm.exceptions import ConfigError


def _edges(kind: type, bounds: tuple) -> list[float]:
    lo, lo_open, hi, hi_open = bounds
    out: list[float] = []
    for value, is_open, direction in ((lo, lo_open, 1), (hi, hi_open, -1)):
        if value is None:
            continue
        if kind is int:
            out.append(value + direction if is_open else value)
        else:
            out.append(math.nextafter(float(value), direction * math.inf) if is_open else value)
    return out


def _accepted() -> list[str]:
    """``--set`` texts at the ends of each field's range that the validator accepts, one
    per config they make: an edge that is its field's default (``camera.seed=0``) makes
    the config another edge made, and the commands would run it again to the same end."""
    out, made = [], set()
    for path, kind, bounds in FIELDS:
        for value in _edges(kind, bounds):
            text = f"{path}={value!r}"
            try:
                config = load_config(None, [text])
            except ConfigError:
                continue  # refused by a rule across fields: not this test's business
            if (dump := config.model_dump_json()) not in made:
                made.add(dump)
                out.append(text)
    return out


ACCEPTED = _accepted()


def _no_crash(argv: list[str], within_s: float = 30.0) -> None:
    out = run_in_process(argv, within_s=within_s)
    lines = out.stderr.strip().splitlines()
    assert out.code in (0, 1, 2), f"{argv}: exit {out.code}: {out.stderr}"
    assert "unexpected error" not in out.stderr and "Traceback" not in out.stderr, out.stderr
    assert out.code != 2 or len(lines) == 1, f"{argv}: {lines}"  # 1: ik did not converge


def test_the_edges_are_many() -> None:
    assert len(ACCEPTED) > 100


@pytest.mark.parametrize("setting", ACCEPTED)
def test_kinematics_commands_survive_every_accepted_edge(setting: str, tmp_path: Path) -> None:
    """fk, ik and urdf at each end of each field's range."""
    _no_crash(["fk", "--set", setting, "--joints", "120,93,-132"])
    _no_crash(["ik", "--set", setting, "--target", "-10.99,49.70,12.76"])
    _no_crash(["urdf", "--set", setting, "--output", tmp_path / "arm.urdf"])


@pytest.mark.slow
@pytest.mark.parametrize("setting", ACCEPTED)
def test_vision_and_sort_survive_every_accepted_edge(setting: str) -> None:
    """detect (the simulated camera) and a short simulated sort at each edge: two objects,
    so a pick follows a place (a third object would only repeat the second's path)."""
    _no_crash(["detect", "--camera", "--json", "--set", setting])
    _no_crash(["sort", "--random", "2", "--quiet", "--set", setting], within_s=120)
