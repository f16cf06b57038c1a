"""``mearm ik-stalls``: every config is loaded, and its solver built, before any is measured.

``ik-stalls sim nonexist`` printed sim's whole table and only then stopped on
``nonexist`` (exit 2): a run of many configs could measure for an hour and be refused on
the last name, the tables before it printed as if the run had gone well.
"""

from __future__ import annotations

from badinput import check_bad_input


def test_a_bad_config_named_last_is_refused_before_any_measurement(tmp_path):
    out = check_bad_input(["ik-stalls", "--targets", "5", "sim", tmp_path / "nonexist.yaml"])
    assert "nonexist.yaml" in out.line and "not found" in out.line
    assert out.stdout == ""  # no table of sim's printed first
