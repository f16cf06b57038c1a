"""The virtual Uno: the real firmware in simavr drives the simulated arm by its measured pulses.

``configs/virtual_uno.yaml`` sorts the paper's objects (three of them here) through the
serial backend and the firmware on a simulated ATmega328P; a firmware with two channels
swapped stops the sort with the mismatch named; the pulses the emulated pins produce
agree with the commands. Needs make, gcc-avr, avr-libc, arduino-core-avr, gcc,
libsimavr-dev and libelf-dev; skipped without them, but failed when MEARM_REQUIRE_TOOLS=1 (CI).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
import serial
from badinput import Outcome, run_in_process
from built_once import built_once
from conftest import QUICK_SERVOS, ROOT, interrupted, missing_tool

from mearm.backends import open_bus
from mearm.config import config_from_dict
from mearm.config.sections import VirtualUnoConfig
from mearm.exceptions import ConfigError, MoveNotConfirmedError, ServoFaultedError
from mearm.hardware import ArmCommand, ArmState
from mearm.sim import World
from mearm.sim.virtual_uno import (
    VirtualUno,
    VirtualUnoBuild,
    VirtualUnoBus,
    VirtualUnoError,
    build_virtual_uno,
    cache_root,
    missing_requirements,
)

#: Channels 1 (shoulder) and 2 (elbow) on each other's pins.
SWAPPED = "[SERVO_PIN_1=6,SERVO_PIN_2=5]"


@pytest.fixture(scope="module")
def cache_home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An ``XDG_CACHE_HOME`` of the module's own, holding the shipped firmware and the
    harness, built.

    The build is made once per run (:func:`built_once`) and copied in: a module's
    variant builds go into its own copy, and its simulators run from there, so that
    :func:`_simulators_of` finds its own and no other worker's. (Each module built its
    own before: some 1.3 s of CPU each, ten times a run.)
    """
    missing = missing_requirements()
    if missing:
        missing_tool(", ".join(f"{r.what} ({r.package})" for r in missing))

    def build(home: Path) -> None:
        build_virtual_uno(cache_dir=home / "mearm" / "virtual_uno")

    home = tmp_path_factory.mktemp("cache")
    shutil.copytree(
        built_once(tmp_path_factory, "virtual-uno-cache", build), home, dirs_exist_ok=True
    )
    return home


#: Three of the paper's twelve objects (M1, H2, B3), one of each class: a sort of each
#: class through the board, a pick after a place, as the twelve show it.
PAPER_THREE = (
    "task.scene=[{color: red, x: -10.99, y: 49.70}, {color: green, x: -4.57, y: 47.58}, "
    "{color: blue, x: 6.93, y: 41.11}]"
)


def _sort(
    cache_home: Path, monkeypatch: pytest.MonkeyPatch, *args: str, path: str | None = None
) -> Outcome:
    """``mearm sort`` on the virtual Uno, in this process (the board is a child either way)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    if path is not None:
        monkeypatch.setenv("PATH", path)
    # a generous acknowledgement timeout: on a loaded machine the emulated board, run by
    # simavr beside other work, answered a move after more than the default 2 s
    generous = ["--set", "servo.ack_timeout_s=10"]
    return run_in_process(
        ["sort", "--config", str(ROOT / "configs" / "virtual_uno.yaml"), *generous, *args],
        within_s=30,
    )


@pytest.mark.heavy
def test_virtual_uno_sorts_the_paper_layout(cache_home, monkeypatch):
    """One object of each class of the paper's layout, 3 of 3, through the serial backend
    and the real firmware, the arm moved by the pins' measured pulses, exit 0 (the twelve
    cost four times the CPU and show nothing three do not)."""
    r = _sort(cache_home, monkeypatch, "--quiet", *QUICK_SERVOS, "--set", PAPER_THREE)
    assert r.code == 0, r.stdout + r.stderr
    assert r.stdout.splitlines()[-1] == "sorted 3 of 3 objects (simulated)"
    assert "Traceback" not in r.stderr


@pytest.mark.heavy
def test_swapped_channels_stop_the_sort_with_the_mismatch(cache_home, monkeypatch):
    """A firmware with channels 1 and 2 on each other's pins: the first move's pulses put
    the shoulder and the elbow where the other was sent; exit 1, both named, no motion
    confirmed."""
    r = _sort(cache_home, monkeypatch, "--quiet", "--set", f"servo.virtual_uno.defines={SWAPPED}")
    assert r.code == 1, r.stdout + r.stderr
    # home: shoulder 93° → 1530 µs, elbow -132° → 1080 µs; swapped, each reads the other's
    # (a pulse may end up to a few µs late when another interrupt runs: 48.0° ± 0.5°)
    said = re.search(
        r"joint shoulder: the board's pulses say ([-\d.]+)°, the command was 93\.0°", r.stderr
    )
    assert said is not None and abs(float(said[1]) - 48.0) <= 0.5, r.stderr
    said = re.search(
        r"joint elbow: the board's pulses say ([-\d.]+)°, the command was -132\.0°", r.stderr
    )
    assert said is not None and abs(float(said[1]) + 87.0) <= 0.5, r.stderr
    assert "joint base" not in r.stderr  # channel 0 is where it should be
    assert "last acknowledged pose: none" in r.stderr
    assert "nothing more sent to the servos" in r.stderr
    assert "Traceback" not in r.stderr
    assert r.stdout.splitlines()[-1].startswith("sorted 0 of")  # stopped at the first move


def _simulators_of(cache_home: Path) -> list[int]:
    """Pids of the running ``mearm_sim`` processes built under ``cache_home``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:  # it ended meanwhile
            continue
        if state != "Z" and argv[0].endswith(b"mearm_sim") and str(cache_home).encode() in argv[0]:
            found.append(int(entry.name))
    return found


