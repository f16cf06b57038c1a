"""Protocol 2: every line ends in a CRC-16, and a board still speaking protocol 1 is refused.

Protocol 1 checked a line by the XOR of its bytes, which misses the same bit flipped in
two bytes: ``1500 1500`` read as ``1400 1501`` passed, and the board made a move nobody
sent. The CRC-16/XMODEM of protocol 2 catches it on both sides — the host's decoder and
the firmware, run in simavr, which answers it as the fake Uno does — and every error of
1, 2 or 3 bits on a line of the longest length. A board flashed before the change prints
protocol 1's banner: the host refuses it by name, telling to reflash, and sends nothing.
"""

from __future__ import annotations

import itertools

import pytest
from fakeboard import FakeMearmBoard, MearmFaults
from hardware_helpers import command, fast_config, firmware_answers

from mearm.backends import open_bus
from mearm.hardware.errors import FirmwareVersionError
from mearm.hardware.mearm_protocol import (
    CHECK_DIGITS,
    ERR_CHECKSUM,
    MAX_LINE,
    BadChecksum,
    Reply,
    checksum,
    decode_line,
    encode_command,
    encode_line,
)
from mearm.maker.find_port import SerialPort, format_report, probe_port

#: The same bit (the lowest) flipped in two bytes: '5' → '4' and '0' → '1'.
SENT, READ = b"1500 1500", b"1400 1501"
#: A command whose first two channels get 1500 µs with the default config.
MIDDLE = command(90.0, 90.0, -132.0)
#: The banner of the firmware before the CRC-16, as it printed it (protocol 1).
PROTOCOL_1_BANNER = b"READY mearm_servo 1.0 5*25\n"


def garbled(line: bytes) -> bytes:
    """``line`` with the two-byte flip, its check value as sent."""
    assert SENT in line
    return line.replace(SENT, READ, 1)


# --------------------------------------------------------------------------- the check


def test_the_two_byte_flip_fails_the_check():
    reply = encode_line("OK 2 RUN 1500 1500 1080 2100 1000")
    assert isinstance(decode_line(reply), Reply)
    assert isinstance(decode_line(garbled(reply)), BadChecksum)


def test_every_error_of_up_to_three_bits_on_the_longest_line_is_caught():
    """Exhaustively, by the check's linearity: an error pattern goes unseen exactly when
    its own check value is 0, and a pattern's value is the XOR of its bits' values. So
    every 1-bit error is caught when no bit's value is 0, every 2-bit error when no two
    are equal, every 3-bit error when no two XOR to a third's."""
    body_bytes = MAX_LINE - 1 - CHECK_DIGITS
    values = []
    for bit in range(8 * body_bytes):
        pattern = bytearray(body_bytes)
        pattern[bit // 8] = 0x80 >> (bit % 8)
        values.append(checksum(bytes(pattern)))
    assert 0 not in values
    assert len(set(values)) == len(values)
    singles = set(values)
    assert not any(a ^ b in singles for a, b in itertools.combinations(values, 2))


# --------------------------------------------------------------------------- host and fake board


def test_a_command_garbled_so_on_the_wire_is_resent_not_made():
    """The fake Uno reads the move with the two-byte flip: it refuses it (``ERR - 1``),
    the host resends it, and the move made is the one sent."""
    with FakeMearmBoard(MearmFaults(garble_incoming=(SENT, READ))) as board:
        with open_bus(fast_config("serial", board.port)) as bus:
            bus.move(MIDDLE)
        assert board.faults.garble_incoming is None  # the noise struck
        assert board.moves == [[1500, 1500, 1080, 2100, 1000]]


def test_a_reply_garbled_so_on_the_wire_is_not_believed():
    """The board's answer to ``Q`` comes with the two-byte flip: the host asks again and
    reports the pulses the board holds."""
    with FakeMearmBoard(MearmFaults(garble_reply=(SENT, READ))) as board:
        with open_bus(fast_config("serial", board.port)) as bus:
            bus.move(MIDDLE)
            status = bus.query()
        assert board.faults.garble_reply is None
        assert status.pulses_us == (1500, 1500, 1080, 2100, 1000)


# --------------------------------------------------------------------------- a protocol-1 board


@pytest.mark.parametrize(
    ("faults", "version", "speaks"),
    [
        (MearmFaults(banner=False, boot_noise=b"\x00\xfe\r\n" + PROTOCOL_1_BANNER), "2.0", 1),
        (MearmFaults(), "1.0", 1),  # its banner checked by a CRC, its version says 1
        (MearmFaults(), "3.0", 3),
    ],
    ids=["protocol-1-banner", "crc-banner-version-1", "crc-banner-version-3"],
)
def test_a_board_of_another_protocol_is_refused_before_anything_is_sent(faults, version, speaks):
    with FakeMearmBoard(faults, version=version) as board:
        bus = open_bus(fast_config("serial", board.port))
        with pytest.raises(FirmwareVersionError) as err:
            bus.connect()
        assert not bus.is_connected
        assert board.received == []
    message = str(err.value)
    assert f"speaks protocol {speaks}" in message and "this host speaks protocol 2" in message
    assert "mearm flash" in message and "nothing was sent" in message
    assert "\n" not in message


@pytest.mark.parametrize(
    ("faults", "version", "says"),
    [
        (MearmFaults(banner=False, boot_noise=b"\x00\xfe\r\n" + PROTOCOL_1_BANNER), "2.0",
         "mearm_servo 1.0 speaks protocol 1"),
        (MearmFaults(), "3.0", "mearm_servo 3.0 speaks protocol 3"),
    ],
    ids=["protocol-1-banner", "crc-banner-version-3"],
)  # fmt: skip
def test_find_port_says_to_reflash_a_board_of_another_protocol(faults, version, says):
    """``find-port`` (and ``flash``'s check after it uploads) said a protocol-1 board was
    "not a mearm board … wrong baud rate?": it is the mearm firmware, to be reflashed."""
    with FakeMearmBoard(faults, version=version) as board:
        report = probe_port(SerialPort(board.port), 115200, 5.0)
        assert board.received == []
    assert report.status == "outdated"
    line = format_report(report, len(board.port))
    assert f"mearm board of another protocol: {says}, this host 2: reflash it" in line
    assert f"(mearm flash --port {board.port})" in line


# --------------------------------------------------------------------------- the firmware


FRAMES = [
    garbled(encode_command(1, "M", [1500, 1500, 1080, 2100, 1000]).rstrip()),
    b"2 V*44",  # a protocol-1 line (its XOR): not a frame of protocol 2
    encode_command(3, "Q").rstrip(),
]


@pytest.mark.heavy
def test_the_firmware_refuses_the_two_byte_flip_as_the_fake_board_does(tmp_path_factory):
    firmware = firmware_answers(tmp_path_factory, FRAMES)  # the garbled move not made
    codes = [decode_line(r) for r in firmware]
    assert [(c.kind, c.seq, c.code) for c in codes] == [  # type: ignore[union-attr]
        ("ERR", None, ERR_CHECKSUM), ("ERR", None, 2), ("OK", 3, 0)
    ]  # fmt: skip
    assert codes[2].fields == ("IDLE", "0", "0", "0", "0", "0")  # type: ignore[union-attr]
