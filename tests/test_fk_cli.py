import contextlib
import json

import pytest
from badinput import Outcome, run_in_process
from conftest import ROOT, run_cli


def fk_here(*args: str) -> Outcome:
    """``mearm fk ARGS`` in this process, from the checkout (test_home_json runs the
    command as a process: its exit status and output as a shell sees them)."""
    with contextlib.chdir(ROOT):
        return run_in_process(["fk", *args], within_s=10)


def test_home_json():
    """python -m mearm.fk --joints 120,93,-132 gives paper §2's check value."""
    r = run_cli(
        "-m", "mearm.fk", "--config", "configs/lab.yaml", "--joints", "120,93,-132", "--json"
    )
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["joints"] == {"base": 120, "shoulder": 93, "elbow": -132, "wrist": 39}
    for got, want in zip(out["ee_cm"], [-20.16, 34.91, 19.95], strict=True):
        assert abs(got - want) < 0.01


def test_home_text_default_config():
    r = fk_here("--joints", "120,93,-132")
    assert r.code == 0
    assert "ee = (-20.16, 34.91, 19.95) cm" in r.stdout
    assert "base 120.00 deg, shoulder 93.00 deg, elbow -132.00 deg, wrist 39.00 deg" in r.stdout


@pytest.mark.heavy
def test_any_arm_from_its_config():
    """The 5-DOF desk arm: five actuated joints by name, the approach axis printed."""
    r = fk_here("--config", "configs/sim_5dof.yaml", "--joints", "90,100,-110,-80,0", "--json")
    assert r.code == 0, r.stderr
    out = json.loads(r.stdout)
    assert list(out["joints"]) == ["base_yaw", "shoulder", "elbow", "wrist_pitch", "wrist_roll"]
    for got, want in zip(out["approach"], [0, 0, -1], strict=True):
        assert abs(got - want) < 1e-9
    r = fk_here("--config", "configs/sim_5dof.yaml", "--joints", "90,100,-110")
    assert r.code == 2
    assert "--joints needs 5 numbers, the actuated joints (base_yaw, shoulder" in r.stderr


@pytest.mark.heavy
def test_bad_joints_exit_2_one_line():
    for joints, needle in [
        ("120,93", "--joints needs 3 numbers"),
        ("a,b,c", "comma-separated numbers"),
        ("120,93,nan", "finite"),
        ("10,93,-132", "base = 10 deg is outside its limits [20, 160] deg"),
    ]:
        r = fk_here("--joints", joints)
        assert r.code == 2, joints
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0], r.stderr
