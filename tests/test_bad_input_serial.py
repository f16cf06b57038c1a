"""Bad serial bytes: the bad-input corpus's cases for both serial backends.

Each case puts a pty fake board (``tests/fakeboard.py``) behind ``mearm sort`` and runs
it in-process through :func:`badinput.check_bad_input`: the fault from the board ends
the sort with exit 1 and one line on stderr naming it, within the time bound, the
config file intact; a handshake that fails is found as the rig opens, before the sort
starts (exit 2 and one line, as a camera that cannot be opened). Then the fake is asked
what it received: no move after the fault struck (a resend of the very frame that
failed is not a new move), none at all when the handshake failed.

``servo.port`` values that are not device paths or allowed URLs are refused before
anything opens (exit 2), and :func:`test_one_line_in_a_real_process` checks the one-line
promise outside pytest too, where nothing captures the library's log records.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest
from badinput import check_bad_input, check_bad_input_subprocess
from fakeboard import FakeBoard, FakeMearmBoard, FakeSSC32Board, MearmFaults, SSC32Faults

from mearm.hardware.mearm_protocol import encode_line

#: Short timeouts, so that each case ends within a few seconds. 0.5 s, not less: the fake
#: board is a thread of the process that runs the sort, and on a loaded 2-core CI machine
#: it once took longer than 0.15 s to answer a healthy VER.
SERVO = {"ack_timeout_s": 0.5, "banner_timeout_s": 1.0, "rate_hz": 100.0, "retries": 2}
#: The mearm board's: the fake board's thread, starved on a loaded machine (CI's 3 workers
#: on 2 cores), once answered the first move after 0.5 s, and the sort stopped there with
#: "no acknowledgement" before the fault under test (the SSC-32's cases time their late
#: answers against the 0.5 s above).
SERVO_UNO = {**SERVO, "ack_timeout_s": 2.0, "banner_timeout_s": 5.0}
#: A case whose board never sends a good banner waits for none: the short window of
#: :data:`SERVO` ends it the same way, starved board or not, 4 s sooner (six cases).
SERVO_UNO_NO_BANNER = {**SERVO_UNO, "banner_timeout_s": SERVO["banner_timeout_s"]}
#: Bounds a hang only.
WITHIN_S = 30.0


@dataclass(frozen=True)
class Case:
    """One bad-bytes case.

    Attributes:
        make: Builds the fake board with its faults.
        needle: Text the one stderr line must hold.
        at_move: The move at which the fault strikes (counting from 1), or ``None``
            when it strikes during the handshake and no move may be sent at all.
    """

    make: Callable[[], FakeBoard]
    needle: str
    at_move: int | None = None


def uno(needle: str, at_move: int | None = None, **faults: object) -> Case:
    return Case(lambda: FakeMearmBoard(MearmFaults(**faults)), needle, at_move)  # type: ignore[arg-type]


def ssc(needle: str, at_move: int | None = None, **faults: object) -> Case:
    return Case(lambda: FakeSSC32Board(SSC32Faults(**faults)), needle, at_move)  # type: ignore[arg-type]


NUL_FLOOD = b"\x00" * 8192
LONG_LINE = b"9" * 5000
NO_BANNER = "no banner within"
NO_ACK = "no acknowledgement"

CASES: dict[str, Case] = {
    # ---- our protocol (the Uno): banners
    "uno-banner-garbage": uno(NO_BANNER, banner=False, boot_noise=b"\x8f\x13 gar\xffbage\r\n"),
    "uno-banner-nul-flood": uno(NO_BANNER, banner=False, boot_noise=NUL_FLOOD),
    "uno-banner-oversized-line": uno(NO_BANNER, banner=False, boot_noise=LONG_LINE + b"\n"),
    "uno-banner-non-utf8": uno(NO_BANNER, banner=False, boot_noise=b"READY \xc3\x28\xff*0025\n"),
    "uno-banner-wrong-checksum": uno(
        NO_BANNER, banner=False, boot_noise=b"READY mearm_servo 2.0 5*0000\n"
    ),
    # the banner of the firmware before the CRC-16, byte for byte: refused by name
    "uno-banner-protocol-1": uno(
        "speaks protocol 1", banner=False, boot_noise=b"READY mearm_servo 1.0 5*25\n"
    ),
    "uno-banner-truncated": uno(NO_BANNER, banner=False, boot_noise=b"READY mearm_se"),
    # ---- our protocol: the version reply
    "uno-version-other-firmware": uno(
        "not running mearm_servo", v_reply=encode_line("OK 0 grbl 1.1 5 500 2500")
    ),
    "uno-version-other-protocol": uno(
        "speaks protocol 3", v_reply=encode_line("OK 0 mearm_servo 3.0 5 500 2500")
    ),
    "uno-version-truncated": uno(NO_ACK, v_reply=b"OK 0 mearm_servo 2.0"),
    "uno-version-wrong-checksum": uno(
        "checksum failure on all 3 tries", v_reply=b"OK 0 mearm_servo 2.0 5 500 2500*0000\n"
    ),
    "uno-version-nul-flood": uno("received only garbage", v_reply=NUL_FLOOD),
    "uno-version-non-utf8": uno(
        "received only garbage", v_reply=b"OK 0 mearm_servo\xff 2.0 5 500 2500*001C\n"
    ),
    # ---- our protocol: acknowledgements of moves
    "uno-move-silent": uno(NO_ACK, 2, silent_from_move=2),
    "uno-move-garbage": uno("received only garbage", 2, garbage_from_move=2),
    "uno-move-wrong-checksum": uno(
        "checksum failure on all 3 tries", 2, raw_reply_from_move=(2, b"OK 2*0000\n")
    ),
    "uno-move-truncated": uno(NO_ACK, 2, raw_reply_from_move=(2, b"OK 2*")),
    "uno-move-nul-flood": uno(NO_ACK, 2, raw_reply_from_move=(2, NUL_FLOOD)),
    "uno-move-oversized-line": uno(NO_ACK, 2, raw_reply_from_move=(2, b"OK 2 " + LONG_LINE)),
    "uno-move-non-utf8": uno(NO_ACK, 2, raw_reply_from_move=(2, b"OK 2 \xe9\xff*001F\n")),
    "uno-move-late-reply": uno(NO_ACK, 2, raw_reply_from_move=(2, encode_line("OK 1"))),
    # a banner damaged on the wire is a restart still: not a bad reply to send the move
    # again for, to the freshly booted board, which would make it at once
    "uno-move-garbled-banner": uno(
        "the board restarted", 2, raw_reply_from_move=(2, b"READY mearm_servo 2.0 5*0000\n")
    ),
    "uno-move-unknown-error-number": uno(
        "board error 99: unknown error number",
        2,
        raw_reply_from_move=(2, encode_line("ERR 2 99 what")),
    ),
    "uno-move-numbered-error": uno("board error 5: pulse out of range", 3, error_at_move=(3, 5)),
    "uno-reset-mid-move": uno("the board restarted", 3, reset_at_move=3),
    "uno-link-dropped": uno("link lost", 2, drop_at_move=2),
    # ---- the SSC-32: the version reply
    "ssc32-version-garbage": ssc("not an SSC-32", ver_reply=b"\x8f\x13gar\xffbage\r"),
    # a flood that fits a pty's buffer at once: 8 KiB once took the reader past a short
    # reply window on a loaded machine (then "no acknowledgement", also exit 1)
    "ssc32-version-nul-flood": ssc("not an SSC-32", ver_reply=NUL_FLOOD[:4000] + b"\r"),
    "ssc32-version-oversized-line": ssc("not an SSC-32", ver_reply=b"SSC32-" + LONG_LINE + b"\r"),
    "ssc32-version-non-utf8": ssc("not an SSC-32", ver_reply=b"SSC32-V2.50\xc3\x28\xff\r"),
    "ssc32-version-truncated": ssc(NO_ACK, ver_reply=b"SSC32-V2"),
    "ssc32-version-uno-banner": ssc("not an SSC-32", ver_reply=b"READY mearm_servo 2.0 5*8003\n"),
    # ---- the SSC-32: answers to Q and QP
    "ssc32-answers-garbage": ssc(
        "no '.'/'+' answer to Q", 2, fault_at_move=2, garbage_answers=10**6
    ),
    "ssc32-answers-nul": ssc(
        "no '.'/'+' answer to Q", 2, fault_at_move=2, garbage_answers=10**6, garbage=b"\x00"
    ),
    "ssc32-answers-lost": ssc(NO_ACK, 3, fault_at_move=3, lost_answers=10**6),
    "ssc32-answers-truncated": ssc(NO_ACK, 2, fault_at_move=2, mute_qp=True),
    "ssc32-answers-late": ssc(NO_ACK, 3, fault_at_move=3, late_answers=10**6, late_s=2.0),
    # 0.4 s after the 0.5 s timeout, 0.1 s before the resync's: a host stalled past its
    # deadline reads the stale '+' as the answer to its own query (then "still moving",
    # as once at 0.7 s on a loaded machine); a resync answered too late is no
    # acknowledgement too, so only the first margin must be wide
    "ssc32-answers-late-stale": ssc(
        NO_ACK, 2, fault_at_move=2, late_answers=10**6, late_s=0.9, stale_late=True
    ),
    "ssc32-pulse-read-back-wrong": ssc(
        "move not confirmed: channel", 3, fault_at_move=3, wrong_qp_us=100
    ),
    # one such answer is asked again (tests/test_hardware_ssc32.py); every one ends it
    "ssc32-extra-byte-in-answer": ssc(
        "an answer longer than", 2, fault_at_move=2, extra_answers=10**6
    ),
    "ssc32-never-done": ssc("still moving", 2, fault_at_move=2, moving_forever=True),
    # ---- the SSC-32: restarts and bytes nobody asked for
    "ssc32-reset-mid-move": ssc("the SSC-32 restarted", 3, reset_at_move=3),
    "ssc32-reset-mid-move-no-banner": ssc(
        "reads no pulse", 3, reset_at_move=3, banner_on_reset=False
    ),
    "ssc32-reset-between-moves": ssc(
        "the SSC-32 restarted", 2, stray_after_move=(2, b"SSC32-V2.50USB\r")
    ),
    "ssc32-stray-nul-flood": ssc("unasked", 2, stray_after_move=(2, NUL_FLOOD)),
    "ssc32-stray-oversized-line": ssc("unasked", 2, stray_after_move=(2, LONG_LINE + b"\r")),
    "ssc32-stray-non-utf8": ssc("unasked", 2, stray_after_move=(2, b"\xc3\x28\xff\xfe")),
    "ssc32-link-dropped": ssc("link lost", 3, drop_at_move=3),
}


def write_config(tmp_path: Path, backend: str, port: str, *, banner: bool = True) -> Path:
    """The rig's config; ``banner=False``: the board sends no good banner."""
    path = tmp_path / "rig.yaml"
    servo = (SERVO_UNO if banner else SERVO_UNO_NO_BANNER) if backend == "serial" else SERVO
    lines = [f"  {k}: {v}" for k, v in {"backend": backend, "port": port, **servo}.items()]
    path.write_text("servo:\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return path


def sort_argv(cfg: Path) -> list[object]:
    return ["sort", "--config", cfg, "--random", "1", "--seed", "0", "--quiet"]


def moves_received(board: FakeBoard) -> list[bytes]:
    """The move lines the board received, in order."""
    if isinstance(board, FakeSSC32Board):
        return [board.received[i] for i in board.move_lines]
    return [line for line in board.received if b" M " in line]


def assert_no_move_after_fault(board: FakeBoard, at_move: int | None) -> None:
    moves = moves_received(board)
    if at_move is None:
        assert moves == [], f"moves sent after a failed handshake: {moves[:3]}"
        return
    assert len(moves) >= at_move, f"the fault at move {at_move} never struck: {len(moves)} moves"
    faulted = moves[at_move - 1]
    later = [m for m in moves[at_move:] if m != faulted]
    assert later == [], f"moves sent after the fault at move {at_move}: {later[:3]}"
    if isinstance(board, FakeSSC32Board):
        assert board.moves_after_fault() == []


@pytest.mark.bad_input
@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.heavy
def test_bad_serial_bytes_end_the_sort(tmp_path: Path, name: str) -> None:
    """A board sending bad bytes stops the sort: exit 1, one line, no move after it; in
    the handshake, before the sort starts: exit 2, one line, no move at all."""
    case = CASES[name]
    handshake = case.at_move is None
    with case.make() as board:
        backend = "ssc32" if isinstance(board, FakeSSC32Board) else "serial"
        cfg = write_config(tmp_path, backend, board.port, banner=case.needle != NO_BANNER)
        code = 2 if handshake else 1
        out = check_bad_input(sort_argv(cfg), code=code, within_s=WITHIN_S, keep=[cfg])
        assert case.needle in out.line, out.line
        assert out.line.startswith("mearm sort: error: " if handshake else "mearm sort: stopped: ")
        assert_no_move_after_fault(board, case.at_move)


@pytest.mark.bad_input
@pytest.mark.parametrize("scheme", ["spy", "hwgrep", "alt", "cp2110"])
def test_port_url_refused_before_anything_opens(tmp_path: Path, scheme: str) -> None:
    """``servo.port`` URLs outside socket/rfc2217/loop: exit 2, one line, no file touched."""
    victim = tmp_path / "precious.log"
    victim.write_text("keep me", encoding="utf-8")
    cfg = write_config(tmp_path, "ssc32", f"{scheme}:///dev/null?file={victim}")
    out = check_bad_input(sort_argv(cfg), code=2, within_s=WITHIN_S, keep=[cfg, victim])
    assert f"{scheme}:///dev/null" in out.line and "socket://, rfc2217://, loop://" in out.line


@pytest.mark.bad_input
@pytest.mark.heavy
def test_one_line_in_a_real_process(tmp_path: Path) -> None:
    """Outside pytest nothing captures log records: the retries and the fault are still
    not printed beside the one line (the hardware package's logger has a handler)."""
    with FakeSSC32Board(SSC32Faults(fault_at_move=2, lost_answers=10**6)) as board:
        cfg = write_config(tmp_path, "ssc32", board.port)
        out = check_bad_input_subprocess(sort_argv(cfg), code=1, within_s=WITHIN_S, keep=[cfg])
        assert NO_ACK in out.line
        assert_no_move_after_fault(board, 2)
