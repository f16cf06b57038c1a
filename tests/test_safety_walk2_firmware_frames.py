"""The firmware reads a frame's fields as PROTOCOL.md writes them: one space between them.

``strtok`` let the firmware take ``5  V`` or ``5 V `` as well formed, where the fake Uno of
the backend's fault tests (and the protocol) refuse them: the two no longer answered
alike, byte for byte. The real firmware runs in simavr.
"""

from __future__ import annotations

import pytest
from hardware_helpers import firmware_answers

from mearm.hardware.mearm_protocol import decode_line, encode_command, encode_line

SPACING = [
    encode_line("1  V").rstrip(),  # two spaces between seq and command
    encode_line("2 V ").rstrip(),  # a trailing space
    encode_line(" 3 V").rstrip(),  # a leading space: no seq to answer
    encode_line("4 M 1500  1500 1500 1500 1500").rstrip(),  # two spaces between arguments
    encode_command(5, "V").rstrip(),  # and a good frame after them
]


@pytest.mark.heavy
def test_extra_spaces_are_refused_as_the_fake_board_refuses_them(tmp_path_factory):
    firmware = firmware_answers(tmp_path_factory, SPACING)  # the badly spaced M not made
    codes = [decode_line(r) for r in firmware]
    assert [(c.kind, c.seq, c.code) for c in codes[:4]] == [
        ("ERR", 1, 2), ("ERR", 2, 2), ("ERR", None, 2), ("ERR", 4, 2)
    ]  # fmt: skip
    assert codes[4].kind == "OK" and codes[4].seq == 5
