"""A sort by hue bands, without a claw camera, leaves the table-colour and marker code unloaded."""

import json
import os
import subprocess
import sys

import pytest
from conftest import ROOT

#: Modules only a detector that knows the table's colour (``vision.reference_bgr``) or a
#: sort that watches the claw's marker uses.
ONLY_FOR_OTHER_RUNS = (
    "mearm.vision.on_table",
    "mearm.vision.teaching",
    "mearm.vision.claw_marker",
    "mearm.vision.aruco",
)


def _run_whole(module: str, argv: list[str], then: str) -> list[str]:
    """The lines printed by ``python -m module argv`` run whole in a fresh interpreter
    (it must exit 0), then by the code ``then`` run after it in the same interpreter."""
    code = (
        "import runpy, sys\n"
        f"sys.argv = {[module, *argv]!r}\n"
        "try:\n"
        f"    runpy.run_module({module!r}, run_name='__main__', alter_sys=True)\n"
        "except SystemExit as exc:\n"
        "    assert exc.code in (0, None), exc.code\n"
        f"{then}\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    return out.stdout.strip().splitlines()


@pytest.mark.heavy
def test_the_reference_sort_imports_no_table_colour_or_marker_code():
    """``mearm sort --config sim``, run whole, imports none of :data:`ONLY_FOR_OTHER_RUNS`."""
    printed = _run_whole(
        "mearm.sort",
        ["--config", "sim", "--quiet"],
        f"print(sorted(n for n in {ONLY_FOR_OTHER_RUNS!r} if n in sys.modules))",
    )
    assert printed[-1] == "[]", printed[-20:]


def test_detecting_in_a_picture_imports_no_arm_model():
    """``mearm detect IMAGE`` finds objects without the arm's Pinocchio model: the work
    area needs only a bin's size from the kinematics, and ``mearm.kinematics`` imports its
    model (Pinocchio and coal) on first use. It did at start-up, a third of the command's
    CPU. The lazy name still gives the model."""
    picture = ROOT / "docs" / "images" / "detect_sim_4colours.png"
    *printed, loaded, model = _run_whole(
        "mearm.detect",
        ["--config", "sim_4colours", str(picture), "--json"],
        "print(sorted(m for m in ('pinocchio', 'coal', 'mearm.kinematics.model') "
        "if m in sys.modules))\n"
        "from mearm.kinematics import ArmModel\n"
        "print(ArmModel.__module__)",
    )
    assert json.loads(printed[-1]), printed  # the picture's objects, found
    assert (loaded, model) == ("[]", "mearm.kinematics.model")
