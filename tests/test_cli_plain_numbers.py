"""Every command reads numbers alike: plain ASCII decimals, no ``1_20``, no other scripts.

Python's ``float`` and ``int`` read ``1_20``, Arabic-Indic ``١٢٠`` and fullwidth ``１２０``
as 120. ``mearm fk`` and ``mearm ik`` refused them while every other command's numeric
options took them; the one check now lives in :func:`mearm.cli.check_plain_number`, which
each of mearm.cli's numeric argparse types calls. Options once typed ``type=int`` or
``type=float`` (``bench --repeat``, ``sort --random``...) take :func:`mearm.cli.plain_int`
and :func:`mearm.cli.plain_float`; the commands' own number types call the check too.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import subprocess
import sys
from pathlib import Path

import pytest
from badinput import check_bad_input

from mearm.cli import (
    float_list,
    plain_float,
    plain_int,
    positive_number,
    seed_value,
    worker_count,
)
from mearm.errors import MearmError

ROOT = Path(__file__).resolve().parent.parent

#: Text Python reads as a number that nobody typed as one.
NOT_PLAIN = ["1_20", "\u0661\u0662\u0660", "\uff11\uff12\uff10", "12\u0660"]

TYPES = {
    "float_list": (float_list(None, "--joints"), "plain decimal numbers"),
    "positive_number": (positive_number(0.0, 1e6), "a plain decimal number"),
    "seed_value": (seed_value, "a seed is a plain integer"),
    "worker_count": (worker_count, "a number of workers is a plain integer"),
    "plain_int": (plain_int, "must be a plain integer"),
    "plain_float": (plain_float, "must be a plain decimal number"),
}


@pytest.mark.parametrize("text", NOT_PLAIN)
@pytest.mark.parametrize("kind", list(TYPES))
def test_every_numeric_type_refuses_what_is_no_plain_number(kind, text):
    parse, must_be = TYPES[kind]
    with pytest.raises(argparse.ArgumentTypeError) as caught:
        parse(text)
    message = str(caught.value)
    assert must_be in message and "ASCII digits 0-9" in message and "no '_'" in message
    assert repr(text) in message  # what was typed, to see what was wrong


def test_plain_numbers_still_read():
    assert float_list(None, "--joints")("120,-93.5,1e-3, 2") == [120.0, -93.5, 0.001, 2.0]
    assert positive_number(0.0, 1e6)("1.5e2") == 150.0
    assert seed_value("+120") == 120
    assert worker_count(" 2 ") == 2
    assert plain_int("-7") == -7
    assert plain_float(" -1.5e1") == -15.0


@pytest.mark.parametrize(("parse", "text"), [(plain_int, "1.5"), (plain_float, "1,5")])
def test_what_is_no_number_is_refused_saying_what_is_allowed(parse, text):
    with pytest.raises(argparse.ArgumentTypeError, match="ASCII digits 0-9"):
        parse(text)


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("argv", "says"),
    [
        # each command stops on the option as typed: before, 1_20 and ١ passed and the
        # command went on to the next complaint (--log missing, --rate-hz 0) or ran
        (["experiment", "--seed", "1_20"], "argument --seed: a seed is a plain integer"),
        (["experiment", "--jobs", "\u0661"], "argument --jobs: a number of workers is a plain"),
        (["preview", "--step-deg", "1_0", "--rate-hz", "0"], "a plain decimal number"),
        (["ik", "--target=-10.99,49.70,12.76", "--tolerance", "1_0"], "a plain decimal number"),
    ],
)
def test_commands_refuse_numbers_nobody_typed(argv, says):
    out = check_bad_input(argv)
    assert says in out.line and "got" in out.line, out.line


#: Fullwidth 120, as a phone's or an East Asian keyboard types it.
FULLWIDTH = "\uff11\uff12\uff10"

#: ``mearm`` commands, each with an option given ``1_20`` and one given ``１２０``, and
#: the text its error must quote. Before, ``type=int``/``type=float`` and the commands'
#: own types read both as 120.
OPTION_CASES = [
    (["bench", "--repeat", "1_20"], "--repeat", "1_20"),
    (["bench", "--repeat", FULLWIDTH], "--repeat", FULLWIDTH),
    (["experiment", "--trials", "1_20"], "--trials", "1_20"),
    (["experiment", "--trials", FULLWIDTH], "--trials", FULLWIDTH),
    (["sort", "--random", "1_20"], "--random", "1_20"),
    (["sort", "--random", FULLWIDTH], "--random", FULLWIDTH),
    (["twin-scenes", "--scenes", "1_20"], "--scenes", "1_20"),
    (["twin-scenes", "--require", FULLWIDTH], "--require", FULLWIDTH),
    (["shape-sweep", "--objects", "1_20"], "--objects", "1_20"),
    (["shape-sweep", "--max-cm", FULLWIDTH], "--max-cm", FULLWIDTH),
    (["camera-accuracy", "--views", "1_20"], "--views", "1_20"),
    (["camera-accuracy", "--noise-std", FULLWIDTH], "--noise-std", FULLWIDTH),
    (["eval-policy", "--episodes", "1_20"], "--episodes", "1_20"),
    (["eval-policy", "--require", FULLWIDTH], "--require", FULLWIDTH),
    (["quantization", "--poses", "1_20"], "--poses", "1_20"),
    (["quantization", "--poses", FULLWIDTH], "--poses", FULLWIDTH),
    (["aruco-sheet", "--dpi", "1_20"], "--dpi", "1_20"),
    (["aruco-sheet", "--side-cm", FULLWIDTH], "--side-cm", FULLWIDTH),
    (["charuco-board", "--dpi", FULLWIDTH], "--dpi", FULLWIDTH),
    (["servo-steps", "--degrees", "10", "1_20"], "--degrees", "1_20"),
    (["servo-steps", "--degrees", FULLWIDTH], "--degrees", FULLWIDTH),
    (["calibrate-camera", "--marker-side-cm", "1_20"], "--marker-side-cm", "1_20"),
    (["calibrate-camera", "--raised-height-cm", FULLWIDTH], "--raised-height-cm", FULLWIDTH),
    (["learn-colours", "--radius", "1_20"], "--radius", "1_20"),
    (["learn-colours", "--radius", FULLWIDTH], "--radius", FULLWIDTH),
    (["flash", "--upload-baud", "115_200"], "--upload-baud", "115_200"),
    (["find-camera", "--indices", FULLWIDTH], "--indices", FULLWIDTH),
    (["preview", "--port", "7_000"], "--port", "7_000"),
    (["ik-stalls", "--targets", FULLWIDTH], "--targets", FULLWIDTH),
    # the commands' own number types
    (["preview", "--joints", "shoulder=1_20"], "--joints", "1_20"),
    (["preview", "--size", f"{FULLWIDTH}0x800"], "--size", f"{FULLWIDTH}0x800"),
    (["check-camera", "--points", "1_0"], "--points", "1_0"),
    (["calibrate-intrinsics", "--frames", FULLWIDTH], "--frames", FULLWIDTH),
    (["vision-bench", "--repeat", "1_20"], "--repeat", "1_20"),
    (["render-calibration", "--views", FULLWIDTH], "--views", FULLWIDTH),
    (["render-calibration", "--noise-std", "1_0"], "--noise-std", "1_0"),
    (["render-calibration", "--raised-height-cm", "1_0"], "--raised-height-cm", "1_0"),
    (["calibrate-camera", "--point", "1_0,2:3,4"], "--point", "1_0,2"),
    (["calibrate-camera", "--marker", f"0:{FULLWIDTH},4"], "--marker", f"{FULLWIDTH},4"),
    (["calibrate-servos", "--reading-error", "1_0"], "--reading-error", "1_0"),
    (["sort", "--record-fps", "1_0"], "--record-fps", "1_0"),
    (["experiment", "--record-fps", FULLWIDTH], "--record-fps", FULLWIDTH),
]


def _refused_as_typed(line: str, option: str, text: str) -> bool:
    return f"argument {option}: " in line and "ASCII digits 0-9" in line and repr(text) in line


@pytest.mark.bad_input
@pytest.mark.parametrize(("argv", "option", "text"), OPTION_CASES)
def test_every_numeric_option_refuses_numbers_nobody_typed(argv, option, text):
    # the unknown option after it: had the command taken the number, argparse stops there
    # (exit 2, "unrecognized arguments") and nothing runs
    out = check_bad_input([*argv, "--no-such-option"])
    assert _refused_as_typed(out.line, option, text), out.line


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("module", "argv", "option", "text"),
    [
        ("mearm.envs.replay", ["data", "--episode", "1_20"], "--episode", "1_20"),
        ("mearm.envs.replay", ["data", "--objects", FULLWIDTH], "--objects", FULLWIDTH),
        ("mearm.learn.bc", ["--steps", "1_20"], "--steps", "1_20"),
        ("mearm.learn.bc", ["--batch", FULLWIDTH], "--batch", FULLWIDTH),
        ("mearm.analysis.servo_bound", ["--samples", FULLWIDTH], "--samples", FULLWIDTH),
    ],
)
def test_module_commands_refuse_numbers_nobody_typed(module, argv, option, text):
    """The ``python -m`` commands outside ``mearm``'s list: their parser, in-process."""
    main = importlib.import_module(module).main
    err = io.StringIO()
    with contextlib.redirect_stderr(err), pytest.raises(SystemExit) as stop:
        main([*argv, "--no-such-option"])
    lines = err.getvalue().strip().splitlines()
    assert stop.value.code == 2 and len(lines) == 1, lines
    assert _refused_as_typed(lines[0], option, text), lines[0]


