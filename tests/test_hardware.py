"""The hardware package: exports, backend choice, the quantisation CLI (layers: test_layers)."""

from __future__ import annotations

import contextlib
import json

import pytest
from badinput import run_in_process
from conftest import ROOT, run_cli
from hardware_helpers import fast_config

import mearm.hardware as hardware
from mearm.backends import open_bus
from mearm.config.port import ALLOWED_URL_SCHEMES, check_port
from mearm.exceptions import ConfigError, LinkError, MearmError, SerialPortError
from mearm.hardware import ArduinoBus, ServoBus, SSC32Bus
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


@pytest.mark.parametrize(
    "port",
    ["/dev/ttyACM0", "/dev/ttyUSB0", "COM3", "/dev/serial/by-id/usb-Arduino_Uno-if00",
     "socket://localhost:7777", "SOCKET://10.0.0.2:23", "rfc2217://host:2217?timeout=1",
     "loop://", "loop://?logging=debug"],
)  # fmt: skip
def test_port_allowed(port):
    """Device paths and the socket, rfc2217 and loop URLs are accepted unchanged."""
    assert check_port(port) == port
    assert open_bus(fast_config("serial", port)).port == port


@pytest.mark.parametrize(
    ("port", "reason"),
    [("spy:///dev/ttyACM0?file=/tmp/x", "scheme 'spy'"), ("SPY://x", "scheme 'SPY'"),
     ("hwgrep://.*", "scheme 'hwgrep'"), ("alt:///dev/ttyS0?class=PosixPollSerial", "'alt'"),
     ("cp2110://0001:0004:00", "'cp2110'"), ("file:///etc/passwd", "'file'"),
     ("://x", "scheme ''"), ("", "is empty"), ("   ", "is empty"),
     (" /dev/ttyACM0", "whitespace around it"), ("/dev/tty\x00ACM0", "control character"),
     ("/dev/ttyACM0\n", "whitespace around it"), (7, "must be a string")],
)  # fmt: skip
def test_port_refused(port, reason):
    """Anything else is refused by name, with the allowed forms, before anything opens."""
    with pytest.raises(SerialPortError) as err:
        check_port(port)
    assert isinstance(err.value, MearmError) and isinstance(err.value, ValueError)
    assert err.value.port == port and err.value.allowed == ALLOWED_URL_SCHEMES
    text = str(err.value)
    assert reason in text and repr(port) in text
    assert "device path" in text and "socket://, rfc2217://, loop://" in text


@pytest.mark.parametrize("backend", ["serial", "ssc32"])
def test_spy_url_never_writes_its_file(tmp_path, backend):
    """``spy://…?file=PATH`` used to truncate PATH: the backends refuse it, PATH intact."""
    victim = tmp_path / "precious.txt"
    victim.write_text("keep me")
    url = f"spy:///dev/null?file={victim}"
    with pytest.raises(ConfigError, match="servo.port: the URL scheme 'spy'"):
        fast_config(backend, url)  # refused when the config loads
    bus = open_bus(fast_config(backend, "/dev/null"))
    bus.port = url  # changed after the check: refused again where the port is opened
    with pytest.raises(SerialPortError):
        bus.connect()
    assert victim.read_text() == "keep me"


def test_allowed_url_that_cannot_connect():
    """An allowed URL to nowhere is a LinkError naming it, not a crash."""
    bus = open_bus(fast_config("serial", "socket://127.0.0.1:1"))
    with pytest.raises(LinkError, match="socket://127.0.0.1:1"):
        bus.connect()


@pytest.mark.heavy
def test_quantization_cli_json():
    """The CLI reports the paper §5 figures: degree ~0.3-0.4 cm, microsecond ~10x less."""
    out = run_cli("-m", "mearm", "quantization", "--poses", "300", "--json")
    assert out.returncode == 0, out.stderr
    modes = json.loads(out.stdout)["modes"]
    assert 0.2 < modes["degree"]["mean_cm"] < 0.6
    assert 0.07 < modes["microsecond"]["mean_cm"] / modes["degree"]["mean_cm"] < 0.14
    assert modes["none"]["max_cm"] < 1e-9


@pytest.mark.heavy
def test_quantization_cli_other_arm():
    """The CLI measures any arm: the 5-joint desk arm (no closed form) works too."""
    with contextlib.chdir(ROOT):  # in this process: the test above runs the command
        out = run_in_process(
            ["quantization", "--config", "configs/sim_5dof.yaml", "--poses", "100", "--json"],
            within_s=30,
        )
    assert out.code == 0, out.stderr
    modes = json.loads(out.stdout)["modes"]
    assert 0 < modes["microsecond"]["mean_cm"] < modes["degree"]["mean_cm"] < 1.0


@pytest.mark.heavy
def test_quantization_cli_bad_input():
    out = run_in_process(["quantization", "--poses", "0"])  # the command: the tests above
    assert out.code == 2 and out.stderr.count("\n") == 1 and "--poses" in out.stderr