@pytest.mark.heavy
def test_ctrl_c_at_the_terminal_parks_the_arm_on_the_virtual_uno(cache_home):
    """A terminal's Ctrl-C goes to the whole foreground process group. The simulated board
    is not in it (a real Uno does not die on Ctrl-C): the park that follows is acknowledged,
    exit 130, and no simulator is left running."""
    env = {**os.environ, "XDG_CACHE_HOME": str(cache_home)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "mearm.sort", "--config", "configs/virtual_uno.yaml",
         "--set", "servo.ack_timeout_s=10"],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        start_new_session=True,
    )  # fmt: skip
    assert proc.stdout is not None
    for line in proc.stdout:  # the first place: the board is up and moving
        if line.startswith("place"):
            break
    assert _simulators_of(cache_home), "no simulator ran"
    out, err = interrupted(proc)
    assert proc.returncode == 130, out + err
    assert err.strip().splitlines()[-1].endswith("interrupted (Ctrl-C); arm parked at home"), err
    assert "parking failed" not in err
    assert _simulators_of(cache_home) == []


@pytest.mark.heavy
def test_a_killed_mearm_leaves_no_simulator_running(cache_home):
    """SIGKILL gives mearm no chance to stop its board: the simulator's stdin closes and it
    ends by itself (it is in a process group of its own, so nothing else would end it)."""
    env = {**os.environ, "XDG_CACHE_HOME": str(cache_home)}
    proc = subprocess.Popen(
        [sys.executable, "-m", "mearm.sort", "--config", "configs/virtual_uno.yaml",
         "--set", "servo.ack_timeout_s=10"],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
    )  # fmt: skip
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("pick"):
            break
    running = _simulators_of(cache_home)
    assert running, "no simulator ran"
    proc.kill()
    proc.communicate(timeout=60)
    deadline = time.monotonic() + 60  # generous: a simulator still running then is the bug
    while _simulators_of(cache_home) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert _simulators_of(cache_home) == []


@pytest.mark.heavy
def test_missing_toolchain_is_one_line_naming_the_package(tmp_path, monkeypatch):
    """No avr-gcc, make or cc on PATH and nothing built yet: exit 2 before anything moves,
    one line naming the Debian packages to install."""
    r = _sort(tmp_path, monkeypatch, path=str(tmp_path / "no-tools"))
    assert r.code == 2, r.stdout + r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert "avr-gcc (gcc-avr)" in lines[0] and "make (make)" in lines[0]
    assert "sudo apt-get install make gcc-avr" in lines[0]


def test_missing_toolchain_error_carries_the_packages(tmp_path, monkeypatch):
    """The build names what is missing as data, not only in its message."""
    monkeypatch.setenv("PATH", str(tmp_path / "no-tools"))
    with pytest.raises(VirtualUnoError) as info:
        build_virtual_uno(cache_dir=tmp_path / "cache")
    assert {"make", "gcc-avr", "gcc"} <= set(info.value.packages)
    assert not (tmp_path / "cache").exists()  # nothing half-built


