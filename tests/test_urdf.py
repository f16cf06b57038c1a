import xml.etree.ElementTree as ET

import numpy as np
from conftest import ROOT, run_cli

from mearm.kinematics import ArmModel, dh_to_urdf

URDF = ROOT / "robot_description" / "mearm.urdf"


def test_committed_urdf_is_not_stale(lab_config, config):
    """robot_description/mearm.urdf equals what tools/dh_to_urdf.py writes now."""
    expected = dh_to_urdf(lab_config.robot)
    assert URDF.read_text() == expected, "regenerate: python tools/dh_to_urdf.py"
    assert dh_to_urdf(config.robot) == expected  # the sim rig is the same arm


def test_tool_writes_the_same_file(tmp_path):
    out = tmp_path / "sub" / "arm.urdf"
    r = run_cli("tools/dh_to_urdf.py", "--config", "configs/lab.yaml", "--output", str(out))
    assert r.returncode == 0, r.stderr
    assert out.read_text() == URDF.read_text()


def test_tool_bad_argument_exits_2(tmp_path):
    r = run_cli("tools/dh_to_urdf.py", "--config", str(tmp_path / "none.yaml"))
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "file not found" in r.stderr


def test_joints_limits_in_radians_and_ee_frame(config):
    root = ET.fromstring(dh_to_urdf(config.robot))
    joints = {j.get("name"): j for j in root.iter("joint")}
    assert [n for n, j in joints.items() if j.get("type") == "revolute"] == [
        "joint1",
        "joint2",
        "joint3",
        "joint4",
    ]
    lim = joints["joint2"].find("limit")
    np.testing.assert_allclose(
        [float(lim.get("lower")), float(lim.get("upper"))], np.radians([30, 135])
    )
    lim4 = joints["joint4"].find("limit")  # derived from the coupling
    np.testing.assert_allclose(
        [float(lim4.get("lower")), float(lim4.get("upper"))], np.radians([-115, 130])
    )
    assert joints["ee_fixed"].find("child").get("link") == "ee"
    # every moving link has something to draw
    for link in root.iter("link"):
        if link.get("name") != "ee":
            assert link.find("visual") is not None, link.get("name")


def test_model_loads_committed_file(config):
    model = ArmModel(config.robot, urdf_path=URDF)
    np.testing.assert_allclose(model.fk_cm(model.home_rad), [-20.16, 34.91, 19.95], atol=0.01)
