"""An error line too long is shortened where it quotes, never at its end (mearm.cli.run).

A mearm message says what to do last (``… (mearm find-port lists the ports; …)``): a cut
at its end dropped just that. ``mearm jog`` on a 250-character port path that does not
exist (its message quotes the path three times) must still end with the hint; only the
terminal is real to it, the board is a path no machine has.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from test_maker_calibrate import ROOT
from test_missing_port import pty_error_line

from mearm import cli
from mearm.errors import MearmError

#: How the serial bus's message for a port it cannot open ends (mearm.hardware.serial_bus).
HINT_END = (
    "Is the board plugged in and servo.port right? (mearm find-port lists the ports; Linux: "
    "the user must be in the dialout group); last acknowledged pose: none (no move "
    "acknowledged yet)"
)


@pytest.mark.heavy
def test_jog_on_a_long_port_path_ends_with_the_find_port_hint(tmp_path: Path) -> None:
    """On a terminal: exit 2, one line naming the port's two ends and ending with the hint."""
    port = str(tmp_path / ("p" * (250 - len(str(tmp_path)) - 2))) + "Z"
    assert len(port) == 250
    line = pty_error_line(
        "jog", "--config", str(ROOT / "configs" / "sim.yaml"),
        "--set", "servo.backend=serial", "--set", f"servo.port={port}",
    )  # fmt: skip
    assert line.startswith(f"mearm jog: error: {port[:20]}"), line
    assert "pZ: cannot open at" in line, line  # the path's end, where its name is
    assert line.endswith(HINT_END), line
    assert len(line) <= len("mearm jog: error: ") + cli.LINE_MAX


def test_a_line_within_the_bound_is_said_whole() -> None:
    """A message past the old 300-character cut, a 120-character path in it: said whole."""
    path = "/" + "d" * 118 + "f"
    text = f"{path}: cannot read: " + "because " * 80 + "(do what it says)"
    assert 300 < len(text) <= cli.LINE_MAX
    assert cli._one_line(MearmError(text)) == text


def test_long_quoted_words_keep_their_ends_and_the_prose_stays_whole() -> None:
    """A huge path quoted twice: each keeps its two ends, cut evenly; the prose is whole."""
    path = "/home/" + "x" * 2000 + "/frame.png"
    text = f"{path}: cannot read ({path!r} is not there): teach again (mearm learn-colours)"
    line = cli._one_line(MearmError(text))
    assert len(line) <= cli.LINE_MAX
    words = line.split(" ")
    first, second = words[0], words[3]
    assert first.startswith("/home/xxx") and first.endswith("/frame.png:"), first
    assert second.startswith("('/home/xxx") and second.endswith("/frame.png'"), second
    assert "…" in first and "…" in second
    assert abs(len(first) - len(second)) <= 1  # cut evenly
    assert len(first) > 400  # no more than the line needs
    assert " ".join(words[1:3]) == "cannot read"
    assert line.endswith(" is not there): teach again (mearm learn-colours)")


def test_a_line_still_too_long_keeps_its_start_and_its_end() -> None:
    """Prose of short words past the bound: the middle goes, not the part saying what to do."""
    text = "camera: " + "word " * 400 + "(run mearm find-port)"
    line = cli._one_line(MearmError(text))
    assert len(line) == cli.LINE_MAX
    assert line.startswith("camera: word word")
    assert line.endswith("word (run mearm find-port)")
    assert "…" in line
