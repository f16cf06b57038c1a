import xml.etree.ElementTree as ET

import numpy as np
import pytest
from badinput import run_in_process
from conftest import ROOT, run_cli

from mearm.kinematics import ArmModel, generate_urdf

DESCRIPTIONS = ROOT / "robot_description"


def test_committed_urdfs_are_not_stale(reference_config):
    """robot_description/<arm>.urdf equals what the generator writes now, for every arm."""
    path = DESCRIPTIONS / f"{reference_config.arm.name}.urdf"
    assert path.read_text() == generate_urdf(reference_config.arm), (
        "regenerate: python tools/dh_to_urdf.py"
    )


def test_committed_urdfs_load_in_pinocchio(reference_config):
    model = ArmModel(
        reference_config.arm, urdf_path=DESCRIPTIONS / f"{reference_config.arm.name}.urdf"
    )
    generated = ArmModel(reference_config.arm)
    np.testing.assert_allclose(model.fk_cm(model.home), generated.fk_cm(generated.home), atol=1e-12)


@pytest.mark.heavy
def test_tool_writes_every_reference_arm(tmp_path):
    out = tmp_path / "sub" / "arm.urdf"
    r = run_cli("tools/dh_to_urdf.py", "--config", "configs/sim_5dof.yaml", "--output", str(out))
    assert r.returncode == 0, r.stderr
    assert out.read_text() == (DESCRIPTIONS / "desk_5dof.urdf").read_text()


def test_tool_set_changes_the_arm(tmp_path):
    """In this process (``mearm urdf``, the script's command)."""
    out = tmp_path / "arm.urdf"
    r = run_in_process(["urdf", "--set", "arm.joints.shoulder.dh.a_cm=25", "--output", out])
    assert r.code == 0, r.stderr
    assert '<origin xyz="0.25 0.0 0.0"' in out.read_text()


def test_a_changed_arm_does_not_replace_its_reference_arms_urdf(tmp_path, monkeypatch):
    """``mearm urdf --config my.yaml`` (``use: mearm_v1``, a limit changed) without --output.

    robot_description/mearm_v1.urdf is the reference arm's: refused, exit 2, one line, the
    file as it was. The unchanged arm (its own URDF again) and a name of its own are written.
    """
    from mearm.tools import dh_to_urdf

    folder = tmp_path / "robot_description"
    folder.mkdir()
    (folder / "mearm_v1.urdf").write_text("the reference\n")
    monkeypatch.setattr(dh_to_urdf, "output_folder", lambda: folder)
    changed = ["urdf", "--config", "sim_mearm_v1", "--set", "arm.joints.shoulder.limits.max=120"]
    r = run_in_process(changed)
    assert r.code == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "reference arm 'mearm_v1'" in r.stderr and "--output" in r.stderr
    assert (folder / "mearm_v1.urdf").read_text() == "the reference\n"
    r = run_in_process([*changed, "--set", "arm.name=my_v1"])
    assert r.code == 0, r.stderr
    assert '<robot name="my_v1"' in (folder / "my_v1.urdf").read_text()
    r = run_in_process(["urdf", "--config", "sim_mearm_v1"])
    assert r.code == 0, r.stderr
    assert (folder / "mearm_v1.urdf").read_text() == (DESCRIPTIONS / "mearm_v1.urdf").read_text()


@pytest.mark.heavy
def test_tool_bad_argument_exits_2(tmp_path):
    r = run_cli("tools/dh_to_urdf.py", "--config", str(tmp_path / "none.yaml"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "file not found" in r.stderr
    r = run_in_process(["urdf", "--set", "arm.joints.wrist.coupling.terms={x: 1}"])
    assert r.code == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "arm.joints.wrist.coupling.terms" in r.stderr
    assert "'x' is not an actuated joint" in r.stderr


def test_joints_limits_in_radians_tcp_and_coupling_recorded(config):
    root = ET.fromstring(generate_urdf(config.arm))
    joints = {j.get("name"): j for j in root.iter("joint")}
    assert [n for n, j in joints.items() if j.get("type") == "revolute"] == [
        "base",
        "shoulder",
        "elbow",
        "wrist",
    ]
    lim = joints["shoulder"].find("limit")
    np.testing.assert_allclose(
        [float(lim.get("lower")), float(lim.get("upper"))], np.radians([30, 135])
    )
    lim4 = joints["wrist"].find("limit")  # derived from the coupling
    np.testing.assert_allclose(
        [float(lim4.get("lower")), float(lim4.get("upper"))], np.radians([-115, 130])
    )
    assert joints["tcp_fixed"].find("child").get("link") == "tcp"
    assert "mearm:coupling wrist = -1.0*shoulder + -1.0*elbow + 0.0" in generate_urdf(config.arm)
    for link in root.iter("link"):
        if link.get("name") != "tcp":
            assert link.find("visual") is not None, link.get("name")