def test_cache_honours_xdg_cache_home(monkeypatch, tmp_path):
    """Builds go under $XDG_CACHE_HOME/mearm/virtual_uno."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert cache_root() == tmp_path / "mearm" / "virtual_uno"


@pytest.mark.parametrize("define", ["servo_pin_1=6", "X=1;rm", "A B", "X=$(id)", ""])
def test_bad_firmware_define_is_refused(define):
    """A define that is not NAME or NAME=VALUE never reaches make's shell."""
    with pytest.raises(ConfigError, match="defines"):
        config_from_dict(
            {"servo": {"backend": "virtual_uno", "virtual_uno": {"defines": [define]}}}
        )


@pytest.mark.heavy
def test_pulses_agree_with_the_commands(cache_home):
    """Over 150 random commands on every channel (500–2500 µs), the first frame after each
    OK: median |error| ≤ 0.5 µs, 97 % within the firmware's 1 µs, every pulse within the
    tolerance the virtual Uno checks moves against (``mearm virtual-uno-pulses``).

    Over 10 000 pulses on a quiet machine 0.4 % end more than 1 µs late (another interrupt,
    the serial port's, was running): 3 of these 750 on average. When the bytes arrive
    depends on the host, and under the whole suite's load in CI's script 12 of 750 were
    late (1.6 %; a bound of 98.5 %, 11 allowed, failed there). The bound allows 22."""
    from mearm.tools.virtual_uno_pulses import pulse_errors, summary

    s = summary(pulse_errors(150, cache_dir=cache_home / "mearm" / "virtual_uno"))
    print(s)
    assert s["pulses"] == 750
    assert s["median_us"] <= 0.5
    assert s["within_1us"] >= 0.97
    assert s["max_us"] <= VirtualUnoConfig().pulse_tolerance_us


def test_opening_the_port_resets_the_board(cache_home, monkeypatch):
    """As DTR resets an Uno: every open of the pty restarts the chip, which prints its
    banner (what find-port reads); no pulses before the first move."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    with VirtualUno.start(speed=0) as board:
        for opens in (1, 2):
            # the read returns at the banner's end: the timeout only bounds a hang (2 s
            # failed once, the chip restarted under a loaded machine)
            with serial.Serial(board.port, 115200, timeout=30.0) as link:
                assert link.readline() == b"READY mearm_servo 2.0 5*8003\n"
            assert board.opens == opens
        assert board.pulses == []


@pytest.fixture
def realtime_thread() -> Iterator[None]:
    """This thread at a realtime policy (``SCHED_FIFO``, priority 1) for the test, as
    SVT-AV1 leaves a thread that opened an encoder as root; put back afterwards."""
    if not hasattr(os, "sched_setscheduler"):
        pytest.skip("scheduling policies are Linux's")
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
    except PermissionError:
        pytest.skip("a realtime policy needs root or an RLIMIT_RTPRIO")
    try:
        yield
    finally:
        os.sched_setscheduler(0, policy, param)


def test_the_simulator_runs_at_the_normal_policy_under_a_realtime_host(
    cache_home, monkeypatch, realtime_thread
):
    """A host thread at a realtime policy: the simulator it starts runs at the normal one.
    At speed 0 it never sleeps; at SCHED_FIFO 99 (a pytest worker after an AV1 test) it
    held a core nothing beside it could have, and the full suite's virtual-Uno sort
    crawled past its 300 s."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    with VirtualUno.start(speed=0) as board:
        with serial.Serial(board.port, 115200, timeout=30.0) as link:
            assert link.readline().startswith(b"READY")  # the simulator runs
            (pid,) = _simulators_of(cache_home)
            assert os.sched_getscheduler(pid) == os.SCHED_OTHER


def test_bad_define_or_speed_is_refused_by_the_library(tmp_path):
    """The library checks what the config would: nothing unchecked reaches make's shell."""
    with pytest.raises(VirtualUnoError, match="NAME or NAME=VALUE"):
        build_virtual_uno(["X=1 -include /etc/passwd"], cache_dir=tmp_path)
    with pytest.raises(VirtualUnoError, match="speed must be from 0 to 1000"):
        VirtualUno(VirtualUnoBuild(tmp_path / "fw.elf", tmp_path / "mearm_sim"), speed=-1.0)


