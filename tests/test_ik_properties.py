"""Properties of PD-PIJ for any target in the box and any start within the limits."""

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from mearm.config import Config
from mearm.exceptions import UnreachableTargetError
from mearm.ik import STATUSES, PdPij
from mearm.kinematics import ArmModel, check_target, closed_form_for

CONFIG = Config()
MODEL = ArmModel(CONFIG.arm)
CLOSED_FORM = closed_form_for(CONFIG.arm)
BOX = CONFIG.arm.target_box
LOWER, UPPER = MODEL.lower, MODEL.upper
SOLVERS = {
    (mode, damping, safeguard): PdPij(
        MODEL, CONFIG.controller.updated(mode=mode, damping=damping, safeguard=safeguard)
    )
    for mode in ("paper", "coupled")
    for damping in (0.0, 3.0)
    for safeguard in (True, False)
}


def joint(i: int) -> st.SearchStrategy[float]:
    """Angles of actuated joint i, its limits drawn often (hypothesis would rarely)."""
    lo, hi = float(LOWER[i]), float(UPPER[i])
    return st.one_of(st.sampled_from([lo, hi]), st.floats(lo, hi))


targets = st.tuples(
    st.floats(BOX.x_cm.min, BOX.x_cm.max),
    st.floats(BOX.y_cm.min, BOX.y_cm.max),
    st.floats(BOX.z_cm.min, BOX.z_cm.max),
)
starts = st.tuples(joint(0), joint(1), joint(2)).map(MODEL.chain.full)
settings_ = settings(max_examples=100, deadline=None)


def solve_or_unreachable(solver, q0, target):
    """The result, or None when the target is out of reach (which check_target agrees on)."""
    try:
        check_target(target, CONFIG.arm, CLOSED_FORM)
        reachable = True
    except UnreachableTargetError:
        reachable = False
    if not reachable:
        with pytest.raises(UnreachableTargetError):
            solver.solve(target, q0)
        return None
    return solver.solve(target, q0)


def assert_safe(result):
    assert result.status in STATUSES
    for array in (result.q_path, result.ee_path_cm, result.error_path_cm):
        assert np.all(np.isfinite(array))
    assert np.all(result.q_path >= LOWER) and np.all(result.q_path <= UPPER)
    assert np.abs(result.q_path[:, 1:].sum(axis=1)).max() < 1e-9
    assert result.iterations <= CONFIG.controller.max_iterations


@settings_
@given(
    target=targets,
    q0=starts,
    mode=st.sampled_from(["paper", "coupled"]),
    damping=st.sampled_from([0.0, 3.0]),
)
# found by CI: a start with the TCP 4.5 cm above the table (elbow at -160°) and the box's
# top corner; every joint-space move to a solution dips below the start's height
@example(
    target=(0.0, 20.0, 60.0), q0=np.radians([20.0, 30.0, -160.0, 130.0]), mode="paper",
    damping=0.0,
)  # fmt: skip
def test_returns_a_status_within_limits_with_error_never_rising(target, q0, mode, damping):
    """Any target in the box, any start within limits: no NaN, no limit left, and
    converged — or, from a start low over the table, stalled because every joint-space
    move to a solution would take the TCP lower than it already is (the recovery refuses
    those, and says so); along PD-PIJ's own path (with the safeguard) |e| never rises, and
    a recovery's joint-space move takes every actuated joint monotonically along each of
    its legs (straight to the solution, or through home: the joint may turn there)."""
    result = solve_or_unreachable(SOLVERS[(mode, damping, True)], q0, target)
    if result is None:
        return
    assert_safe(result)
    if not result.converged:
        assert result.failure is not None, (target, result.status)
        assert "would take the TCP below" in result.failure.message, result.failure.message
        return
    assert result.converged, (target, result.status, result.final_error_cm)
    assert result.final_error_cm**2 < CONFIG.controller.tolerance_cm2
    if result.method == "direct":
        assert np.all(np.diff(result.error_path_cm) <= 0.0)
    else:  # a recovery's move: straight, or through home (and one joint first or last)
        steps = np.diff(MODEL.chain.actuated_of(result.q_path), axis=0)
        for joint in steps.T:  # each leg monotonic: at most two turns over three legs
            signs = np.sign(joint[np.abs(joint) > 1e-12])
            assert np.count_nonzero(np.diff(signs)) <= 2, joint


@settings_
@given(target=targets, q0=starts, mode=st.sampled_from(["paper", "coupled"]))
@pytest.mark.heavy
def test_bare_paper_algorithm_is_still_safe(target, q0, mode):
    """Without the safeguard the error may rise, but limits, coupling and finiteness hold."""
    result = solve_or_unreachable(SOLVERS[(mode, 0.0, False)], q0, target)
    if result is not None:
        assert_safe(result)


@settings_
@given(target=targets, mode=st.sampled_from(["paper", "coupled"]))
@pytest.mark.heavy
def test_from_home_every_reachable_target_converges(target, mode):
    """From home (where every route of the demo starts) the solver always gets there."""
    result = solve_or_unreachable(SOLVERS[(mode, 0.0, True)], MODEL.home, target)
    if result is not None:
        assert result.converged, (target, result.status, result.final_error_cm)
