"""``mearm ik-stalls --no-recover``: a table says what ran, PD-PIJ without the recovery.

``--no-recover`` runs PD-PIJ whatever solver the config names; a config whose
``controller.solver`` is mink had its table labelled ``(mink, no recovery)``: a solver
that did not run, and that has no recovery to go without.
"""

from __future__ import annotations

from badinput import run_in_process
from conftest import ROOT


def test_a_mink_configs_table_names_pdpij_without_the_recovery(tmp_path):
    text = (ROOT / "configs" / "sim.yaml").read_text()
    assert "  solver: pdpij" in text
    mink = tmp_path / "mink.yaml"
    mink.write_text(text.replace("  solver: pdpij", "  solver: mink", 1))
    r = run_in_process(["ik-stalls", "--targets", "3", "--no-recover", mink, "sim"], within_s=10)
    assert r.code == 0, r.stderr
    labels = [line for line in r.stdout.splitlines() if not line.startswith(" ")]
    assert labels == [
        "mink.yaml (pdpij, no recovery, in place of the config's mink)",
        "sim (pdpij, no recovery)",
    ]


def test_without_no_recover_the_configs_solver_is_named(tmp_path):
    text = (ROOT / "configs" / "sim.yaml").read_text()
    mink = tmp_path / "mink.yaml"
    mink.write_text(text.replace("  solver: pdpij", "  solver: mink", 1))
    r = run_in_process(["ik-stalls", "--targets", "3", mink], within_s=10)
    assert r.code == 0, r.stderr
    assert r.stdout.splitlines()[0] == "mink.yaml (mink)"
