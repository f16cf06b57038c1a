"""``init-config --of MINE --rig sim_mujoco``: the twin reference's joint limits land on
the maker's own joints, whatever they are named.

The twin references set each joint's servo acceleration limit by the reference's joint
names (``base``, ``shoulder``, ``elbow``). Copied as written, a maker's arm with joints of
other names did not load ("arm.joints.base: no item named 'base'", exit 2, with every
``--arm``), and a joint the reference lacks (a wrist servo) ran with no limit: the limit
that keeps a held object in the claw (configs/sim_mearm_v1_mujoco.yaml).
"""

from __future__ import annotations

from pathlib import Path

import yaml

from mearm.config import load_config
from mearm.maker import init_config


def _renamed(mine: Path) -> None:
    """The MeArm v1's starter config with its joints renamed and a wrist servo added."""
    assert init_config.main(["--arm", "mearm_v1", "--rig", "sim", str(mine)]) == 0
    arm = load_config(mine).arm.model_dump(mode="json", exclude_none=True)
    names = {"base": "waist", "shoulder": "upper", "elbow": "fore"}
    text = yaml.safe_dump(arm)
    for old, new in names.items():  # couplings name the joints too
        text = text.replace(f"name: {old}\n", f"name: {new}\n").replace(f"{old}:", f"{new}:")
    arm = yaml.safe_load(text)
    wrist = next(j for j in arm["joints"] if j["name"] == "wrist")
    wrist.pop("coupling", None)
    wrist.update(servo={**arm["joints"][0]["servo"], "channel": 5}, home=90.0,
                 limits={"min": 30.0, "max": 150.0})  # fmt: skip
    arm.update(name="my_arm", closed_form=None)  # the MeArm's formula keeps the wrist coupled
    data = yaml.safe_load(mine.read_text(encoding="utf-8"))
    mine.write_text(yaml.safe_dump({**data, "arm": arm}), encoding="utf-8")


def test_a_twin_of_an_arm_with_its_own_joint_names_loads_with_the_limit_on_each(tmp_path, capsys):
    mine, twin = tmp_path / "my_arm.yaml", tmp_path / "my_twin.yaml"
    _renamed(mine)
    argv = ["--of", str(mine), "--arm", "mearm_v1", "--rig", "sim_mujoco", str(twin)]
    assert init_config.main(argv) == 0, capsys.readouterr()
    config = load_config(twin)
    actuated = [j for j in config.arm.joints if j.actuated]
    assert [j.name for j in actuated] == ["waist", "upper", "fore", "wrist"]
    # the reference's own value (2000 deg/s² on the kit's SG90s), on every servo
    reference = load_config("sim_mearm_v1_mujoco").arm.joints[0].servo
    assert reference is not None and reference.max_accel_deg_s2 == 2000
    for joint in actuated:
        assert joint.servo is not None and joint.servo.max_accel_deg_s2 == 2000, joint.name


def test_a_twin_of_a_reference_arm_keeps_the_references_limits(tmp_path):
    """The reference arm itself: the same limits as the twin reference config writes."""
    mine, twin = tmp_path / "my_arm.yaml", tmp_path / "my_twin.yaml"
    assert init_config.main(["--arm", "paper", "--rig", "sim", str(mine)]) == 0
    assert init_config.main(["--of", str(mine), "--rig", "sim_mujoco", str(twin)]) == 0
    made, reference = load_config(twin).arm.joints, load_config("sim_mujoco").arm.joints
    assert [(j.name, j.servo.max_accel_deg_s2 if j.servo else None) for j in made] == [
        (j.name, j.servo.max_accel_deg_s2 if j.servo else None) for j in reference
    ]
