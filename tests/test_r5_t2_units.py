"""An arm written in mm or radians is said to be (docs/your-arm.md, docs/troubleshooting.md).

Such an arm is valid data: ``mearm fk``, ``mearm ik`` and a sort's config check take it,
and used to say nothing, so a maker found out from a sort that missed its bins. Each now
says one warning line naming the config; a rule with no false alarm on anything shipped.
"""

import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.config.files import unit_warning
from mearm.config.loader import radian_hint
from mearm.data import ARMS_DIR, CONFIGS_DIR
from mearm.errors import ConfigError
from mearm.task.check import check_consistency

RADIANS = "angles are in degrees; these look like radians (90° is 90.0, not 1.5708)"
MM = "lengths are in cm; these look like mm (8 cm is 8.0, not 80)"


@pytest.mark.parametrize(
    "path",
    sorted(CONFIGS_DIR.glob("*.yaml")) + sorted(ARMS_DIR.glob("*.yaml")),
    ids=lambda p: p.name,
)
def test_no_unit_warning_on_any_shipped_config_or_reference_arm(path):
    assert unit_warning(load_config(path)) is None


def _arm(alpha=90.0, theta=0.0, limits=(-150.0, -20.0)):
    low, high = limits
    return {
        "arm": {
            "joints": [
                {"name": "base", "dh": {"alpha_deg": alpha, "theta_deg": theta}},
                {"name": "elbow", "limits": {"min": low, "max": high}},
                {"name": "wrist", "coupling": {"terms": {"elbow": -1.0}}, "limits": None},
            ]
        }
    }


@pytest.mark.parametrize(
    ("data", "said"),
    [
        (_arm(alpha=1.5708), "base.dh.alpha_deg = 1.5708"),
        (_arm(alpha=-1.57), "base.dh.alpha_deg = -1.57"),
        (_arm(alpha=3.1416), "base.dh.alpha_deg = 3.1416"),
        (_arm(theta=6.2832), "base.dh.theta_deg = 6.2832"),
        (_arm(limits=(-2.6, -0.17)), "elbow.limits = [-2.6, -0.17]"),
        (_arm(alpha=90.0), None),
        (_arm(alpha=1.0), None),  # no right angle in radians
        (_arm(limits=(-10.0, 3.0)), None),  # a range past a turn's worth of radians
    ],
)
def test_radian_hint(data, said):
    hint = radian_hint(data)
    assert hint == (None if said is None else f"arm.joints: {said}: {RADIANS}")


def test_fk_warns_of_an_arm_in_mm_and_still_answers():
    r = run_in_process(
        ["fk", "--config", "sim_mearm_v1", "--set", "arm.joints.shoulder.dh.a_cm=80",
         "--set", "arm.joints.elbow.dh.a_cm=80", "--joints", "90,90,-90"]
    )  # fmt: skip
    assert r.code == 0, r.stderr
    (line,) = r.stderr.splitlines()
    assert line.startswith("mearm fk: warning: ") and line.endswith(
        f"sim_mearm_v1.yaml with --set: arm.joints: shoulder.dh.a_cm = 80, elbow.dh.a_cm = 80: {MM}"
    )
    assert "ee = " in r.stdout


def test_ik_names_the_config_and_the_radians_of_the_closed_form_it_breaks():
    """Bad input is one line: the closed form's refusal, led by the hint, naming the config."""
    r = run_in_process(
        ["ik", "--config", "sim_mearm_v1", "--set", "arm.joints.base.dh.alpha_deg=1.5708",
         "--target", "0,15,5"]
    )  # fmt: skip
    assert (r.code, r.stdout) == (2, ""), r.stderr
    (line,) = r.stderr.splitlines()
    assert line.startswith("mearm ik: error: /")
    assert line.endswith(
        f"sim_mearm_v1.yaml with --set: 2 problems: arm.joints: base.dh.alpha_deg = 1.5708: "
        f"{RADIANS}; arm.closed_form: 'planar_wrist' needs alpha = (90, 0, 0, 0) deg; this "
        "arm has another structure (set closed_form to null)"
    )


def test_ik_warns_of_radians_as_it_answers():
    r = run_in_process(
        ["ik", "--config", "sim_5dof", "--set", "arm.joints.wrist_roll.dh.theta_deg=3.1416",
         "--target", "0,20,5"]
    )  # fmt: skip
    assert r.code == 0, r.stderr
    (line,) = r.stderr.splitlines()
    assert line.startswith("mearm ik: warning: /") and line.endswith(
        f"sim_5dof.yaml with --set: arm.joints: wrist_roll.dh.theta_deg = 3.1416: {RADIANS}"
    )
    assert "converged" in r.stdout


