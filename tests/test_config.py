from pathlib import Path

import pytest
from badinput import run_in_process
from conftest import ROOT

from mearm.config import Config, config_from_dict, load_config
from mearm.exceptions import ConfigError


def test_sim_yaml_is_the_embedded_default():
    """configs/sim.yaml writes out exactly the built-in defaults."""
    assert load_config(ROOT / "configs" / "sim.yaml") == Config()


def test_lab_yaml_is_the_real_rig():
    lab = load_config(ROOT / "configs" / "lab.yaml")
    assert lab.camera.kind == "device" and lab.camera.device_index == 0
    assert lab.servo.backend == "serial" and lab.servo.port == "/dev/ttyACM0"
    assert lab.arm == Config().arm


def test_table4_reading_of_the_paper():
    lim = Config().arm.joint_limits()
    assert (lim["base"].min, lim["base"].max) == (20, 160)
    assert (lim["shoulder"].min, lim["shoulder"].max) == (30, 135)
    assert (lim["elbow"].min, lim["elbow"].max) == (-160, -20)
    assert (lim["wrist"].min, lim["wrist"].max) == (-115, 130)  # from the coupling


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "c.yaml"
    p.write_text(text)
    return p


def test_unknown_key_names_its_path(tmp_path):
    with pytest.raises(ConfigError) as exc:
        load_config(_write(tmp_path, "controller:\n  kpp: 0.1\n"))
    assert "controller.kpp: unknown key" in str(exc.value)
    assert exc.value.path.endswith("c.yaml")


def test_wrong_type_names_value_and_path(tmp_path):
    with pytest.raises(ConfigError) as exc:
        load_config(_write(tmp_path, "controller:\n  max_iterations: many\n"))
    msg = str(exc.value)
    assert "controller.max_iterations" in msg and "'many'" in msg and "integer" in msg


def test_min_above_max_limit():
    with pytest.raises(ConfigError) as exc:
        load_config(None, ["arm.joints.shoulder.limits={min: 30, max: -80}"])
    msg = str(exc.value)
    assert "arm.joints.shoulder.limits" in msg and "min (30) must be below max (-80)" in msg


def test_home_outside_limits():
    with pytest.raises(
        ConfigError, match=r"arm.joints.elbow.home: -132 is outside the limits \[-80, -20\]"
    ):
        load_config(None, ["arm.joints.elbow.limits={min: -80, max: -20}"])


BAD_ARMS = [
    # (override, what the one line must say)
    (
        ["arm.joints.wrist.coupling.terms={shoulder: -1, knee: -1}"],
        "arm.joints.wrist.coupling.terms: 'knee' is not an actuated joint of this arm "
        "(actuated: base, shoulder, elbow)",
    ),
    (["arm.joints=[]"], "arm.joints: List should have at least 1 item"),
    (
        [f"arm.joints.{i}.dh={{a_cm: 0, d_cm: 0}}" for i in range(4)],
        "arm.joints: singular chain",
    ),
    (
        ["arm.joints.base.limits.max=200"],
        "arm.joints.base.limits.max: 200 needs a 2600 µs pulse, outside the servo's "
        "[600, 2400] µs, which allows [0, 180]",
    ),
    (
        ["task.classes.green.bin_cm=[-20, 35, 20]"],
        "task.classes: 'green' and 'red' share the bin at [-20.0, 35.0, 20.0] cm",
    ),
    (["task.scene.0.color=pink"], "task.scene.0.color: 'pink' is not a class"),
    (["arm.joints.elbow.servo=null"], "arm.joints.elbow: joint 'elbow' needs exactly one of"),
    (["arm.joints.base.servo.channel=4"], "arm.joints: gripper and base share servo channel 4"),
    (["arm.closed_form=nonsense"], None),  # the name is valid data; the model refuses it
]


@pytest.mark.parametrize(("overrides", "message"), BAD_ARMS)
def test_bad_arm_descriptions_refused_at_load(overrides, message):
    """Each bad description is refused when the config loads, naming the field."""
    if message is None:
        from mearm.exceptions import ModelError
        from mearm.kinematics import closed_form_for

        with pytest.raises(ModelError, match="unknown closed form 'nonsense'"):
            closed_form_for(load_config(None, overrides).arm)
        return
    with pytest.raises(ConfigError) as exc:
        load_config(None, overrides)
    assert message in str(exc.value)


