"""A servo over a combination of joints narrows what plans keep to: no pose it cannot take.

The MeArm v1's elbow servo turns shoulder + elbow (the forearm's angle to the table) and
its 544..2400 µs hold that within ±75°, inside the box of the joints' own limits. The
levelled wrist follows −(shoulder + elbow), so in the arm the plans are solved on, its
limits are what the servo reaches (``ArmDescription.within_servos``): the chain, the closed form
and every solver on it keep to them. A pick at (0, 16) cm needs the forearm at −76.3°: it
was solved, then refused by the check before sending; now the solve refuses it, naming
the servo.
"""

import pytest

from mearm.config import load_config
from mearm.hardware.mapping import ServoMap
from mearm.kinematics import ArmModel
from mearm.task.plan import Planner
from mearm.task.route import Route

#: Picks on the table near the arm's inner edge and around it [cm]: (0, 16) and (5, 15)
#: need the forearm past −75°; the others are within what the elbow servo reaches.
PICKS_CM = [(0.0, 16.0), (5.0, 15.0), (-4.0, 16.5), (0.0, 17.0), (6.0, 16.5), (-8.7, 15.07)]


def _planner(*overrides: str) -> tuple[Planner, ArmModel]:
    config = load_config("sim_mearm_v1", list(overrides))
    model = ArmModel(config.arm)
    return Planner(config, model), model


def test_wrist_limits_are_what_the_elbow_servo_reaches():
    """The wrist's limits: −(shoulder + elbow) over the elbow servo's values, said why."""
    arm = load_config("sim_mearm_v1").arm
    lo, hi = arm.joints[2].servo.value_range()
    own = arm.joint_limits()["wrist"]
    assert (own.min, own.max) == (-130, 140)  # the box of shoulder and elbow alone
    bounded = arm.within_servos()
    wrist = bounded.joint_limits()["wrist"]
    assert (wrist.min, wrist.max) == pytest.approx((-hi, -lo))
    assert bounded.joint_limits()["elbow"] == arm.joint_limits()["elbow"]
    reason = bounded.limits_reason("wrist")
    assert (
        reason is not None
        and "elbow's servo (shoulder + elbow) reaches in its pulse range" in reason
    )
    assert arm.limits_reason("wrist") is None  # the arm's own limits: the coupling's box
    # the paper's arm: every servo turns its own joint, nothing narrows
    paper = load_config("sim_paper_arm").arm
    assert paper.within_servos() is paper


@pytest.mark.parametrize("closed_form", ["planar_wrist", "null"])
def test_no_plan_the_check_before_sending_refuses(closed_form):
    """Every pick is planned inside the servo's range, or refused by the solve naming it.

    With the arm's closed form and without it (PD-PIJ's own updates and its multi-start
    recovery): no route is solved and then refused by the check before sending.
    """
    planner, model = _planner(f"arm.closed_form={closed_form}")
    servos = ServoMap.from_arm(planner.config.arm)
    chain = model.chain
    red = planner.config.task.classes[0]
    planned = []
    for x, y in PICKS_CM:
        route = planner.plan(
            Route("", "red", "pick", 1, planner.pick_target(red, x, y)), model.home
        )
        assert "before sending" not in (route.failure or "")
        if route.planned:
            q = route.plan.q_path
            assert (
                servos.outside_pulse_range(chain.actuated_of(q) / chain.scale[chain.actuated_index])
                is None
            )
        planned.append(route.planned)
    assert planned == [False, False, True, True, True, True]


def test_out_of_the_servos_reach_is_refused_before_planning():
    """The reach survey (the scene's and the start-up check's) says so, and the refusal why."""
    planner, model = _planner()
    red = planner.config.task.classes[0]
    targets = [planner.pick_target(red, x, y) for x, y in PICKS_CM]
    assert planner.reaches(targets).tolist() == [False, False, True, True, True, True]
    route = planner.plan(Route("", "red", "pick", 1, targets[0]), model.home)
    assert route.failure_kind == "limit"
    assert "elbow's servo (shoulder + elbow)" in route.failure
    # the servo's ends as a reader writes them (they are ±75.0002° at 544 and 2400 µs)
    assert "outside its limits [-75, 75] deg" in route.failure
