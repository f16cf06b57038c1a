"""``mearm servo-steps``: an output that is one of the run's inputs is refused, --force or not.

``servo-steps --config mycfg.yaml --csv mycfg.yaml --force`` replaced the user's config
with the CSV (``wrote mycfg.yaml``, exit 0, no backup): --csv, --out and --before were
checked against each other only.
"""

from __future__ import annotations

import contextlib
import shutil

import pytest
from badinput import check_bad_input
from conftest import ROOT


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (
            ("--config", "mycfg.yaml", "--csv", "mycfg.yaml", "--force"),
            "--csv mycfg.yaml: is the --config file ",
        ),
        (
            ("--config", "./mycfg.yaml", "--out", "mycfg.png", "--csv", "mycfg.yaml"),
            "--csv mycfg.yaml: is the --config file ",
        ),
        (
            ("--config", "mycfg.yaml", "--before", "old.csv", "--out", "p.png", "--force"),
            None,  # a different file: this case is the others' control, refused elsewhere
        ),
    ],
)
def test_an_output_over_an_input_is_refused_even_with_force(tmp_path, args, says):
    """Exit 2, one line naming the flag and the input it would replace; the config kept."""
    shutil.copy(ROOT / "configs" / "sim_mujoco.yaml", tmp_path / "mycfg.yaml")
    (tmp_path / "old.csv").write_text("joint,step_deg,t_s,angle_deg\n")  # no rows: refused
    with contextlib.chdir(tmp_path):  # the file names are relative, as a user types them
        out = check_bad_input(["servo-steps", "--degrees", "10", *args], keep=[tmp_path])
    assert (says or "--before old.csv: no responses in it") in out.line
    assert says is None or "mycfg.yaml, one of this run's inputs" in out.line
