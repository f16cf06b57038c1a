"""A maker's walk through the config's errors: each line says where and what to look at.

The walk found: a whole-config check's line did not name the config file (a bad key's
did); ``--config Sim`` or ``--config my_arm`` (with ``my_arm.yaml`` here) had no "did you
mean"; ``mearm urdf`` wrote an arm in mm without the hint a sort gives; ``mearm preview
--screenshot`` in a missing folder named an internal parameter (such a folder is now made;
one under a file is refused); a DH row with a flipped sign was refused as ~900
characters of unreachable bins pointing nowhere near the DH rows.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import check_bad_input

from mearm.config import load_config
from mearm.config.files import config_source, resolve_config_path
from mearm.errors import ConfigError
from mearm.task.check import check_consistency
from mearm.tools import dh_to_urdf

#: A bin 80 cm to the side: in no arm's target box.
FAR_BIN = "task.classes.red.bin_cm=[-80, 16, 6]"
#: The MeArm v1's links written in mm.
MM_ARM = (
    "extends: sim_mearm_v1\narm:\n  name: my_mm\n  joints:\n"
    "    shoulder: {dh: {a_cm: 80}}\n    elbow: {dh: {a_cm: 80}}\n"
)
#: The desk arm with its base's alpha sign flipped: every bin is then out of its way.
FLIPPED_ALPHA = "extends: sim_5dof\narm:\n  joints:\n    base_yaw: {dh: {alpha_deg: -90.0}}\n"


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def test_a_whole_config_checks_line_names_the_file(tmp_path):
    path = _write(tmp_path, "far.yaml", "extends: sim\n")
    with pytest.raises(ConfigError) as caught:
        check_consistency(load_config(path, [FAR_BIN]))
    assert caught.value.path == f"{path} with overrides"  # a command's: "with --set"
    assert str(caught.value).startswith(f"{path} with overrides: task.classes.red.bin_cm: [-80")
    with pytest.raises(ConfigError) as caught:
        check_consistency(load_config(None, [FAR_BIN]))
    assert caught.value.path == "overrides"


@pytest.mark.bad_input
def test_the_sorts_line_names_the_file_as_a_bad_keys_does(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _write(
        tmp_path, "far.yaml", "extends: sim\ntask:\n  classes:\n    red: {bin_cm: [-80, 16, 6]}\n"
    )
    out = check_bad_input(["sort", "--config", "far.yaml"], within_s=10.0)
    assert out.line.startswith("mearm sort: error: far.yaml: task.classes.red.bin_cm: "), out.line


def test_a_loaded_config_knows_its_file_and_a_built_one_none(tmp_path):
    path = _write(tmp_path, "mine.yaml", "extends: sim\n")
    assert config_source(load_config(path)) == str(path)
    assert config_source(load_config()) is None


@pytest.mark.parametrize(("name", "meant"), [("Sim", "'sim'"), ("SIM_MUJOCO", "'sim_mujoco'")])
def test_a_shipped_name_in_other_case_gets_a_did_you_mean(name, meant, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ConfigError) as caught:
        resolve_config_path(name)
    assert f"(did you mean {meant}?)" in str(caught.value)


@pytest.mark.parametrize("name", ["my_arm", "my_arn", "my_arm.yml"])
def test_a_bare_name_of_a_file_here_gets_a_did_you_mean(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path, "my_arm.yaml", "extends: sim\n")
    with pytest.raises(ConfigError) as caught:
        resolve_config_path(name)
    assert "(did you mean 'my_arm.yaml'?)" in str(caught.value)


def test_urdf_of_an_arm_in_mm_warns_as_the_sort_does_and_writes(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path, "mm.yaml", MM_ARM)
    out = tmp_path / "mm.urdf"
    assert dh_to_urdf.main(["--config", "mm.yaml", "--output", str(out)]) == 0
    assert out.is_file()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].endswith(
        "warning: mm.yaml: arm.joints: shoulder.dh.a_cm = 80, elbow.dh.a_cm = 80: lengths "
        "are in cm; these look like mm (8 cm is 8.0, not 80); the URDF is written with the "
        "arm as given"
    ), err


def test_urdf_of_an_arm_in_cm_says_nothing(tmp_path, capsys):
    out = tmp_path / "v1.urdf"
    assert dh_to_urdf.main(["--config", "sim_mearm_v1", "--output", str(out)]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.bad_input
def test_preview_names_screenshot_for_a_path_under_a_file(tmp_path):
    """A missing folder is made (tests/test_view_sizes.py); one that is a file is refused,
    named as the flag, not as the view's parameter."""
    (tmp_path / "no").write_text("a file")
    shot = tmp_path / "no" / "such" / "r.png"
    out = check_bad_input(["preview", "--screenshot", shot])
    assert out.line == (
        f"mearm preview: error: --screenshot {shot}: cannot write: {tmp_path / 'no'} is a "
        "file, not a folder"
    )
    assert "out_png" not in out.line


@pytest.mark.bad_input
def test_a_flipped_dh_sign_points_at_the_dh_rows_in_one_short_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _write(tmp_path, "flip.yaml", FLIPPED_ALPHA)
    out = check_bad_input(["sort", "--config", "flip.yaml"], within_s=10.0)
    line = out.line
    assert len(line) <= 1000 and "…" not in line, line  # whole: not cut to fit
    assert line.startswith(
        "mearm sort: error: flip.yaml: 2 problems: task.classes.{red,green,blue}.bin_cm: "
        "3 bins inside arm.target_box cannot be reached from home within the joint limits: "
        "the arm's description is the likely cause; check the signs of its DH rows"
    ), line
    assert "mearm preview --sweep" in line
