"""The virtual Uno's acknowledgements are waited for by its simulated clock, not the wall's.

A loaded machine runs simavr well below real time (three busy processes on 2 cores: 0.2 to
0.45 of it), and a sort once stopped on ``no acknowledgement within 2 s`` of wall time
from a board that was only slow. Here the board is slowed on purpose and deterministically
(``servo.virtual_uno.speed`` 0.02: its clock never runs ahead of 1/50 of the wall clock's),
so its replies, some 4 to 10 simulated milliseconds after each command, take at least 3
times the acknowledgement timeout of wall time, and must still pass; a board that answers
nothing, its simulator frozen or dead, must still time out.

A connect that times out says which: the simulator stopped on its own (and how), or the
chip, running, did not answer within the timeout of its own clock, or its clock stood still.
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from pathlib import Path

import pytest
from test_virtual_uno import cache_home  # noqa: F401  (a fixture)

from mearm.config import Config, config_from_dict
from mearm.exceptions import NoAckError
from mearm.hardware import ArmCommand, ArmState
from mearm.sim.virtual_uno import VirtualUnoBuild, VirtualUnoBus, VirtualUnoError

#: Simulated seconds per wall-clock second: the V reply (over 4 ms of the chip's time to
#: take its 9 bytes and send its 40 at 115200 baud) takes 0.19 s of wall time at least
#: (the harness lets the chip's clock fall behind by 20 ms of wall time, never run ahead).
SLOW = 0.02
#: The acknowledgement (and banner) timeout [s]: a quarter of that wall time, and five
#: times the chip's own (under 10 ms a reply).
ACK_S = 0.05


def _slow_config(banner_timeout_s: float = ACK_S) -> Config:
    return config_from_dict(
        {
            "task": {"scene": []},
            "servo": {
                "backend": "virtual_uno",
                "ack_timeout_s": ACK_S,
                "banner_timeout_s": banner_timeout_s,
                "virtual_uno": {"speed": SLOW},
            },
        }
    )


@pytest.mark.heavy
@pytest.mark.parametrize("banner_timeout_s", [ACK_S, 5.0])
def test_a_board_slower_than_real_time_is_not_taken_for_a_silent_one(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
    banner_timeout_s: float,
) -> None:
    """The banner, the handshake and a move on a board at 1/50 of real time: every reply
    comes well within ACK_S of its simulated time, long after ACK_S of wall time. (With a
    banner timeout of 5 s the banner passes by the wall clock too: the acknowledgements
    alone are tried.)"""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _slow_config(banner_timeout_s)
    home = ArmCommand.home(config.arm)
    with VirtualUnoBus(config) as bus:
        bus.move(home)
        assert bus.state == ArmState.from_command(home)
        assert bus.last_frame is not None


@pytest.mark.heavy
@pytest.mark.parametrize("how", ["frozen", "dead"])
def test_a_slow_board_that_stops_answering_still_times_out(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
    how: str,
) -> None:
    """The same slow board, its simulator then paused (SIGSTOP: its clock stands still,
    and the wait ends at its wall bound) or killed (no clock: the wall time alone): the
    next move is not acknowledged, and the fault keeps the last confirmed pose."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = _slow_config()
    home = ArmCommand.home(config.arm)
    with VirtualUnoBus(config) as bus:
        bus.move(home)
        confirmed = bus.state
        assert confirmed == ArmState.from_command(home)
        assert bus.board is not None and bus.board._proc is not None
        bus.board.sleep_s(bus.period_s)  # the next move is due: it is sent at once
        pid = bus.board._proc.pid
        os.kill(pid, signal.SIGSTOP if how == "frozen" else signal.SIGKILL)
        try:
            with pytest.raises(NoAckError) as info:
                bus.move(home)
        finally:
            if how == "frozen":
                os.kill(pid, signal.SIGCONT)
        assert info.value.last_state == confirmed
        assert bus.fault is info.value


def _silent_firmware(folder: Path) -> Path:
    """A firmware that runs and never prints a thing: no banner, ever."""
    source = folder / "silent.c"
    source.write_text("int main(void) { for (;;) { } }\n")
    elf = folder / "silent.elf"
    subprocess.run(["avr-gcc", "-mmcu=atmega328p", "-Os", "-o", str(elf), str(source)], check=True)
    return elf


@pytest.mark.heavy
@pytest.mark.parametrize("how", ["running", "frozen", "dead"])
def test_a_connect_that_times_out_says_whether_the_simulator_stopped(
    cache_home: Path,  # noqa: F811  (the fixture imported above)
    monkeypatch: pytest.MonkeyPatch,
    tmp_path: Path,
    how: str,
) -> None:
    """A board that never prints its banner, in real time (its clock never ahead of the
    wall's): running, the chip did not answer within the banner timeout of its own clock;
    paused (SIGSTOP) before that, its clock stood still (the wait ends at its wall bound);
    killed (SIGKILL), the simulator stopped, and the signal says how. The simulator closed
    by the failed connect is never said to have stopped with the close's own words
    (simavr's ``Loaded 0 .data``)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(cache_home))
    config = config_from_dict(
        {
            "task": {"scene": []},
            "servo": {
                "backend": "virtual_uno",
                "banner_timeout_s": 1.0,
                "virtual_uno": {"speed": 1},
            },
        }
    )
    bus = VirtualUnoBus(config)
    bus.built = VirtualUnoBuild(_silent_firmware(tmp_path), bus.built.simulator)
    done = threading.Event()
    hit: list[int] = []

    def strike() -> None:  # as soon as the chip runs: well before 1 s of its clock
        while not done.is_set():
            board = bus.board
            proc = None if board is None else board._proc
            if proc is not None:
                hit.append(proc.pid)
                os.kill(proc.pid, signal.SIGSTOP if how == "frozen" else signal.SIGKILL)
                return
            time.sleep(0.001)

    striker = threading.Thread(target=strike, daemon=True)
    if how != "running":
        striker.start()
    try:
        with pytest.raises(VirtualUnoError) as info:
            bus.connect()
    finally:
        done.set()
        if striker.is_alive():
            striker.join()
    message = str(info.value)
    assert "no banner within 1 s" in message
    assert "Loaded" not in message
    if how == "running":
        assert "the chip did not answer within 1 s of its own clock" in message
        assert "stopped" not in message
    elif how == "frozen":
        assert hit and "its clock stood still" in message
        assert "stopped" not in message
    else:
        assert hit and "the simulator stopped (killed by SIGKILL)" in message
    assert not bus.is_connected
