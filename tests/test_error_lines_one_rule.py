"""A rig that does not open is said by the one error path every command shares.

``mearm calibrate-servos --camera`` and ``mearm experiment`` printed their "rig did not
open" line themselves, so the rule of :func:`mearm.cli.run` for a line too long (cut in
the middle of what it quotes, never at its end: :data:`mearm.cli.LINE_MAX`) did not apply
there: a servo port path over a thousand characters, quoted three times by the serial
bus's message, came out as one line of 4,000. Now both raise
:class:`~mearm.task.armcheck.RigNotOpened` (bad input, exit 2) and ``run`` says it, as
``mearm check-camera`` does. Only the board is mocked: a path no machine has.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from badinput import ROOT, check_bad_input

from mearm import cli
from mearm.__main__ import SUBCOMMANDS

#: How the serial bus's message for a port it cannot open ends (mearm.hardware.serial_bus).
HINT_END = (
    "(mearm find-port lists the ports; Linux: the user must be in the dialout group); last "
    "acknowledged pose: none (no move acknowledged yet)"
)


def long_port(tmp_path: Path) -> str:
    """A servo port path of over 1,000 characters that does not exist, its name ``ttyZ``.

    Folders of 200 characters each (a name may have 255), so opening it fails as a missing
    file, not as a name too long.
    """
    port = str(tmp_path.joinpath(*["d" * 200] * 6, "ttyZ"))
    assert len(port) > cli.LINE_MAX
    return port


def check_cut_line(line: str, prog: str, port: str) -> None:
    """One line of at most LINE_MAX after its prefix: the port's two ends, the hint whole."""
    prefix = f"{prog}: error: "
    assert line.startswith(prefix + port[:20]), line[:200]
    assert len(line) <= len(prefix) + cli.LINE_MAX, len(line)
    assert "…" in line  # the quoted path cut in its middle
    assert "ttyZ: cannot open" in line, line  # the path's end, where its name is
    assert line.endswith(HINT_END), line[-300:]


@pytest.mark.bad_input
def test_calibrate_servos_by_camera_cuts_a_long_rig_line_in_the_middle(tmp_path: Path) -> None:
    """``calibrate-servos --camera`` on a port path too long to say whole: exit 2, one line
    cut in the middle, nothing written."""
    port = long_port(tmp_path)
    out = tmp_path / "kit.servos.yaml"
    result = check_bad_input(
        [
            "calibrate-servos", "--camera",
            "--config", ROOT / "configs" / "sim_mujoco_perspective.yaml",
            "--set", "simulator=kinematic", "--set", "servo.backend=serial",
            "--set", f"servo.port={port}", "--output", out,
        ],
        within_s=5, keep=[tmp_path],
    )  # fmt: skip
    check_cut_line(result.line, "mearm calibrate-servos", port)
    assert "connected" not in result.stdout  # the procedure never started
    assert not out.exists()


@pytest.mark.bad_input
def test_experiment_cuts_a_long_rig_line_in_the_middle(tmp_path: Path) -> None:
    """``experiment`` on a port path too long to say whole: exit 2, one line cut in the
    middle, no log written."""
    port = long_port(tmp_path)
    log = tmp_path / "trials.jsonl"
    result = check_bad_input(
        [
            "experiment", "--config", ROOT / "configs" / "sim.yaml",
            "--set", "servo.backend=serial", "--set", f"servo.port={port}",
            "--trials", "1", "--log", log,
        ],
        within_s=5, keep=[tmp_path],
    )  # fmt: skip
    check_cut_line(result.line, "mearm experiment", port)
    assert not log.exists()


@pytest.mark.bad_input
def test_an_unknown_subcommand_too_long_to_say_whole_is_cut_in_the_middle() -> None:
    """``mearm NAME`` quoted the typed name whole: 3,000 characters made a line of 3,300.
    Cut in its middle, the line still ends with the subcommands to choose from."""
    result = check_bad_input(["x" * 3000], within_s=2)
    assert len(result.line) <= len("mearm: error: ") + cli.LINE_MAX
    assert result.line.startswith("mearm: error: unknown subcommand 'xxx")
    assert "…" in result.line and result.line.endswith(f"{list(SUBCOMMANDS)[-1]})"), result.line[
        -200:
    ]


@pytest.mark.bad_input
def test_an_option_value_too_long_to_say_whole_is_cut_in_the_middle() -> None:
    """argparse's own errors (``--target`` not three numbers) skipped the rule, and quoted
    the value whole; cut in its middle, the line keeps what is allowed at its end."""
    result = check_bad_input(["ik", "--target", "1," * 1500], within_s=2)
    assert len(result.line) <= len("mearm ik: error: ") + cli.LINE_MAX, len(result.line)
    assert result.line.startswith("mearm ik: error: argument --target")
    assert "…" in result.line


@pytest.mark.bad_input
def test_sort_cuts_a_long_rig_line_in_the_middle(tmp_path: Path) -> None:
    """``sort`` printed its rig-not-open line itself too: the same cut, exit 2, one line."""
    port = long_port(tmp_path)
    result = check_bad_input(
        ["sort", "--config", ROOT / "configs" / "sim.yaml", "--set", "servo.backend=serial",
         "--set", f"servo.port={port}"],
        within_s=5, keep=[tmp_path],
    )  # fmt: skip
    check_cut_line(result.line, "mearm sort", port)
