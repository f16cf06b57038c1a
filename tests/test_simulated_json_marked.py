"""``quantization --json`` and ``virtual-uno-pulses --json`` say their figures are simulated.

Their text said so (``[cm, simulated]``; ``simulated: the firmware in simavr``) but their
JSON did not: a file read later, away from the terminal, passed for a measured arm's or
board's. camera-accuracy's JSON has carried ``"simulated": true`` all along.
"""

from __future__ import annotations

import json

from badinput import run_in_process

from mearm.tools import virtual_uno_pulses


def test_quantization_json_is_marked_simulated():
    out = run_in_process(["quantization", "--poses", "20", "--json"], within_s=30)
    assert out.code == 0, out.stderr
    record = json.loads(out.stdout)
    assert record["simulated"] is True
    assert set(record["modes"]) == {"degree", "microsecond", "none"}


def test_virtual_uno_pulses_json_is_marked_simulated(tmp_path, monkeypatch, capsys):
    """The file written, its figures beside the mark (the board's pulses stubbed: the
    measurement itself is tests/test_virtual_uno.py's)."""
    monkeypatch.setattr(virtual_uno_pulses, "pulse_errors", lambda n, seed: [0.0, 0.5] * n)
    path = tmp_path / "pulses.json"
    assert virtual_uno_pulses.main(["--commands", "3", "--json", str(path)]) == 0
    record = json.loads(path.read_text())
    assert record == {
        "simulated": True, "pulses": 6, "median_us": 0.25, "mean_us": 0.25, "max_us": 0.5,
        "within_1us": 1.0,
    }  # fmt: skip
    assert "simulated" in capsys.readouterr().out  # as the text said already
