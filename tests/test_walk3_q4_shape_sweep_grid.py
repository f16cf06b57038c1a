"""``mearm shape-sweep``: a camera that does not see the sweep's grid is refused.

The grid lies where the paper's camera looks. Under the desk arms' cameras, or a nearer
one, its objects were drawn past the frame's edge and the sweep reported them missed
("0 of 24 ... found", exit 1), as if the detector could not tell the shapes apart.
"""

from __future__ import annotations

import pytest

from mearm.cli import run
from mearm.tools import shape_sweep


@pytest.mark.parametrize(
    "config",
    [
        ["--config", "sim_5dof"],  # its camera looks at the desk arm's nearer table
        ["--set", "calibration.homography=[[0.05,0,-20.5],[0,-0.05,59],[0,0,1]]"],  # nearer
    ],
)
def test_a_grid_past_the_frame_is_refused(
    capsys: pytest.CaptureFixture[str], config: list[str]
) -> None:
    """Exit 2, one line saying the grid reaches past the frame, no table printed."""
    with pytest.raises(SystemExit) as info:
        run(shape_sweep.main, [*config, "--objects", "24"])
    out, err = capsys.readouterr()
    assert info.value.code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1
    assert "reaches past the 640x480 px frame" in err


def test_the_largest_objects_on_the_papers_camera_still_fit() -> None:
    """The largest size allowed (4 cm) under configs/sim.yaml's camera is not refused."""
    from mearm.config import load_config

    shape_sweep.check_grid_in_frame(load_config("sim"), 4.0)
