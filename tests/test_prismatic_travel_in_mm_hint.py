"""A rail's travel written in mm is said to be, as a link's length in mm is.

A prismatic joint's variable is its DH row's d, in cm (docs/your-arm.md): a lift of
4…16 cm written ``{min: 40, max: 160}`` is a 1.6 m rail, the same units mistake as a
link of 80 for 8 cm, and ``mearm fk``/``urdf`` answered for it without a word.
"""

from badinput import run_in_process

from mearm.config import load_config
from mearm.config.files import unit_warning
from mearm.data import CONFIGS_DIR

MM = "lengths are in cm; these look like mm (8 cm is 8.0, not 80)"
#: sim_5dof's wrist roll made a rail (its servo's 600…2400 µs allow −90…90 cm)
RAIL = ["arm.joints.wrist_roll.type=prismatic", "arm.joints.wrist_roll.home=10"]


def test_a_rail_whose_travel_looks_like_mm_is_named():
    config = load_config(
        CONFIGS_DIR / "sim_5dof.yaml", [*RAIL, "arm.joints.wrist_roll.limits={min: 0, max: 80}"]
    )
    assert unit_warning(config).endswith(f"arm.joints: wrist_roll.limits = [0, 80]: {MM}")


def test_a_rail_of_a_few_cm_and_a_revolute_joint_past_60_deg_say_nothing():
    config = load_config(
        CONFIGS_DIR / "sim_5dof.yaml", [*RAIL, "arm.joints.wrist_roll.limits={min: 0, max: 40}"]
    )
    assert unit_warning(config) is None
    assert unit_warning(load_config(CONFIGS_DIR / "sim_5dof.yaml")) is None  # (limits to 180°)


def test_fk_warns_of_the_rail_in_one_line():
    r = run_in_process(
        ["fk", "--config", "sim_5dof", *(a for s in RAIL for a in ("--set", s)),
         "--set", "arm.joints.wrist_roll.limits={min: 0, max: 80}",
         "--joints", "90,100,-110,-80,10"]
    )  # fmt: skip
    assert r.code == 0, r.stderr
    (line,) = r.stderr.splitlines()
    assert line.startswith("mearm fk: warning: ") and line.endswith(
        f"with --set: arm.joints: wrist_roll.limits = [0, 80]: {MM}"
    )
