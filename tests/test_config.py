from pathlib import Path

import pytest
from conftest import ROOT, run_cli

from mearm.config import Config, config_from_dict, load_config
from mearm.exceptions import ConfigError


def test_sim_yaml_is_the_embedded_default():
    """configs/sim.yaml writes out exactly the built-in defaults."""
    assert load_config(ROOT / "configs" / "sim.yaml") == Config()


def test_lab_yaml_is_the_real_rig():
    lab = load_config(ROOT / "configs" / "lab.yaml")
    assert lab.camera.kind == "device" and lab.camera.device_index == 0
    assert lab.servo.backend == "serial" and lab.servo.port == "/dev/ttyACM0"
    assert lab.robot == Config().robot


def test_table4_reading_of_spec_section3():
    lim = Config().robot.joint_limits_deg
    assert (lim.joint1.min, lim.joint1.max) == (20, 160)
    assert (lim.joint2.min, lim.joint2.max) == (30, 135)
    assert (lim.joint3.min, lim.joint3.max) == (-160, -20)
    j4 = lim.as_list()[3]
    assert (j4.min, j4.max) == (-115, 130)


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


def test_min_above_max_limit(tmp_path):
    text = "robot:\n  joint_limits_deg:\n    joint2: {min: 30, max: -80}\n"
    with pytest.raises(ConfigError) as exc:
        load_config(_write(tmp_path, text))
    msg = str(exc.value)
    assert "robot.joint_limits_deg.joint2" in msg and "min (30) must be below max (-80)" in msg


def test_home_outside_limits(tmp_path):
    text = "robot:\n  joint_limits_deg:\n    joint3: {min: -80, max: -20}\n"
    with pytest.raises(ConfigError, match=r"joint3 = -132 is outside its limits \[-80, -20\]"):
        load_config(_write(tmp_path, text))


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="nope.yaml: file not found"):
        load_config(tmp_path / "nope.yaml")


def test_malformed_yaml_gives_line(tmp_path):
    with pytest.raises(
        ConfigError, match=r"malformed YAML at line \d+, column \d+: expected ',' or ']'"
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


def test_empty_file_is_the_default(tmp_path):
    assert load_config(_write(tmp_path, "")) == Config()


def test_cli_bad_config_exits_2_with_one_line(tmp_path):
    bad = _write(tmp_path, "controller:\n  kpp: 0.1\n")
    r = run_cli("-m", "mearm.fk", "--config", str(bad), "--joints", "120,93,-132")
    assert r.returncode == 2
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "controller.kpp: unknown key" in lines[0]
    assert "Traceback" not in r.stderr
