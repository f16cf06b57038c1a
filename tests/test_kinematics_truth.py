"""fk and ik tell the truth: what the servos can be sent to, negative link lengths,
limit messages that show why, an approach the arm cannot choose, plain numbers only.

Walk 4's findings (helpers/w2.md items 1, 5 and 6).
"""

import json

import numpy as np
import pytest
import yaml
from badinput import Outcome, run_in_process
from conftest import ROOT, planar_yaw_arm_data

from mearm.config import config_from_dict, load_config
from mearm.hardware.mapping import ServoMap
from mearm.ik import PdPij
from mearm.kinematics import ArmModel, closed_form_for
from mearm.task.plan import Planner

V1 = "sim_mearm_v1"
PAPER = ROOT / "configs" / "arms" / "mearm_paper.yaml"
#: MeArm v1 targets in its box whose only pose puts shoulder + elbow past the elbow
#: servo's ±75° (its 544..2400 µs): sum 100° (~2709 µs) and -110° (~113 µs).
PAST_SERVO = ["0,0.2685,19.5068", "0,11.5814,0.7186"]


def mearm(*args: str) -> Outcome:
    """``mearm ARGS`` in this process, from the checkout."""
    return run_in_process(list(args), within_s=30)


def one_line(r: Outcome) -> str:
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    return lines[0]


# ----------------------------------------------------------------- item 1: servo range


@pytest.mark.parametrize("solver", ["pdpij", "analytic", "mink"])
@pytest.mark.parametrize("target", PAST_SERVO)
def test_ik_does_not_call_a_pose_its_servo_cannot_take_converged(solver, target):
    r = mearm("ik", "--config", V1, f"--target={target}", "--solver", solver)
    assert r.code == 1, r.stdout + r.stderr
    assert "to a pose its servos cannot be sent to" in r.stdout
    failure = next(line for line in r.stdout.splitlines() if line.startswith("failure"))
    assert failure.startswith("failure (limit): the solution cannot be sent: elbow's servo")
    assert "(shoulder + elbow)" in failure and "µs pulse on channel 2" in failure
    assert "outside its [544, 2400] µs" in failure
    r = mearm("ik", "--config", V1, f"--target={target}", "--solver", solver, "--json")
    out = json.loads(r.stdout)
    assert r.code == 1 and out["failure_kind"] == "limit"
    assert "elbow's servo (shoulder + elbow)" in out["failure"]


def test_ik_within_the_servo_range_still_exits_0():
    r = mearm("ik", "--config", V1, "--target=0,14.8,13.5", "--json")
    assert r.code == 0, r.stdout + r.stderr
    assert json.loads(r.stdout)["failure"] is None


def test_fk_refuses_joints_its_servo_cannot_be_sent_to():
    r = mearm("fk", "--config", V1, "--joints", "90,150,-20")
    assert r.code == 2 and r.stdout == ""
    line = one_line(r)
    assert "elbow's servo (shoulder + elbow) = 130 deg needs a 3080.5 µs pulse" in line
    assert "outside its [544, 2400] µs" in line and "[-75, 75] deg" in line
    assert mearm("fk", "--config", V1, "--joints", "90,60,-130").code == 0  # sum -70: fine


def test_ik_refuses_a_start_its_servo_cannot_be_at():
    r = mearm("ik", "--config", V1, "--target=0,14.8,13.5", "--start", "90,150,-20")
    assert r.code == 2
    assert "elbow's servo (shoulder + elbow) = 130 deg" in one_line(r)


def test_the_planner_and_the_commands_share_one_servo_check():
    """The sort planner refuses exactly the poses the servo map calls out of range."""
    config = load_config(ROOT / "configs" / f"{V1}.yaml")
    model = ArmModel(config.arm)
    chain = model.chain
    planner = Planner(config, model)
    servos = ServoMap.from_arm(config.arm)
    rng = np.random.default_rng(0)
    outside = 0
    for _ in range(300):
        q_a = rng.uniform(chain.actuated_lower, chain.actuated_upper)
        found = servos.outside_pulse_range(q_a / chain.scale[chain.actuated_index])
        outside += found is not None
        assert planner.pose_allowed(chain.full(q_a)) == (found is None)
    assert 30 < outside < 270  # both kinds were seen


# ----------------------------------------------------------------- item 5: negative lengths


def in_box(box, p) -> bool:
    ranges = (box.x_cm, box.y_cm, box.z_cm)
    return all(r.contains(float(v)) for r, v in zip(ranges, p, strict=True))


def negative_arm(tmp_path, old: str, new: str):
    path = tmp_path / "neg.yaml"
    text = PAPER.read_text(encoding="utf-8")
    assert old in text
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


@pytest.mark.parametrize(
    "old,new",
    [("a_cm: 22.3", "a_cm: -22.3"), ("a_cm: 31.5", "a_cm: -31.5")],
    ids=["shoulder", "elbow"],
)
def test_closed_form_round_trips_a_negative_link_length(tmp_path, old, new):
    """fk → closed form gives the pose back; PD-PIJ (without the closed form) agrees."""
    config = load_config(negative_arm(tmp_path, old, new))
    model = ArmModel(config.arm)
    chain, box = model.chain, config.arm.target_box
    closed_form = closed_form_for(config.arm)
    plain = config.model_copy(update={"arm": config.arm.model_copy(update={"closed_form": None})})
    pdpij = PdPij(ArmModel(plain.arm), plain.controller)
    rng = np.random.default_rng(1)
    checked = 0
    while checked < 40:
        q = chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper))
        p = model.fk_cm(q)
        if not in_box(box, p):
            continue
        checked += 1
        np.testing.assert_allclose(closed_form.solve(p), q, atol=1e-7)
        result = pdpij.solve(p, model.home)
        assert result.converged, (np.degrees(q), result.failure)