def _bus_config(**virtual_uno):
    return config_from_dict(
        {
            "servo": {
                "backend": "virtual_uno",
                "banner_timeout_s": 2.0,
                "virtual_uno": {"speed": 0, **virtual_uno},
            }
        }
    )


@pytest.mark.heavy
def test_the_arm_follows_the_measured_pulses(cache_home, monkeypatch):
    """open_bus gives the virtual Uno's bus; after a move the simulated arm is where the
    pins' pulses put it: the commanded pose to within the pulse tolerance."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _bus_config()
    bus = open_bus(config, World.from_config(config))
    assert isinstance(bus, VirtualUnoBus)
    home = ArmCommand.home(config.arm)
    with bus:
        bus.move(home)
        assert bus.state == ArmState.from_command(home)
        assert bus.last_frame is not None
        for j in bus.servo_map.joints:
            slack = config.servo.virtual_uno.pulse_tolerance_us / j.us_per_unit
            assert bus.actual_joints[j.name] == pytest.approx(home.joints[j.name], abs=slack)
            assert bus.actual_joints[j.name] == pytest.approx(
                j.value_of(bus.last_frame.widths_us[j.channel])
            )


@pytest.mark.heavy
def test_a_mismatch_faults_the_bus_and_keeps_the_last_confirmed_pose(cache_home, monkeypatch):
    """Swapped channels: the move raises MoveNotConfirmedError, the arm is where the pins
    put it (not where it was sent), no pose is confirmed and nothing more is sent."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _bus_config(defines=["SERVO_PIN_1=6", "SERVO_PIN_2=5"])
    home = ArmCommand.home(config.arm)
    with VirtualUnoBus(config) as bus:
        with pytest.raises(MoveNotConfirmedError) as info:
            bus.move(home)
        assert info.value.expected_us[1] == 1530 and abs(info.value.reported_us[1] - 1080) <= 1
        assert bus.state is None and bus.fault is info.value
        assert bus.actual_joints["shoulder"] == pytest.approx(48.0, abs=0.2)
        assert bus.actual_joints["elbow"] == pytest.approx(-87.0, abs=0.2)
        with pytest.raises(ServoFaultedError):
            bus.move(home)


@pytest.mark.heavy
def test_a_simulator_that_cannot_start_is_named(cache_home, monkeypatch, tmp_path):
    """A firmware file simavr cannot read: connect fails with the simulator's own words."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    bus = VirtualUnoBus(_bus_config())
    bad = tmp_path / "garbage.elf"
    bad.write_bytes(b"not an ELF")
    bus.built = VirtualUnoBuild(firmware=bad, simulator=bus.built.simulator)
    with pytest.raises(VirtualUnoError, match="the simulator stopped .*cannot read"):
        bus.connect()
    assert not bus.is_connected


@pytest.mark.heavy
def test_virtual_uno_sorts_the_mearm_whose_elbow_servo_turns_the_forearm(
    cache_home, tmp_path, monkeypatch
):
    """The MeArm v1 (its elbow servo turns shoulder + elbow) through the real firmware: the
    joints are solved back from the pins' measured pulses, and a scene is sorted.

    Two objects of the config's six, at the ends of its arc (base 60° and 120°), in two
    bins: a pick after a place, every move solved back (each object costs about 1.5 s of
    CPU, the firmware in simavr at full speed)."""
    scene = tmp_path / "scene.yaml"
    scene.write_text("- {color: red, x: 8.7, y: 15.07}\n- {color: green, x: -8.7, y: 15.07}\n")
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    r = run_in_process(
        ["sort", "--config", str(ROOT / "configs" / "sim_mearm_v1.yaml"), "--quiet",
         "--set", "servo={backend: virtual_uno, ack_timeout_s: 10.0, grip_tolerance_cm: 0.6, "
         "virtual_uno: {speed: 0, pulse_tolerance_us: 10.0}}", "--scene", str(scene)],
        within_s=30,
    )  # fmt: skip
    assert r.code == 0, r.stdout + r.stderr
    assert r.stdout.splitlines()[-1] == "sorted 2 of 2 objects (simulated)"
