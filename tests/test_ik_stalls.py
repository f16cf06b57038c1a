"""mearm ik-stalls keeps to what the servos can take (the MeArm v1's elbow servo).

The v1's elbow servo turns shoulder + elbow, and its pulse range is narrower than the two
joints' limits: about a quarter of the poses within the limits are ones it cannot be sent
to. The measurement draws targets and starts only from poses every servo can take, and
counts a solution past a servo's pulse range as a violation, as the sort planner would
refuse it.
"""

from __future__ import annotations

import numpy as np
import pytest
from badinput import run_in_process

from mearm.config import load_config
from mearm.hardware.mapping import ServoMap
from mearm.ik import IKTarget, make_solver
from mearm.kinematics import ArmModel
from mearm.tools.ik_stalls import draw_start, draw_target, sendable, violates

#: A v1 target in its box whose only pose puts shoulder + elbow past the elbow servo's
#: range (tests/test_kinematics_truth.py: PAST_SERVO).
PAST_SERVO = (0.0, 0.2685, 19.5068)


@pytest.fixture(scope="module")
def v1():
    config = load_config("sim_mearm_v1")
    return config, ArmModel(config.arm), ServoMap.from_arm(config.arm)


def test_targets_and_starts_are_poses_the_servos_can_take(v1):
    _, model, servos = v1
    chain = model.chain
    rng = np.random.default_rng(0)
    raw = rng.uniform(chain.actuated_lower, chain.actuated_upper, (100, chain.m))
    assert sum(not sendable(servos, chain, q) for q in raw) > 10  # a filter with work to do
    rng = np.random.default_rng(0)
    for _ in range(100):
        q, _target = draw_target(rng, model, servos)
        assert sendable(servos, chain, chain.actuated_of(q))
        for p_edge in (0.0, 0.5):
            start = draw_start(rng, model, servos, p_edge)
            assert sendable(servos, chain, chain.actuated_of(start))


def test_a_solution_past_a_servos_range_counts_as_a_violation(v1):
    config, model, servos = v1
    solver = make_solver(model, config.controller)
    past = solver.solve(IKTarget(PAST_SERVO), model.home)
    assert past.converged  # within the joint limits all the way: only the servo objects
    assert violates(past, model.chain, servos)
    _, target = draw_target(np.random.default_rng(0), model, servos)
    fine = solver.solve(target, model.home)
    assert fine.converged and not violates(fine, model.chain, servos)


def test_the_command_on_the_v1_finds_no_violation():
    """Without the servo check on the targets, a quarter of them could only be reached
    past the elbow servo's range, and each would count as a violation (exit 1)."""
    r = run_in_process(["ik-stalls", "--targets", "20", "sim_mearm_v1"], within_s=10)
    assert r.code == 0, r.stdout + r.stderr
    assert r.stdout.count("limit violations 0") == 3
