"""Configs and commands shared by the hardware tests (the paper arm, default config)."""

from __future__ import annotations

from typing import Any

import serial

from mearm.config import Config, config_from_dict
from mearm.hardware import ArmCommand


def command(
    base: float, shoulder: float, elbow: float, gripper_arm: float = 60.0, closed: bool = False
) -> ArmCommand:
    """A command to the paper arm (the default config's arm) by its joint names."""
    return ArmCommand(
        {"base": base, "shoulder": shoulder, "elbow": elbow}, {"gripper_arm": gripper_arm}, closed
    )


HOME = command(120.0, 93.0, -132.0, 60.0, False)
#: Pulses of HOME with the default calibration: base 600+1200, shoulder 600+930,
#: elbow 2400-1320, gripper_arm 1500+600, gripper open (4 cm) 2200-1200.
HOME_PULSES = [1800, 1530, 1080, 2100, 1000]


def fast_config(backend: str, port: str = "/dev/null", **servo: Any) -> Config:
    """The default config on ``port`` with short timeouts, so fault tests stay fast.

    0.5 s, not less: a fake board thread on a loaded 2-core CI machine once took
    longer than 0.15 s to answer a healthy query.
    """
    section = {
        "backend": backend,
        "port": port,
        "ack_timeout_s": 0.5,
        "banner_timeout_s": 1.0,
        "rate_hz": 1000.0,
        "retries": 2,
    }
    section.update(servo)
    return config_from_dict({"servo": section})


def route(n: int = 5) -> list[ArmCommand]:
    """``n`` small steps from home, as a PD-PIJ route sends them."""
    return [command(120.0 - i, 93.0 + 0.5 * i, -132.0 + i) for i in range(n)]


def is_default(config: Config) -> bool:
    return config == Config()


def timed_move(config: Config, bus: Any, share: float) -> tuple[Any, Any]:
    """An executor streaming to ``bus`` and its timed move from home to ``share`` of
    each actuated joint's range: ``(executor, timed)``."""
    from mearm.kinematics import ArmModel
    from mearm.task.execute import Executor

    model = ArmModel(config.arm)
    executor = Executor(config, bus, model)
    lo, hi = model.chain.actuated_lower, model.chain.actuated_upper
    target = model.chain.full(lo + share * (hi - lo))
    return executor, executor.timed(executor.joint_path(target))


def exchange_lines(port: str, lines: list[bytes]) -> list[bytes]:
    """Open the port (a reset), wait for the banner, send each line, read one reply each."""
    replies = []
    with serial.Serial(port, 115200, timeout=30.0) as link:  # a hang bound only
        while b"READY" not in link.readline():
            pass
        for line in lines:
            link.write(line + b"\n")
            replies.append(link.readline().rstrip(b"\n"))
    return replies


def firmware_answers(tmp_path_factory: Any, lines: list[bytes]) -> list[bytes]:
    """The real firmware's replies to ``lines`` in simavr, once checked that it made no
    pulse of them and that the fake board answers them byte for byte the same."""
    from conftest import firmware_build, simulator_build  # noqa: PLC0415
    from fakeboard import FakeMearmBoard, MearmFaults, SimavrBoard  # noqa: PLC0415

    firmware_build(tmp_path_factory)
    folder = simulator_build(tmp_path_factory)
    with SimavrBoard(str(folder / "mearm_sim"), str(folder / "mearm_servo.elf")) as chip:
        firmware = exchange_lines(chip.port, lines)
        assert chip.pulses == []  # none of them was made
    with FakeMearmBoard(MearmFaults(boot_noise=b"")) as fake:
        assert exchange_lines(fake.port, lines) == firmware
    return firmware
