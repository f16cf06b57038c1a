"""The hardware package: exports, backend choice, layering, the quantisation CLI."""

from __future__ import annotations

import ast
import json

import pytest
from conftest import ROOT, run_cli
from hardware_helpers import fast_config

import mearm.hardware as hardware
from mearm.hardware import ArduinoBus, ServoBus, SimArm, SSC32Bus, open_bus
from mearm.world import World


def test_all_names_exist():
    for name in hardware.__all__:
        assert hasattr(hardware, name), name


@pytest.mark.parametrize(
    ("backend", "cls"), [("sim", SimArm), ("serial", ArduinoBus), ("ssc32", SSC32Bus)]
)
def test_open_bus_picks_the_backend(backend, cls):
    bus = open_bus(fast_config(backend), world=World())
    assert type(bus) is cls and isinstance(bus, ServoBus) and not bus.is_connected


def test_serial_port_override():
    bus = open_bus(fast_config("serial", "/dev/ttyACM0"), port="socket://localhost:1")
    assert bus.port == "socket://localhost:1"


def test_layering():
    """hardware imports only config, exceptions, kinematics and world (STYLE.md layers)."""
    allowed = {"mearm.config", "mearm.exceptions", "mearm.kinematics", "mearm.world", "mearm.cli"}
    for path in (ROOT / "mearm" / "hardware").glob("*.py"):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("mearm"):
                mod = node.module
                ok = mod.startswith("mearm.hardware") or any(
                    mod == a or mod.startswith(a + ".") for a in allowed
                )
                assert ok, f"{path.name} imports {mod}"
    world = ast.parse((ROOT / "mearm" / "world.py").read_text())
    mods = {n.module for n in ast.walk(world) if isinstance(n, ast.ImportFrom)}
    assert mods <= {"__future__", "dataclasses", "mearm.config", "mearm.exceptions"}


def test_quantization_cli_json():
    """The CLI reports the SPEC §5 figures: degree ~0.3-0.4 cm, microsecond ~10x less."""
    out = run_cli("-m", "mearm.hardware.quantization", "--poses", "300", "--json")
    assert out.returncode == 0, out.stderr
    modes = json.loads(out.stdout)["modes"]
    assert 0.2 < modes["degree"]["mean_cm"] < 0.6
    assert 0.07 < modes["microsecond"]["mean_cm"] / modes["degree"]["mean_cm"] < 0.14
    assert modes["none"]["max_cm"] < 1e-9


def test_quantization_cli_bad_input():
    out = run_cli("-m", "mearm.hardware.quantization", "--poses", "0")
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "--poses" in out.stderr
