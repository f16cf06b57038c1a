"""Every command reads numbers alike: plain ASCII decimals, no ``1_20``, no other scripts.

Python's ``float`` and ``int`` read ``1_20``, Arabic-Indic ``١٢٠`` and fullwidth ``１２０``
as 120. ``mearm fk`` and ``mearm ik`` refused them while every other command's numeric
options took them; the one check now lives in :func:`mearm.cli.check_plain_number`, which
each of mearm.cli's numeric argparse types calls.
"""

from __future__ import annotations

import argparse

import pytest
from badinput import check_bad_input

from mearm.cli import float_list, positive_number, seed_value, worker_count

#: Text Python reads as a number that nobody typed as one.
NOT_PLAIN = ["1_20", "\u0661\u0662\u0660", "\uff11\uff12\uff10", "12\u0660"]

TYPES = {
    "float_list": (float_list(None, "--joints"), "plain decimal numbers"),
    "positive_number": (positive_number(0.0, 1e6), "a plain decimal number"),
    "seed_value": (seed_value, "a seed is a plain integer"),
    "worker_count": (worker_count, "a number of workers is a plain integer"),
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