@pytest.mark.heavy
def test_bad_arm_description_cli_exits_2_one_line(tmp_path):
    """A bad arm file: exit 2, one line naming the field, no traceback."""
    bad = _write(
        tmp_path,
        "arm:\n  name: x\n  joints:\n    - {name: a, coupling: {terms: {b: 1}}}\n"
        "  tool: {gripper: {servo: {channel: 4}, open_cm: 4, closed_cm: 1}}\n",
    )
    # in this process (the script's exit 2 in a real process: tests/test_urdf.py)
    r = run_in_process(["urdf", "--config", bad, "--output", tmp_path / "o"])
    assert r.code == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "arm.joints" in lines[0] and "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()


def test_set_overrides_before_validation():
    """--set reaches list items by name or index and parses the value as YAML."""
    c = load_config(
        ROOT / "configs" / "sim.yaml",
        ["arm.joints.shoulder.dh.a_cm=25", "task.classes.1.bin_cm=[-20, 46, 20]"],
    )
    assert c.arm.joints[1].dh.a_cm == 25
    assert c.task.classes[1].bin_cm == (-20, 46, 20)
    c = load_config(ROOT / "configs" / "sim_4colours.yaml", ["arm.joints.base.home=100"])
    assert c.arm.home()["base"] == 100  # the arm comes from the defaults, then changes


@pytest.mark.parametrize(
    ("override", "message"),
    [
        ("nokey", "expected dotted.key=value"),
        (
            "arm.joints.knee.home=1",
            "arm.joints.knee: no item named 'knee' (choices: base, shoulder, elbow, wrist)",
        ),
        ("arm.joints.9.home=1", "arm.joints.9: no such item (0…3)"),
        ("controller.kp=[1", "controller.kp: value '[1' is not valid YAML"),
        ("controller.kp.x=1", "controller.kp: is a value, not a section"),
        ("controller.kpp=1", "controller.kpp: unknown key"),
    ],
)
def test_bad_set_is_one_line(override, message):
    with pytest.raises(ConfigError) as exc:
        load_config(None, [override])
    assert message in str(exc.value)
    assert len(str(exc.value).splitlines()) == 1


def test_a_key_set_in_a_null_section_makes_the_section():
    """``--set twin.lamp.kind=spot`` on a config whose ``twin.lamp`` is null (no lamp)
    said "twin.lamp: is a value, not a section"; a null section is made as a missing one
    is, the rest of it the model's defaults."""
    c = load_config(ROOT / "configs" / "sim.yaml", ["twin.lamp.kind=spot"])
    assert c.twin.lamp is not None and c.twin.lamp.kind == "spot"


_ONE_CUBE_CLASS = """\
extends: sim
task:
  classes:
    - {name: cubes, shape: cube, draw_rgb: [200, 30, 35], bin_cm: [-20, 35, 20]}
  scene: []
"""


def test_set_in_a_new_item_borrows_nothing_from_the_builtin_item_at_its_index(tmp_path):
    """``--set task.classes.cubes.hue_bands_deg.0.lo_deg=50`` on a file whose one class
    has no bands was accepted with hi_deg 15, the built-in red's (the class at index 0):
    items pair with the built-in ones by name, and a new item borrows nothing."""
    path = tmp_path / "shp.yaml"
    path.write_text(_ONE_CUBE_CLASS)
    with pytest.raises(ConfigError) as exc:
        load_config(path, ["task.classes.cubes.hue_bands_deg.0.lo_deg=50"])
    assert "task.classes.cubes.hue_bands_deg.0.hi_deg: required but missing" in str(exc.value)
    assert len(str(exc.value).splitlines()) == 1
    both = [
        "task.classes.cubes.hue_bands_deg.0.lo_deg=50",
        "task.classes.0.hue_bands_deg.0.hi_deg=70",
    ]
    band = load_config(path, both).task.classes[0].hue_bands_deg[0]
    assert (band.lo_deg, band.hi_deg) == (50, 70)
    red = "    - {name: red, draw_rgb: [200, 30, 35], bin_cm: [-20, 45, 20]}\n"
    path.write_text(_ONE_CUBE_CLASS.replace("  scene:", red + "  scene:"))
    band = load_config(path, ["task.classes.red.hue_bands_deg.0.lo_deg=340"]).task.classes[1]
    assert (band.hue_bands_deg[0].lo_deg, band.hue_bands_deg[0].hi_deg) == (340, 15)  # red's


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="nope.yaml: config file not found"):
        load_config(tmp_path / "nope.yaml")


