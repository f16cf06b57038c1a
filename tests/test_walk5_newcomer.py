"""What a newcomer's walk through the docs tripped on (2026-12-05), each a clear line now."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import mearm_here, one_stderr_line, record_by_hand

POINTS = ["--point", "10,10:-10,30", "--point", "600,10:10,30", "--point", "600,400:10,55"]
POINTS += ["--point", "10,400:-10,55"]


def test_calibrate_camera_on_a_shipped_config_name_says_to_write_ones_own(tmp_path: Path) -> None:
    """Every other command reads a shipped config by its name; calibrate-camera writes its
    fit into --config, so it needs the user's own file, and says so (not only "not found")."""
    done = mearm_here("calibrate-camera", "--config", "sim_mearm_v1", *POINTS, cwd=tmp_path)
    line = one_stderr_line(done, 2)
    assert "config file not found here" in line and "mearm init-config" in line, line
    assert list(tmp_path.iterdir()) == []
    other = mearm_here("calibrate-camera", "--config", "mine.yaml", *POINTS, cwd=tmp_path)
    assert one_stderr_line(other, 2).endswith("mine.yaml: config file not found")


def test_markers_without_positions_say_the_corners_count_with_their_side(tmp_path: Path) -> None:
    png = tmp_path / "frame.png"
    png.write_bytes(b"")  # refused on the arguments, before the image is read
    done = mearm_here("calibrate-camera", "--config", "lab.yaml", "--image", png, cwd=tmp_path)
    line = one_stderr_line(done, 2)
    assert "(4 or more; with --marker-side-cm each marker's corners count too)" in line, line


def test_aruco_sheet_ids_name_the_dictionarys_range(tmp_path: Path) -> None:
    done = mearm_here("aruco-sheet", "--output", tmp_path / "s.png", "--ids", "0,x", cwd=tmp_path)
    line = one_stderr_line(done, 2)
    assert "0 … 49 in the default DICT_4X4_50" in line, line
    assert not (tmp_path / "s.png").exists()


def test_a_checkouts_config_path_from_another_folder_names_the_shipped_config(
    tmp_path: Path,
) -> None:
    """The docs write ``--config configs/sim_shapes_mujoco.yaml``, a path in the checkout;
    run from another folder it is not there, and the line names the shipped config."""
    done = mearm_here("sort", "--config", "configs/sim_shapes_mujoco.yaml", cwd=tmp_path)
    line = one_stderr_line(done, 2)
    assert line.endswith(
        f"configs/sim_shapes_mujoco.yaml: config file not found from {tmp_path}; the config "
        "of that name that mearm ships is --config sim_shapes_mujoco (in Python, "
        "load_config('sim_shapes_mujoco'))"
    ), line
    unknown = mearm_here("sort", "--config", "configs/nosuch.yaml", cwd=tmp_path)
    assert one_stderr_line(unknown, 2).endswith("configs/nosuch.yaml: config file not found")
    long = f"configs/{'x' * 300}.yaml"  # no file can have the name: bad input, not a crash
    assert one_stderr_line(mearm_here("sort", "--config", long, cwd=tmp_path), 2).endswith(
        f"{long}: config file not found"
    )


def test_init_config_takes_the_paper_arm_by_its_file_name_too(tmp_path: Path) -> None:
    """The README and ``arm: {use: …}`` call it ``mearm_paper``; ``--arm`` said ``paper``."""
    texts = []
    for k, arm in enumerate(("paper", "mearm_paper")):
        here = tmp_path / str(k)
        here.mkdir()
        done = mearm_here("init-config", "--arm", arm, "--rig", "sim", "my.yaml", cwd=here)
        assert done.returncode == 0, done.stderr
        texts.append((here / "my.yaml").read_text())
    assert texts[0] == texts[1]


#: Five --point pairs a homography fits within the 0.5 cm rms the command allows.
POINTS5 = [
    f"--point={uv}:{xy}"
    for uv, xy in [("100,100", "-10,50"), ("540,100", "10,50"), ("540,380", "10,30")]
    + [("100,380", "-10,30"), ("320,240", "0,40")]
]


def test_calibrate_camera_output_in_another_folder_keeps_the_configs_paths(
    tmp_path: Path,
) -> None:
    """``extends: base/b.yaml`` copied as it was into ``--output out/cfg.yaml`` named
    out/base/b.yaml, and the config written (exit 0) did not load."""
    (tmp_path / "base").mkdir()
    (tmp_path / "base/b.yaml").write_text("extends: sim\n")
    (tmp_path / "rel.yaml").write_text("extends: base/b.yaml\n")
    (tmp_path / "made").mkdir()
    for out, extends in [
        ("made/cfg.yaml", "../base/b.yaml"),  # a folder that is there: relative to it
        ("new/cfg.yaml", str((tmp_path / "base/b.yaml").resolve())),  # made on writing
        ("cfg.yaml", "base/b.yaml"),  # beside it: as it was
    ]:
        done = mearm_here(
            "calibrate-camera", "--config", "rel.yaml", *POINTS5, "--output", out, cwd=tmp_path
        )
        assert done.returncode == 0, done.stderr
        assert (tmp_path / out).read_text().startswith(f"extends: {extends}\n")
        fk = mearm_here("fk", "--config", out, "--joints", "90,90,-90", cwd=tmp_path)
        assert fk.returncode == 0, fk.stderr


