"""The hardware package: exports, backend choice, layering, the quantisation CLI."""

from __future__ import annotations

import ast
import json

import pytest
from conftest import ROOT, run_cli
from hardware_helpers import fast_config

import mearm.hardware as hardware
from mearm.hardware import ArduinoBus, ServoBus, SSC32Bus, open_bus
from mearm.sim import SimArm, World


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


def _module_level_imports(tree: ast.Module) -> list[str]:
    """``from mearm… import`` at module level, outside ``if TYPE_CHECKING:`` blocks."""
    mods = []
    for node in tree.body:
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            continue
        for sub in ast.walk(node):
            if isinstance(sub, (ast.FunctionDef, ast.AsyncFunctionDef)):
                break
            if isinstance(sub, ast.ImportFrom) and sub.module and sub.module.startswith("mearm"):
                mods.append(sub.module)
    return mods


def _allowed(mod: str, allowed: set[str]) -> bool:
    return any(mod == a or mod.startswith(a + ".") for a in allowed)


def test_layering():
    """hardware imports only config, exceptions, kinematics and cli at module level; the
    simulator (the layer above) only lazily, inside the function that needs it."""
    allowed = {
        "mearm.config",
        "mearm.exceptions",
        "mearm.kinematics",
        "mearm.cli",
        "mearm.hardware",
    }
    lazy = set()
    for path in (ROOT / "mearm" / "hardware").glob("*.py"):
        tree = ast.parse(path.read_text())
        for mod in _module_level_imports(tree):
            assert _allowed(mod, allowed), f"{path.name} imports {mod} at module level"
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("mearm"):
                assert _allowed(node.module, allowed | {"mearm.sim"}), (path.name, node.module)
                if node.module.startswith("mearm.sim"):
                    lazy.add(path.name)
    assert lazy == {"factory.py", "quantization.py"}
    servo_bus = ast.parse((ROOT / "mearm" / "sim" / "servo_bus.py").read_text())
    sim_allowed = allowed - {"mearm.cli"} | {"mearm.sim"}
    for node in ast.walk(servo_bus):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("mearm"):
            assert _allowed(node.module, sim_allowed), f"servo_bus.py imports {node.module}"


def test_quantization_cli_json():
    """The CLI reports the SPEC §5 figures: degree ~0.3-0.4 cm, microsecond ~10x less."""
    out = run_cli("-m", "mearm.hardware.quantization", "--poses", "300", "--json")
    assert out.returncode == 0, out.stderr
    modes = json.loads(out.stdout)["modes"]
    assert 0.2 < modes["degree"]["mean_cm"] < 0.6
    assert 0.07 < modes["microsecond"]["mean_cm"] / modes["degree"]["mean_cm"] < 0.14
    assert modes["none"]["max_cm"] < 1e-9


def test_quantization_cli_other_arm():
    """The CLI measures any arm: the 5-joint desk arm (no closed form) works too."""
    out = run_cli(
        "-m", "mearm.hardware.quantization", "--config", "configs/sim_5dof.yaml",
        "--poses", "100", "--json",
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    modes = json.loads(out.stdout)["modes"]
    assert 0 < modes["microsecond"]["mean_cm"] < modes["degree"]["mean_cm"] < 1.0


def test_quantization_cli_bad_input():
    out = run_cli("-m", "mearm.hardware.quantization", "--poses", "0")
    assert out.returncode == 2 and out.stderr.count("\n") == 1 and "--poses" in out.stderr
