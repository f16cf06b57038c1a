"""Where ``mearm check-camera`` lays its points: each keeps room for a set-down's slip.

On the twin's perspective rig with its 12 objects (``configs/sim_mujoco_perspective.yaml``)
5 points stopped with the shoulder stalled: re-picking the object set down beside the red
bin, the open jaws came down on the bin's wall (the check planned its moves without the
collision model). 10 points set the object down 0.3 cm past the edge of the reach: the
next pick needed the elbow 0.07° past its limit, and every later point failed.

The 5-DOF arm's perspective rig (``configs/sim_5dof_mujoco_perspective.yaml``) found room
for 4 of 5 points: the grid's nodes spread over the whole view, most of it out of the
arm's reach. Spread over where it reaches, one point lay where the arm at home hid the
object from the camera.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.task.armcheck import SET_DOWN_SLIP_CM

NUMBER = r"[-+]?\d+\.\d+"
POINT = re.compile(
    rf"^point \d+: commanded \(\s*({NUMBER}),\s*({NUMBER})\) seen \(\s*({NUMBER}),\s*({NUMBER})\)",
    re.M,
)


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("config", "points"),
    [("sim_mujoco_perspective", 5), ("sim_mujoco_perspective", 10),
     ("sim_5dof_mujoco_perspective", 5)],
)  # fmt: skip
def test_every_point_is_measured_on_the_perspective_rigs(
    config: str, points: int, capsys: pytest.CaptureFixture[str]
) -> None:
    """Exit 0, every point measured, the object put back, and every set-down within the
    room the layout keeps around its point (along x and y)."""
    from mearm.tools.check_camera import main

    path = ROOT / "configs" / f"{config}.yaml"
    code = main(["--config", str(path), "--points", str(points)])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert err == ""
    found = np.array(POINT.findall(out), dtype=float).reshape(-1, 4)
    assert len(found) == points, out
    slip = np.abs(found[:, 2:] - found[:, :2])
    assert np.all(slip <= SET_DOWN_SLIP_CM), out


@pytest.mark.heavy
def test_an_object_left_out_of_reach_stops_the_check(capsys: pytest.CaptureFixture[str]) -> None:
    """The paper arm's kit twin, its servos left uncalibrated (its config calibrates them at
    start: told not to), sets the object down 1.02 cm short of point 2, where the next pick
    needs the elbow past its limit: the check stops at point 3 and says where the object
    lies (exit 1), rather than failing every later point in turn and then the put-back."""
    from mearm.tools.check_camera import main

    kits = str(ROOT / "configs" / "sim_mujoco_kits.yaml")
    never = ["--set", "servo.calibrate_at_start=never"]
    code = main(["--config", kits, *never, "--points", "9"])
    out, err = capsys.readouterr()
    assert code == 1, out
    assert re.fullmatch(
        rf"mearm check-camera: check incomplete: point 3: the object at \({NUMBER}, {NUMBER}\) "
        r"cm cannot be taken up: approach to .* needs elbow = .*\n",
        err,
    ), err
    assert re.findall(r"^point (\d+):", out, re.M) == ["1", "2", "3"], out


@pytest.mark.heavy
def test_a_point_the_batch_solve_does_not_reach_is_one_the_plan_refuses() -> None:
    """The layout plans a lattice point only where one batch solve reaches its pick and the
    point above it (``may_take_up_at``): on the 5-DOF arm each point it skips cost the
    solver's whole recovery before (37 ms), and each would have been refused, so the
    points chosen are the same (`mearm check-camera` printed the same, 2026-12-01)."""
    from mearm.sim.table_collision import collision_model
    from mearm.task.armcheck import _Arm
    from mearm.task.plan import Planner

    config = load_config("sim_5dof")
    model = ArmModel(config.arm)
    planner = Planner(config, model, collision_model(config, model, clearance_cm=0.0))
    arm = _Arm(config, planner, None, config.task.classes[0], [])  # type: ignore[arg-type]
    xy = np.array([(x, y) for x in range(-36, 37, 6) for y in range(4, 61, 6)], dtype=float)
    worth = arm.may_take_up_at(xy)
    assert 10 <= worth.sum() <= len(xy) - 10, worth.sum()  # a test of both answers
    # where a skipped point could be wrong: next to one the batch reaches (the reach's edge)
    skipped, reached = xy[~worth], xy[worth]
    gap = np.linalg.norm(skipped[:, None, :] - reached[None, :, :], axis=2).min(axis=1)
    edge = skipped[gap <= 6.0]
    assert len(edge) >= 10, len(edge)
    assert not [tuple(at) for at in edge if arm.takes_up_at(at)]
    assert any(arm.takes_up_at(at) for at in reached)


@pytest.mark.heavy
def test_a_table_without_room_for_the_points_says_what_makes_room(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """The MeArm v1's perspective twin with its six objects has room for no point: the
    check does not move, and says to leave only the object it takes, in a ``--set`` that
    runs as printed once X and Y are filled in. With that one object, 12 points do not fit
    either: it names how many do, and that many are each measured."""
    from mearm.tools.check_camera import main

    v1 = str(ROOT / "configs" / "sim_mearm_v1_mujoco_perspective.yaml")
    assert main(["--config", v1]) == 1
    out, err = capsys.readouterr()
    assert out == ""
    hint = re.fullmatch(
        r"mearm check-camera: check not run: found room for 0 of 4 check points .*: "
        r"leave only the object taken on the simulated table: --set '(task\.scene=.*)'\n",
        err,
    )
    assert hint is not None, err
    assert "--points" not in err  # fewer than the least allowed fit: no use asking for fewer
    one = ["--set", hint[1].replace("X", "8.7").replace("Y", "15.07")]  # a red of the scene

    assert main(["--config", v1, *one, "--points", "12"]) == 1
    out, err = capsys.readouterr()
    room = re.fullmatch(
        r"mearm check-camera: check not run: found room for (\d+) of 12 check points .*: "
        r"ask for --points (\d+)\n",
        err,
    )
    assert room is not None and room[1] == room[2], err
    assert main(["--config", v1, *one, "--points", room[1]]) == 0
    out, err = capsys.readouterr()
    assert err == ""
    assert len(POINT.findall(out)) == int(room[1]), out
