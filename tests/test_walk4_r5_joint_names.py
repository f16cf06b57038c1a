"""A joint named like a frame of the arm's URDF is refused by name (docs/your-arm.md).

The URDF names its links ``base_link``, ``link_<joint>`` and ``tcp`` and its jaws
``<gripper>_jaw_left/right``; Pinocchio names frames after joints and links alike. A
maker's joint named ``tcp`` or ``base_link`` (a ROS habit) used to end ``mearm fk`` in an
unexpected error (exit 1, a traceback in the crash log), one named like a jaw in URDF's
C++ complaint: now exit 2 and one line naming the config field and the clash.
"""

import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.kinematics import generate_urdf
from mearm.kinematics.errors import ModelError


@pytest.mark.parametrize(
    ("name", "clash"),
    [
        ("tcp", "is both the joint 'tcp' and the TCP frame"),
        ("base_link", "is both the base link and the joint 'base_link'"),
        ("link_shoulder", "is both the link of the joint 'shoulder' and the joint 'link_shoulder'"),
        ("gripper_jaw_left", "is both the joint 'gripper_jaw_left' and the gripper's jaw joint"),
    ],
)
def test_a_joint_named_like_a_urdf_frame_is_refused(name, clash):
    r = run_in_process(["fk", "--set", f"arm.joints.wrist.name={name}", "--joints", "90,90,-90"])
    assert r.code == 2, (r.stdout, r.stderr)
    lines = r.stderr.splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith(f"mearm fk: error: arm.joints.{name}.name: {name!r} {clash}")
    assert lines[0].endswith("give it another name") and r.stdout == ""


def test_the_gripper_named_into_a_joint_is_named_too():
    config = load_config(
        overrides=["arm.tool.gripper.name=link", "arm.joints.wrist.name=link_jaw_left"]
    )
    with pytest.raises(ModelError, match=r"^arm\.joints\.link_jaw_left\.name: 'link_jaw_left'"):
        generate_urdf(config.arm)


def test_a_joint_prefixed_link_without_its_namesake_is_fine():
    """``link_hand`` clashes only beside a joint named ``hand``."""
    config = load_config(overrides=["arm.joints.wrist.name=link_hand"])
    assert '<joint name="link_hand" type="revolute">' in generate_urdf(config.arm)