def test_a_servo_file_named_beside_the_config_follows_it(tmp_path: Path) -> None:
    from ruamel.yaml import YAML

    from mearm.tools.calibrate_camera import _moved

    (tmp_path / "kb.servos.yaml").write_text("")
    data = YAML().load("extends: sim\nservo:\n  calibration_file: kb.servos.yaml\n")
    _moved(data, tmp_path / "rel.yaml", tmp_path / "sub" / "cfg.yaml")
    assert data["extends"] == "sim"  # a shipped config's name: no file beside it
    assert data["servo"]["calibration_file"] == str((tmp_path / "kb.servos.yaml").resolve())
    (tmp_path / "sub").mkdir()
    data = YAML().load("servo:\n  calibration_file: kb.servos.yaml\n")
    _moved(data, tmp_path / "rel.yaml", tmp_path / "sub" / "cfg.yaml")
    assert data["servo"]["calibration_file"] == "../kb.servos.yaml"


def test_a_twin_of_an_arm_the_sort_would_refuse_says_why_before_next(tmp_path: Path) -> None:
    """``arm: {use: mearm_v1}`` alone keeps the built-in table, the paper arm's bins, out
    of the kit's reach: the twin is written, and the warning says why the sort would
    refuse it, where the next step once said only ``mearm sort``."""
    (tmp_path / "mine.yaml").write_text("arm:\n  use: mearm_v1\n")
    done = mearm_here(
        "init-config", "--of", "mine.yaml", "--rig", "sim_mujoco", "twin.yaml", cwd=tmp_path
    )
    assert done.returncode == 0 and (tmp_path / "twin.yaml").is_file(), done.stderr
    (warning,) = done.stderr.splitlines()
    assert warning.startswith("mearm init-config: warning: mearm sort would refuse it as it is:")
    assert "task.classes.red.bin_cm: [-20, 35, 20] cannot be reached" in warning
    assert "  1. change what the warning names, in mine.yaml or twin.yaml" in done.stdout
    fine = tmp_path / "kit.yaml"
    fine.write_text("extends: sim_mearm_v1\narm:\n  use: mearm_v1\n")
    ok = mearm_here(
        "init-config", "--of", "kit.yaml", "--rig", "sim", "kit_twin.yaml", cwd=tmp_path
    )
    assert ok.returncode == 0 and ok.stderr == "", ok.stderr
    assert "  1. mearm sort --config kit_twin.yaml" in ok.stdout


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["calibrate-intrinsics", "--images", "boards", "--out", "boards/intrinsics.png"], "--out"),
        (
            ["calibrate-servos", "--simulate", "--config", "sim_mujoco_kits", "--output", "kb.png"],
            "--output",
        ),
        (
            ["check-camera", "--config", "sim_mujoco_perspective", "--refine", "pose.jpg"],
            "--refine",
        ),
    ],
    ids=["intrinsics", "servos", "refine"],
)
def test_a_yaml_output_named_as_a_picture_is_refused(
    tmp_path: Path, argv: list[str], flag: str
) -> None:
    """calibrate-intrinsics wrote its YAML as boards/intrinsics.png, exit 0, and the next
    run over that folder stopped on it as "not an image"."""
    (tmp_path / "boards").mkdir()
    view = tmp_path / "boards" / "view1.png"  # a folder of views, as the docs make one
    cv2.imwrite(str(view), np.full((48, 64, 3), 200, np.uint8))
    line = one_stderr_line(mearm_here(*argv, cwd=tmp_path), 2)
    assert f"{flag} " in line and "names a picture" in line and "ending .yaml" in line, line
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["boards", "view1.png"]


def test_a_contact_sheet_named_other_than_png_is_refused(tmp_path: Path) -> None:
    root = record_by_hand(tmp_path / "ds", episodes=1, frames=20)
    line = one_stderr_line(mearm_here("dataset", "show", root, "--sheet", "s.jpg", cwd=tmp_path), 2)
    assert line.endswith("--sheet s.jpg: the contact sheet is a PNG: give a name ending .png")
    assert not (tmp_path / "s.jpg").exists()


def test_a_policy_module_beside_the_user_says_how_it_imports(tmp_path: Path) -> None:
    (tmp_path / "pol_here.py").write_text("def act(obs):\n    return None\n")
    done = mearm_here(
        "eval-policy", "--env", "mearm/PickPlace-v0", "--policy", "pol_here:act",
        "--episodes", "1", "--out", "e.json", cwd=tmp_path,
    )  # fmt: skip
    line = one_stderr_line(done, 2)
    assert "module pol_here does not import" in line and "PYTHONPATH=." in line, line


def test_a_file_that_is_no_baseline_says_why_in_whole_words(tmp_path: Path) -> None:
    pytest.importorskip("torch")
    fake = tmp_path / "fake.pt"
    fake.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    done = mearm_here(
        "eval-policy", "--env", "mearm/PickPlace-v0", "--policy", "fake.pt",
        "--episodes", "1", "--out", "e.json", cwd=tmp_path,
    )  # fmt: skip
    line = one_stderr_line(done, 2)
    assert "not a baseline saved by mearm.learn" in line, line
    reason = line.rsplit("(", 1)[1]
    assert reason.endswith(")") and (len(reason) < 120 or reason.endswith(" …)")), line
