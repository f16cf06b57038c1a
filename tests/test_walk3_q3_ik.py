"""Doc walk 3 (q3): the IK page and the paper page against what the code does."""

import json

import pytest

from mearm.ik import PdPij
from mearm.kinematics import ArmModel

#: The paper's first pick (M1) from home: PD-PIJ needs 62 updates in ``coupled`` mode.
M1_PICK_CM = (-10.99, 49.70, 12.76)


@pytest.mark.parametrize("cap", [5, 40])
def test_capped_recovery_names_the_cap_not_the_floor(config, cap):
    """With ``controller.max_iterations`` below what the route needs, PD-PIJ stops at
    the cap and the recovery's joint-space move (paced like the PD loop) cannot finish
    within it either. The failure says the cap was reached; it used to add that every
    move "would take the TCP below z = 10 cm", though the straight move to the solution
    stays far above the table."""
    model = ArmModel(config.arm)
    result = PdPij(model, config.controller.updated(max_iterations=cap)).solve(
        M1_PICK_CM, model.home
    )
    assert not result.converged and result.status == "max_iterations"
    message = result.failure.message
    assert message.startswith(f"the solver reached its iteration cap ({cap}) "), message
    assert "below z" not in message, message
    # with the default cap the same solve converges, on a path above the box's bottom
    full = PdPij(model, config.controller).solve(M1_PICK_CM, model.home)
    assert full.converged
    assert full.ee_path_cm[:, 2].min() >= config.arm.target_box.z_cm.min


def test_reproduce_paper_labels_its_figures_simulated(capsys):
    """The demo's table sits beside the paper's figures from its real arm: its header
    says the routes ran on simulated kinematics."""
    from mearm.tools.reproduce_paper import main  # noqa: PLC0415

    assert main(["--mode", "coupled"]) == 0
    header = capsys.readouterr().out.splitlines()[0]
    assert header.startswith("PD-PIJ on simulated kinematics, coupled mode: "), header


def test_fk_json_prints_no_negative_zero(capsys):
    """The 5-DOF arm reaching straight out along +y: its approach axis is (0, 1, 0), a
    cosine of 90° away from zero either way; the JSON prints 0.0, never -0.0."""
    from mearm.fk import main  # noqa: PLC0415

    assert main(["--config", "sim_5dof", "--joints", "90,90,-90,0,0", "--json"]) == 0
    out = capsys.readouterr().out
    assert "-0.0," not in out and "-0.0]" not in out, out
    assert json.loads(out)["approach"] == [0.0, 1.0, 0.0]


@pytest.mark.parametrize(
    ("argv", "why"),
    [
        (["--config", "sim_mearm_v1", "--target", "0,13,3"],
         "failure (limit): the solution cannot be sent: "),
        (["--config", "sim", "--target", "10,40,20", "--set", "controller.max_iterations=3"],
         "failure (stalled): the solver reached its iteration cap (3) "),
    ],
)  # fmt: skip
def test_ik_that_did_not_do_its_job_says_why_last(argv, why, capsys) -> None:
    """Exit 1: its last line (stderr) says why; it ended on the TCP's coordinates, the
    reason three lines up (a safety walk, 2026-12-06)."""
    from mearm.ik.__main__ import main  # noqa: PLC0415

    assert main(argv) == 1
    out, err = capsys.readouterr()
    assert out.splitlines()[-1].startswith("ee = (")
    [line] = err.splitlines()
    assert line.split(": ", 1)[1].startswith(why), line
