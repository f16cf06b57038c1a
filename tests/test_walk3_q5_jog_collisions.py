"""``mearm jog`` checks every path against the table and the bins before it is sent.

The maker's path says every jog move "is checked as the sort's are": the sort's planner
checks each path with the collision model, and a path into the table or a bin is never
sent. A jog that sent one drove the MeArm v1's claw into the table (a shoulder step
down: the simulator's "the arm ran into something") or its finger 1.3 cm into the red
bin's wall (x steps at the pick height: no simulator noticed). In-process on the ``sim``
backend, as ``test_maker_more_jog`` drives the jogger.
"""

from __future__ import annotations

import io

import pytest
from test_maker_calibrate import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.maker.calibrate_servos import open_arm_bus
from mearm.maker.jog import CARTESIAN_STEPS_CM, JOINT_STEPS, Jogger, Refused
from mearm.sim.table_collision import collision_model

MEARM = ROOT / "configs" / "sim_mearm_v1.yaml"
CONFIG = load_config(MEARM)
#: The sort's collision model of the MeArm v1's table: what a sent pose must keep clear of.
TABLE = collision_model(CONFIG, ArmModel(CONFIG.arm), clearance_cm=CONFIG.task.clearance_cm)


def _stepping_5_cm(bus, along_z: int) -> tuple[Jogger, io.StringIO]:  # noqa: ANN001
    """A jogger from home in 5 cm tool steps, two of them taken along ``along_z`` z."""
    out = io.StringIO()
    jogger = Jogger(CONFIG, bus, out)
    jogger.executor.home_pose()
    jogger.step_index = CARTESIAN_STEPS_CM.index(5.0)
    for _ in range(2):
        jogger.move_tcp(2, along_z)
    return jogger, out


def test_a_shoulder_step_into_the_table_is_refused_and_nothing_sent():
    """The shoulder down by 10° from home: at 20° the gripper's servo is 0.001 cm above the
    table, and the step to 10° would put it 0.16 cm into it (at 19.3°). It is refused,
    naming the table, and nothing is sent; a smaller step back up goes."""
    with open_arm_bus(CONFIG) as bus:
        jogger = Jogger(CONFIG, bus, io.StringIO())
        jogger.executor.home_pose()
        jogger.step_index = JOINT_STEPS.index(10.0)
        jogger.selected = 1  # the shoulder
        for _ in range(7):  # 90° → 20°: clear all the way
            jogger.move_joint(-1)
        assert jogger.chain.named(jogger.executor.q_now())["shoulder"] == pytest.approx(20.0)
        sent = bus.state
        with pytest.raises(Refused, match=r"collision: gripper_servo touches table"):
            jogger.move_joint(-1)
        assert bus.state == sent
        jogger.move_joint(+1)
        assert jogger.chain.named(jogger.executor.q_now())["shoulder"] == pytest.approx(30.0)


def test_tcp_steps_toward_a_bin_stop_short_of_its_wall():
    """The TCP 5 cm down from home (z 8.5 cm, then 3.5 cm: the second stops on the elbow
    servo's end), then 5 cm steps along -x toward the red bin at (-15, 16): every pose
    sent keeps the clearance from its wall; the step that would reach it stops short and
    says it was the bin."""
    with open_arm_bus(CONFIG) as bus:
        jogger, out = _stepping_5_cm(bus, along_z=-1)
        for _ in range(4):
            try:
                jogger.move_tcp(0, -1)
            except Refused:
                break
            q = jogger.executor.q_now()
            assert TABLE.first_contact(q[None, :]) is None, jogger.chain.named(q)
        assert "along -x: collision: " in out.getvalue()
        assert "bin_red_wall" in out.getvalue()


def test_the_pages_tool_step_example_is_what_the_jog_says():
    """docs/maker-path.md step 6 quotes the MeArm v1's second 5 cm ``Z`` from home; the
    jog prints that line, word for word."""
    page = " ".join((ROOT / "docs" / "maker-path.md").read_text(encoding="utf-8").split())
    with open_arm_bus(CONFIG) as bus:
        _, out = _stepping_5_cm(bus, along_z=+1)
    said = out.getvalue().strip().splitlines()[-1]
    assert said.startswith("stopped after 0.57 of the 5 cm step along +z: "), said
    assert f"`{said}`" in page