def test_malformed_yaml_gives_line(tmp_path):
    with pytest.raises(
        ConfigError,
        match=r"malformed YAML at line \d+, column \d+: (did not find )?expected ',' or ']'",
    ):
        load_config(_write(tmp_path, "controller:\n  kp: [0.1\n"))


def test_every_bad_field_reported_once_each(tmp_path):
    text = "controller:\n  kp: -1\n  kd: -0.5\n  bogus: 1\n"
    with pytest.raises(ConfigError) as exc:
        load_config(_write(tmp_path, text))
    problems = exc.value.problems
    assert len(problems) == 3
    assert any(p.startswith("controller.kp:") and "greater than 0" in p for p in problems)
    assert any(
        p.startswith("controller.kd:") and "greater than or equal to 0" in p for p in problems
    )


def test_top_level_must_be_mapping():
    with pytest.raises(ConfigError, match="top level must be a mapping, got list"):
        config_from_dict([1, 2])


def test_nan_rejected():
    with pytest.raises(ConfigError, match="controller.kp"):
        config_from_dict({"controller": {"kp": float("nan")}})


def test_empty_file_is_refused(tmp_path):
    """An empty file is a mistake, not the simulated rig; ``{}`` asks for the defaults."""
    for text in ("", "# only a comment\n", "---\n"):
        with pytest.raises(ConfigError, match="empty config: the file holds no YAML document"):
            load_config(_write(tmp_path, text))
    assert load_config(_write(tmp_path, "{}\n")) == Config()


@pytest.mark.heavy
def test_cli_bad_config_exits_2_with_one_line(tmp_path):
    bad = _write(tmp_path, "controller:\n  kpp: 0.1\n")
    r = run_in_process(["fk", "--config", bad, "--joints", "120,93,-132"])  # fk: test_fk_cli
    assert r.code == 2
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "controller.kpp: unknown key" in lines[0]
    assert "Traceback" not in r.stderr


@pytest.mark.bad_input
@pytest.mark.parametrize(
    "port", ["spy:///dev/ttyACM0?file=/tmp/victim", "hwgrep://.*", "alt:///dev/ttyS0?class=X"]
)
def test_a_serial_port_outside_the_allow_list_is_refused_at_load(tmp_path, port):
    """Refused when the config loads (exit 2, one line), before any port is opened."""
    from badinput import check_bad_input

    victim = tmp_path / "victim"
    victim.write_text("kept")
    out = check_bad_input(
        ["sort", "--set", "servo.backend=serial", "--set", f"servo.port={port}"],
        keep=[victim],
    )
    assert "servo.port" in out.line and "socket://" in out.line


def test_a_bad_set_value_on_a_good_file_is_blamed_on_the_set(tmp_path: Path) -> None:
    """``load_config("sim", ["servo.rate_hz=-1"])``: the line starts ``overrides:`` (the
    command's ``--set:``), not the shipped file's path (which the user never wrote); a bad
    file is still named as the file."""
    with pytest.raises(ConfigError) as exc:
        load_config("sim", ["servo.rate_hz=-1"])
    assert str(exc.value).startswith("overrides: servo.rate_hz: "), str(exc.value)
    bad = tmp_path / "bad.yaml"
    bad.write_text("servo: {rate_hz: -2}\n")
    with pytest.raises(ConfigError) as exc:
        load_config(bad, ["servo.port=/dev/ttyACM1"])
    assert str(exc.value).startswith(f"{bad}: servo.rate_hz: "), str(exc.value)
