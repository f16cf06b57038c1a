"""camera-accuracy: --help says what its two bounds do; its --json says the figures are simulated.

Found walking docs/calibration.md: the page names the bounds (0.05 cm mean, 0.10 cm
largest) the command exits 1 on, but ``--help`` listed ``--max-mean-cm`` and
``--max-error-cm`` with no word on either; and the ``--json`` file held the twin's
figures with nothing saying they were simulated (the printed table says so).
"""

from __future__ import annotations

import json

import pytest
from badinput import run_in_process
from test_tool_outputs import camera_accuracy_once


def test_help_names_the_bounds_and_their_defaults() -> None:
    done = run_in_process(["camera-accuracy", "--help"])
    assert done.code == 0
    text = " ".join(done.stdout.split())
    assert "MAX_MEAN_CM exit 1 when a height's mean error is above this [cm] (0.05)" in text
    assert "MAX_ERROR_CM exit 1 when any object's error is above this [cm] (0.10)" in text


def test_the_json_figures_are_labelled_simulated(tmp_path_factory: pytest.TempPathFactory) -> None:
    """The --json of camera-accuracy at its quickest (one height, one scene, 3 objects),
    run once for the tests that read it."""
    done = camera_accuracy_once(tmp_path_factory)
    assert done.code == 0, done.stdout + done.stderr
    record = json.loads((done.folder / "ca.json").read_text())
    assert record["simulated"] is True and record["rows"][0]["height_cm"] == 1.0


@pytest.mark.slow
def test_without_a_config_it_measures_the_twin_and_names_its_backups(tmp_path) -> None:
    """Without --config it refused every run ("simulator is 'kinematic'"), though its help
    named a default; a rerun into --work kept the old calibrations as .bak unnamed."""
    argv = ["camera-accuracy", "--heights", "1", "--scenes", "1", "--objects", "1"]
    work = tmp_path / "work"
    first = run_in_process([*argv, "--work", str(work)], within_s=60)
    assert first.code == 0, first.stderr
    assert "s; simulated: the twin's rendered camera)" in first.stdout
    again = run_in_process([*argv, "--work", str(work)], within_s=60)
    assert again.code == 0, again.stderr
    for name in ("intrinsics.yaml", "pose.yaml"):
        assert f"wrote {work / name}.bak (the old {work / name})" in again.stdout
        assert (work / f"{name}.bak").is_file()


def test_a_height_given_twice_is_refused() -> None:
    done = run_in_process(["camera-accuracy", "--heights", "1,2.5,1"])
    assert done.code == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "--heights names a height twice" in done.stderr