def test_developer_script_refuses_numbers_nobody_typed(tmp_path):
    """``tools/calibration_worth.py`` (plain argparse: usage, then the error line)."""
    done = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "calibration_worth.py"), "--kits", "1_20",
         "--out", str(tmp_path / "out"), "--no-such-option"],
        capture_output=True, text=True, cwd=tmp_path, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert _refused_as_typed(done.stderr.strip().splitlines()[-1], "--kits", "1_20"), done.stderr
    assert not (tmp_path / "out").exists()


ARABIC_ONE = "\u0661"  # ١


@pytest.mark.parametrize(
    ("parse", "text"),
    [
        ("mearm.maker.learn_colours:parse_sample", f"red=1,2@{ARABIC_ONE}"),
        ("mearm.maker.learn_colours:parse_point", "1_0,2"),
        ("mearm.maker.learn_colours:parse_point", f"{FULLWIDTH},2"),
        ("mearm.tools.camera_accuracy:_numbers", "1_0"),
        ("mearm.tools.camera_accuracy:_numbers", "\uff12"),  # ２, within its range
    ],
)
def test_numbers_read_after_the_parser_are_plain_too(parse, text):
    """Options whose text is split after argparse (``--sample CLASS=U,V@I``,
    ``--work-area``, ``--heights``) read the same plain numbers: ``@١`` was image 1,
    ``1_0`` was 10."""
    module, name = parse.split(":")
    with pytest.raises((ValueError, MearmError)):
        getattr(importlib.import_module(module), name)(text)


def test_a_camera_index_is_ascii_digits():
    """``find-camera --camera ١`` was camera 1; it is now a path, which does not exist."""
    from mearm.maker.find_camera import _source

    assert _source("1") == 1
    with pytest.raises(MearmError, match="does not exist|no such"):
        _source(ARABIC_ONE)
