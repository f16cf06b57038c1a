"""``mearm sort`` refuses an output file that is one of its inputs or another output.

Found walking docs/sorting.md:
- ``--log run.jsonl --save-mjcf run.jsonl``: the log was opened, then the MJCF replaced
  the file; every record of the run went to a file no longer there, and an existing run
  log was replaced (exit 0).
- ``--scene s.yaml --save-mjcf s.yaml`` (or over the ``--config`` file): the run's own
  input was replaced by the MJCF.
Each is now bad input before any work: exit 2, one line naming both flags, every file as
it was.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.badinput import run_in_process

SCENE = "- {color: red, x: -10.99, y: 49.70}\n"


def _refused(argv: list[object], *flags: str) -> str:
    out = run_in_process(["sort", "--quiet", *argv], within_s=10)
    assert out.code == 2, out.stdout + out.stderr
    lines = out.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    for flag in flags:
        assert flag in lines[0], lines[0]
    assert "sorted" not in out.stdout
    return lines[0]


@pytest.mark.parametrize("existing", [False, True], ids=["new", "existing log"])
def test_save_mjcf_over_the_run_log_is_refused(tmp_path: Path, existing: bool) -> None:
    log = tmp_path / "run.jsonl"
    old = None
    if existing:
        made = run_in_process(["sort", "--quiet", "--random", "1", "--log", log], within_s=30)
        assert made.code == 0, made.stderr
        old = log.read_bytes()
    _refused(["--log", log, "--save-mjcf", log], "--save-mjcf", "--log")
    assert (log.read_bytes() if log.exists() else None) == old
    assert not (tmp_path / "run.jsonl.bak").exists()


def test_save_mjcf_over_the_scene_is_refused(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text(SCENE)
    link = tmp_path / "link.yaml"
    link.symlink_to(scene)
    for out in (scene, link):  # by any name
        _refused(["--scene", scene, "--save-mjcf", out], "--save-mjcf", "--scene")
        assert scene.read_text() == SCENE
        assert sorted(p.name for p in tmp_path.iterdir()) == ["link.yaml", "scene.yaml"]


def test_save_mjcf_over_the_config_is_refused(tmp_path: Path) -> None:
    config = tmp_path / "rig.yaml"
    config.write_text("extends: sim.yaml\n")
    _refused(["--config", config, "--save-mjcf", config], "--save-mjcf", "--config")
    assert config.read_text() == "extends: sim.yaml\n"
    assert [p.name for p in tmp_path.iterdir()] == ["rig.yaml"]