def test_fk_and_ik_say_bad_input_in_one_line_even_for_an_arm_in_mm():
    """A link of 1000 cm (mm?) and a target out of its reach: the error alone (exit 2)."""
    r = run_in_process(
        ["ik", "--set", "arm.joints.base.dh.a_cm=1000", "--target", "-10.99,49.70,12.76"]
    )
    assert r.code == 2 and len(r.stderr.splitlines()) == 1 and "out of reach" in r.stderr
    r = run_in_process(["fk", "--set", "arm.joints.base.dh.a_cm=1000", "--joints", "0,93,-132"])
    assert r.code == 2 and len(r.stderr.splitlines()) == 1 and "base" in r.stderr


def test_sort_names_the_config_of_a_closed_form_its_arm_cannot_use():
    r = run_in_process(
        ["sort", "--config", "sim_mearm_v1", "--set", "arm.joints.base.dh.alpha_deg=1.5708",
         "--quiet"]
    )  # fmt: skip
    assert r.code == 2 and r.stdout == ""
    (line,) = r.stderr.splitlines()
    assert line.startswith("mearm sort: error: /")
    assert (
        f"sim_mearm_v1.yaml with --set: 2 problems: arm.joints: base.dh.alpha_deg = 1.5708: "
        f"{RADIANS}; arm.closed_form: 'planar_wrist' needs alpha" in line
    )


def test_the_config_check_gives_the_warning_of_an_arm_that_passes_it():
    """The sort's config check passes (the roll's 3° turns the jaws only) and warns."""
    config = load_config("sim_5dof", ["arm.joints.wrist_roll.dh.theta_deg=3.1416"])
    found = check_consistency(config)
    assert found.warnings == [unit_warning(config)]
    assert found.warnings[0].endswith(
        f"sim_5dof.yaml with overrides: arm.joints: wrist_roll.dh.theta_deg = 3.1416: {RADIANS}"
    )
    assert check_consistency(load_config("sim_5dof")).warnings == []


def test_the_config_check_leads_its_problems_with_the_hint():
    config = load_config(
        "sim_mearm_v1", ["arm.joints.shoulder.dh.a_cm=80", "arm.joints.elbow.dh.a_cm=80"]
    )
    with pytest.raises(ConfigError) as exc:
        check_consistency(config)
    assert exc.value.problems[0] == (f"arm.joints: shoulder.dh.a_cm = 80, elbow.dh.a_cm = 80: {MM}")


def test_ik_solver_analytic_speaks_of_its_options():
    r = run_in_process(
        ["ik", "--config", "sim_5dof", "--solver", "analytic", "--target", "0,20,10"]
    )
    assert (r.code, r.stdout) == (2, "")
    assert r.stderr.splitlines() == [
        "mearm ik: error: --solver analytic: arm 'desk_5dof' has no closed form "
        "(arm.closed_form is null); choose --solver pdpij or --solver mink"
    ]


@pytest.mark.parametrize(("typed", "shown"), [("yes", "'yes'"), ("On", "'On'"), ("false", "false")])
def test_set_a_boolean_for_a_number_shows_what_was_typed(typed, shown):
    r = run_in_process(
        ["fk", "--config", "sim", "--set", f"controller.kp={typed}", "--joints", "90,90,-90"]
    )
    assert r.code == 2
    assert r.stderr.splitlines() == [
        f"mearm fk: error: --set: controller.kp: expected a number, got {shown}"
    ]


def test_set_a_boolean_by_index_shows_what_was_typed():
    with pytest.raises(ConfigError) as exc:
        load_config("sim", ["arm.joints.1.dh.a_cm=no"])
    assert exc.value.problems == ["arm.joints.shoulder.dh.a_cm: expected a number, got 'no'"]


def _radian_arm_file(tmp_path):  # noqa: ANN001, ANN202
    import yaml  # noqa: PLC0415

    arm = load_config("sim").arm.model_dump(mode="json")
    arm["joints"][0]["dh"]["alpha_deg"] = 1.5708
    arm["closed_form"] = None  # (the paper arm's formula needs its right angle)
    path = tmp_path / "rad.yaml"
    path.write_text(yaml.safe_dump({"arm": arm}))
    return path


def test_urdf_of_an_arm_in_radians_warns_as_fk_does(tmp_path):
    """``mearm urdf`` said only ``wrote rad.urdf``: the URDF of a chain folded the wrong
    way, in silence, where ``mearm fk`` of the same config warns."""
    config = _radian_arm_file(tmp_path)
    out = run_in_process(["urdf", "--config", str(config), "--output", str(tmp_path / "r.urdf")])
    assert out.code == 0 and (tmp_path / "r.urdf").is_file()
    [line] = out.stderr.strip().splitlines()
    assert "warning:" in line and "base.dh.alpha_deg = 1.5708" in line and RADIANS in line
    assert line.endswith("the URDF is written with the arm as given")


def test_preview_of_an_arm_in_radians_warns_as_fk_does(tmp_path):
    config = _radian_arm_file(tmp_path)
    shot = tmp_path / "shot.png"
    out = run_in_process(["preview", "--config", str(config), "--screenshot", str(shot)])
    warned = [ln for ln in out.stderr.splitlines() if "warning:" in ln]
    assert len(warned) == 1 and RADIANS in warned[0], out.stderr
