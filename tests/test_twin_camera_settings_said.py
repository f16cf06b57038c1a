"""The kinematic renderer's camera settings on the twin are said to do nothing.

From a newcomer's walk: ``mearm sort --config sim_mujoco --set camera.brightness=0.05
--set camera.noise_std=80 --set camera.table=grey`` sorted 12 of 12, exit 0, with no word,
and ``mearm detect --config sim_mujoco --camera`` gave byte-identical frames with any
``camera.brightness``, ``noise_std``, ``gradient``, ``seed`` or ``table``: the twin renders
its own scene (its light or ``twin.lamp``, from ``twin.camera``, no sensor noise). On
``--config sim`` brightness 0.05 gives a black frame. The opposite case (``twin.*`` on the
kinematic rig) was already said.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.task.check import twin_only_warning

CONFIGS = sorted((Path(__file__).resolve().parents[1] / "configs").glob("*.yaml"))
SAID = (
    "the kinematic renderer's (simulator: kinematic); this config's simulator is mujoco, "
    "whose camera renders the twin's scene under its own light (twin.lamp) from "
    "twin.camera, with no sensor noise: "
)


def test_a_twin_sort_with_kinematic_image_settings_says_they_do_nothing() -> None:
    argv = ["sort", "--config", "sim_mujoco", "--quiet",
            "--set", "task.scene=[{color: red, x: -5, y: 45}]",
            "--set", "camera.brightness=0.05", "--set", "camera.noise_std=80",
            "--set", "camera.table=grey"]  # fmt: skip
    done = run_in_process(argv, within_s=120)
    assert done.code == 0, done.stderr
    said = [ln for ln in done.stderr.splitlines() if "kinematic renderer" in ln]
    assert said == [
        "mearm sort: warning: camera.noise_std, camera.brightness, camera.table: "
        + SAID
        + "they do nothing here"
    ], done.stderr


def test_detect_on_the_twin_camera_says_it_once() -> None:
    argv = ["detect", "--config", "sim_mujoco", "--camera", "--set", "camera.gradient=1"]
    done = run_in_process(argv, within_s=60)
    assert done.code == 0, done.stderr
    assert done.stderr.splitlines() == [
        "mearm detect: warning: camera.gradient: " + SAID + "it does nothing here"
    ], done.stderr
    assert done.stdout.startswith("camera: 12 object(s)")


@pytest.mark.parametrize(
    "overrides",
    [
        # what the twin's camera does use, or a setting at its default
        [
            "camera.width_px=320",
            "camera.height_px=240",
            "calibration.image_size_px=[320, 240]",
            "camera.latency_s=0.05",
        ],
        ["camera.brightness=1.0", "camera.table=wood", "camera.seed=0"],
    ],
)
def test_what_the_twin_uses_or_a_default_is_not_said(overrides: list[str]) -> None:
    assert twin_only_warning(load_config("sim_mujoco", overrides)) is None


def test_the_kinematic_rig_uses_them_and_says_nothing() -> None:
    config = load_config("sim", ["camera.brightness=0.05", "camera.table=grey"])
    assert twin_only_warning(config) is None


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_no_shipped_config_is_warned(path: Path) -> None:
    assert twin_only_warning(load_config(path)) is None


def test_learn_colours_on_the_twin_camera_says_it(tmp_path: Path) -> None:
    argv = ["learn-colours", "--camera", "--config", "sim_mujoco", "--set", "camera.seed=5",
            "--sample", "red=315,81", "--out", tmp_path / "taught.yaml"]  # fmt: skip
    done = run_in_process(argv, within_s=60)
    assert done.code == 0, done.stderr
    assert done.stderr.splitlines() == [
        "mearm learn-colours: warning: camera.seed: " + SAID + "it does nothing here"
    ]
