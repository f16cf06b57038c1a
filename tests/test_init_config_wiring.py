"""init-config: the wiring it prints, the maker path's order, and twins of a maker's config."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

from mearm.config import load_config
from mearm.errors import MearmError
from mearm.maker import init_config
from mearm.maker.wiring import UNO_PINS, wiring_rows, wiring_table, wiring_text

ROOT = Path(__file__).resolve().parent.parent
SKETCH = ROOT / "tools" / "arduino" / "mearm_servo" / "mearm_servo.ino"
#: Each reference arm's simulated config and its board.
ARMS = {
    "mearm_v1": ("sim_mearm_v1", "uno"),
    "paper": ("sim", "uno"),
    "desk_5dof": ("sim_5dof", "ssc32"),
}


def test_uno_pins_are_the_firmwares() -> None:
    """UNO_PINS is the sketch's SERVO_PIN_<i> defaults, channel by channel."""
    text = SKETCH.read_text()
    pins = dict(re.findall(r"#define SERVO_PIN_(\d) (\d+)", text))
    assert [f"D{pins[str(i)]}" for i in range(len(pins))] == list(UNO_PINS)
    assert f"#define SERVO_COUNT {len(UNO_PINS)}" in text


@pytest.mark.parametrize("arm", list(ARMS))
def test_wiring_rows_are_the_arm_files_channels(arm: str) -> None:
    """One row per servo, with the channel its ``channel:`` line gives, in channel order."""
    config, board = ARMS[arm]
    description = load_config(config).arm
    arm_file = (ROOT / "configs" / "arms" / f"{description.name}.yaml").read_text()
    channels = sorted(int(c) for c in re.findall(r"channel: (\d+)", arm_file))
    rows = wiring_rows(description, board)
    assert [r.channel for r in rows] == channels
    for row in rows:
        assert row.pin == (UNO_PINS[row.channel] if board == "uno" else f"ch {row.channel}")


def test_the_mearm_v1_rows_say_what_each_servo_turns_and_its_home_pulse() -> None:
    """The elbow servo turns shoulder + elbow; home pulses are the calibration's."""
    rows = {r.actuator: r for r in wiring_rows(load_config("sim_mearm_v1").arm)}
    assert rows["elbow"].turns == "shoulder + elbow" and rows["elbow"].home == "0 deg"
    assert rows["base"].pin == "D3" and rows["gripper"].pin == "D9"
    # base: zero 2534 µs, direction -1, 11 µs/deg, home 90 deg
    assert rows["base"].home_us == pytest.approx(2534.0 - 11.0 * 90.0)


@pytest.mark.parametrize("arm", list(ARMS))
def test_the_maker_path_shows_each_arms_wiring_as_generated(arm: str) -> None:
    """docs/maker-path.md carries each reference arm's table as the code makes it today."""
    config, board = ARMS[arm]
    doc = (ROOT / "docs" / "maker-path.md").read_text()
    block = re.search(rf"<!-- wiring: {config} {board} -->\n(.*?)<!-- /wiring -->", doc, re.S)
    assert block is not None, f"no wiring block for {config}"
    assert wiring_table(load_config(config).arm, board) in block.group(1)


def test_uno_starter_prints_the_wiring_and_the_steps_in_the_maker_paths_order(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Find the port, then flash, then calibrate; the wiring follows, also in the header."""
    out = tmp_path / "my_arm.yaml"
    assert init_config.main(["--arm", "mearm_v1", "--rig", "uno", str(out)]) == 0
    printed = capsys.readouterr().out
    steps = [m.group(1) for m in re.finditer(r"^  \d\. (.*)$", printed, re.M)]
    firsts = [s.split(" (")[0] for s in steps]
    order = ["find-port", "flash", "calibrate-servos", "find-camera", "calibrate-camera", "sort"]
    at = [next(i for i, s in enumerate(firsts) if f" {name}" in s) for name in order]
    assert at == sorted(at), steps
    assert "channel 2  D6    elbow" in printed and "turns shoulder + elbow" in printed
    header = out.read_text()
    assert "# Wiring" in header and "#   channel 0  D3" in header
    assert wiring_text(load_config(out).arm) in printed


def test_twin_of_a_makers_config_simulates_the_arm_they_measured(tmp_path: Path) -> None:
    """--of: the twin extends the maker's file, so a length measured into it is simulated."""
    mine = tmp_path / "my_arm.yaml"
    init_config.main(["--arm", "mearm_v1", "--rig", "uno", str(mine)])
    mine.write_text(
        mine.read_text().replace(
            "  use: mearm_v1\n", "  use: mearm_v1\n  joints: {shoulder: {dh: {a_cm: 8.3}}}\n"
        )
    )
    twin = tmp_path / "twin" / "my_twin.yaml"
    twin.parent.mkdir()
    assert init_config.main(["--of", str(mine), "--rig", "sim_mujoco", str(twin)]) == 0
    data = yaml.safe_load(twin.read_text())
    assert data["extends"] == "../my_arm.yaml"
    config = load_config(twin)
    assert config.arm.joints[1].dh.a_cm == 8.3
    assert config.simulator == "mujoco" and config.servo.backend == "sim"
    assert config.camera.kind == "sim" and len(config.task.scene) == 6
    assert config.twin.joint_servo == "SG90"
    kinematic = tmp_path / "my_sim.yaml"
    assert init_config.main(["--of", str(mine), "--rig", "sim", str(kinematic)]) == 0
    assert load_config(kinematic).simulator == "kinematic"


def test_twin_of_refuses_a_real_rig_and_an_arm_it_cannot_place(tmp_path: Path) -> None:
    """--of with --rig uno, or over the file itself, or an arm that is no reference: refused."""
    mine = tmp_path / "my_arm.yaml"
    init_config.main(["--arm", "paper", "--rig", "sim", str(mine)])
    with pytest.raises(MearmError, match="give --rig sim or sim_mujoco"):
        init_config.main(["--of", str(mine), "--rig", "uno", str(tmp_path / "t.yaml")])
    with pytest.raises(MearmError, match="not over it"):
        init_config.main(["--of", str(mine), "--rig", "sim", "--force", str(mine)])
    renamed = tmp_path / "renamed.yaml"
    renamed.write_text("extends: my_arm.yaml\narm: {name: my_own_arm}\n")
    with pytest.raises(MearmError, match="is not a reference arm: give --arm"):
        init_config.main(["--of", str(renamed), "--rig", "sim", str(tmp_path / "t.yaml")])
    assert (
        init_config.main(
            ["--of", str(renamed), "--arm", "paper", "--rig", "sim", str(tmp_path / "t.yaml")]
        )
        == 0
    )