def test_negative_shoulder_length_mearm_v1_round_trips():
    """A negative length on the MeArm v1 puts the shoulder's solution a turn off: taken
    within its limits."""
    data = yaml.safe_load((ROOT / "configs/arms/mearm_v1.yaml").read_text(encoding="utf-8"))
    for joint in data["arm"]["joints"][1:3]:
        joint["dh"]["a_cm"] = -joint["dh"]["a_cm"]
    arm = config_from_dict(data).arm
    model, closed_form = ArmModel(arm), closed_form_for(arm)
    chain, box = model.chain, arm.target_box
    rng = np.random.default_rng(2)
    checked = 0
    while checked < 200:
        q = chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper))
        p = model.fk_cm(q)
        if in_box(box, p):
            checked += 1
            np.testing.assert_allclose(closed_form.solve(p), q, atol=1e-7)


def test_ik_on_a_negative_length_reaches_what_fk_gives(tmp_path):
    path = str(negative_arm(tmp_path, "a_cm: 22.3", "a_cm: -22.3"))
    r = mearm("fk", "--config", path, "--joints", "90,120,-40", "--json")
    x, y, z = json.loads(r.stdout)["ee_cm"]
    r = mearm("ik", "--config", path, f"--target={x},{y},{z}")  # PD-PIJ
    assert r.code == 0, r.stderr
    r = mearm("ik", "--config", path, f"--target={x},{y},{z}", "--solver", "analytic")
    assert r.code == 0, r.stderr
    assert "shoulder 120.000 deg, elbow -40.000 deg" in r.stdout
    # out of reach in its box: the interval reads low to high
    r = mearm("ik", "--config", path, "--target=0,60,60")
    assert r.code == 2
    assert "the arm reaches [9.200, 53.800] cm" in one_line(r)


# ----------------------------------------------------------------- item 6: messages, input


def test_a_limit_refusal_shows_the_digits_that_matter():
    r = mearm("fk", "--joints", "160.0000001,135,-20")
    assert r.code == 2
    assert one_line(r).endswith(
        "base = 160 deg is outside its limits [20, 160] deg (160.0000001 > 160)"
    )
    r = mearm("fk", "--joints", "19.99,135,-20")  # 4 digits already tell: nothing added
    assert one_line(r).endswith("base = 19.99 deg is outside its limits [20, 160] deg")


@pytest.mark.parametrize(
    "argv",
    [
        ["fk", "--joints", "1_20,93,-132"],
        ["fk", "--joints", "\u0661\u0662\u0660,93,-132"],  # Arabic-Indic 120
        ["ik", "--target=-10.99,49.70,1_2.76"],
        ["ik", "--target=-10.99,49.70,12.76", "--start", "\uff11\uff12\uff10,93,-132"],
        ["ik", "--config", "sim_5dof", "--target=0,25,15", "--approach", "0,0,-\u0661"],
    ],
)
def test_only_plain_decimal_numbers_are_read(argv):
    r = mearm(*argv)
    assert r.code == 2
    assert "must be plain decimal numbers" in one_line(r)


@pytest.mark.parametrize("approach", ["0,0,-1", "1,0,0"])
def test_approach_refused_up_front_for_an_arm_that_cannot_orient_it(approach):
    r = mearm("ik", "--target=0,40,20", "--approach", approach)
    assert r.code == 2 and r.stdout == ""
    line = one_line(r)
    assert "has 3 actuated joints (base, shoulder, elbow), all needed to place the TCP" in line


def test_an_approach_the_arm_cannot_take_is_not_blamed_on_reach():
    """The 5-DOF arm can orient its approach, but not along x at this target."""
    r = mearm("ik", "--config", "sim_5dof", "--target=0,25,15", "--approach", "1,0,0")
    assert r.code == 1
    assert "or the approach one the arm cannot take there" in r.stdout
    # the TCP on the target, the approach upside down: said so, not "out of reach?"
    r = mearm("ik", "--config", "sim_5dof", "--target=7,29.05,10.95", "--approach",
              "0.0015,-0.138,0.99")  # fmt: skip
    assert r.code == 1
    assert "the TCP is at the target, but no joint motion turns the approach" in r.stdout


def test_fk_json_gives_each_joints_unit(tmp_path):
    # in this process, from the checkout (tests/test_fk_cli.py runs ``python -m mearm.fk``)
    r = run_in_process(["fk", "--joints", "120,93,-132", "--json"], within_s=30, cwd=ROOT)
    out = json.loads(r.stdout)
    assert r.code == 0 and out["joints"]["base"] == 120  # the old key unchanged
    assert out["joint_units"] == dict.fromkeys(["base", "shoulder", "elbow", "wrist"], "deg")
    rail = tmp_path / "rail.yaml"
    rail.write_text(yaml.safe_dump({"arm": planar_yaw_arm_data(rail=True)}), encoding="utf-8")
    r = mearm("fk", "--config", str(rail), "--joints", "2,90,80,-100", "--json")
    assert r.code == 0, r.stderr
    assert json.loads(r.stdout)["joint_units"]["rail"] == "cm"


@pytest.mark.parametrize("value", [".inf", "1.0e+300", "1500.0"])
def test_no_mm_hint_for_a_length_mm_cannot_explain(tmp_path, value):
    """inf or 1e300 cm is no length in mm either: the bound's error alone, no unit hint."""
    path = negative_arm(tmp_path, "a_cm: 22.3", f"a_cm: {value}")
    r = mearm("fk", "--config", str(path), "--joints", "120,93,-132")
    assert r.code == 2 and "look like mm" not in one_line(r), one_line(r)
