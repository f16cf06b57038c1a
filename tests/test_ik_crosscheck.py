"""Cross-validation: PD-PIJ (both modes), mink on MuJoCo and the closed form agree.

200 random reachable targets in the Table 3 box (SPEC §3), each solved from home.
"""

import mujoco
import numpy as np
import pytest

from mearm.exceptions import UnreachableTargetError
from mearm.ik import MinkSolver, PdPij
from mearm.ik.mink_solver import CouplingTask, mujoco_model
from mearm.kinematics import COUPLING, analytic_ik_deg

N_TARGETS = 200
SQRT_TOL_CM = np.sqrt(1e-3)  # 0.0316 cm: the paper's stop criterion, |e|² < 1e-3 cm²


@pytest.fixture(scope="module")
def targets(config):
    """Uniform in the box, kept when the closed form reaches them (fixed seed)."""
    rng = np.random.default_rng(2024)
    box = config.robot.target_box
    lo = np.array([box.x_cm.min, box.y_cm.min, box.z_cm.min])
    hi = np.array([box.x_cm.max, box.y_cm.max, box.z_cm.max])
    out = []
    while len(out) < N_TARGETS:
        t = rng.uniform(lo, hi)
        try:
            analytic_ik_deg(t, config.robot)
        except UnreachableTargetError:
            continue
        out.append(t)
    return np.array(out)


def make(kind, model, config, tolerance_cm2):
    controller = config.controller.updated(tolerance_cm2=tolerance_cm2)
    if kind == "mink":
        return MinkSolver(model, controller)
    return PdPij(model, controller.updated(mode=kind))


SOLVERS = ["paper", "coupled", "mink"]


@pytest.fixture(scope="module")
def loose(model, config, targets):
    """Every solver's result for every target at the paper's tolerance."""
    return {
        kind: [make(kind, model, config, 1e-3).solve(model.home_rad, t) for t in targets]
        for kind in SOLVERS
    }


@pytest.fixture(scope="module")
def tight(model, config, targets):
    """The same at |e|² < 1e-10 cm²."""
    return {
        kind: [make(kind, model, config, 1e-10).solve(model.home_rad, t) for t in targets]
        for kind in SOLVERS
    }


@pytest.mark.parametrize("kind", SOLVERS)
def test_all_reach_within_the_papers_tolerance(loose, kind):
    """PD-PIJ (both modes) and mink converge to within 0.0316 cm of every target."""
    errors = np.array([r.final_error_cm for r in loose[kind]])
    assert all(r.converged for r in loose[kind])
    assert errors.max() < SQRT_TOL_CM


def test_closed_form_reaches_every_target(model, config, targets):
    for t in targets:
        q = np.radians(analytic_ik_deg(t, config.robot))
        assert np.linalg.norm(model.fk_cm(q) - t) < 1e-9
        assert model.within_limits(q)


@pytest.mark.parametrize("kind", SOLVERS)
def test_tight_tolerance_joints_agree_with_the_closed_form(config, targets, tight, kind):
    """At |e|² < 1e-10 cm² every solver's joints match the closed form within 0.001°."""
    worst = 0.0
    for t, result in zip(targets, tight[kind], strict=True):
        assert result.converged
        diff = np.abs(result.q_deg - analytic_ik_deg(t, config.robot))
        worst = max(worst, diff.max())
    assert worst < 1e-3


@pytest.mark.parametrize("kind", SOLVERS)
def test_coupling_holds_in_every_pose(loose, tight, kind):
    """θ2 + θ3 + θ4 = 0 within 1e-9 rad in every solution and along every path."""
    for result in loose[kind] + tight[kind]:
        assert abs(result.q_rad[1:].sum()) < 1e-9
        assert np.abs(result.q_path_rad[:, 1:].sum(axis=1)).max() < 1e-9


@pytest.mark.parametrize("kind", SOLVERS)
def test_limits_hold_in_every_pose(model, loose, kind):
    for result in loose[kind]:
        assert np.all(result.q_path_rad >= model.lower_rad - 1e-12)
        assert np.all(result.q_path_rad <= model.upper_rad + 1e-12)


def test_mujoco_site_is_pinocchios_ee_frame(model):
    """The URDF in MuJoCo puts the ee site where Pinocchio puts the ee frame."""
    mj_model = mujoco_model(model)
    data = mujoco.MjData(mj_model)
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = COUPLING @ rng.uniform(model.lower_rad[:3], model.upper_rad[:3])
        data.qpos[:] = q
        mujoco.mj_kinematics(mj_model, data)
        np.testing.assert_allclose(data.site("ee").xpos * 100, model.fk_cm(q), atol=1e-10)


def test_mujoco_limits_are_the_models(model):
    mj_model = mujoco_model(model)
    np.testing.assert_allclose(mj_model.jnt_range[:, 0], model.lower_rad, atol=1e-12)
    np.testing.assert_allclose(mj_model.jnt_range[:, 1], model.upper_rad, atol=1e-12)


def test_coupling_task_error_and_jacobian(model):
    """e = θ2 + θ3 + θ4, J = [0, 1, 1, 1], checked by finite differences."""
    import mink

    mj_model = mujoco_model(model)
    task = CouplingTask(mj_model)
    q = np.array([1.0, 1.2, -2.0, 0.5])
    conf = mink.Configuration(mj_model, q)
    assert task.compute_error(conf) == pytest.approx([-0.3])
    J = task.compute_jacobian(conf)
    for i in range(4):
        dq = np.zeros(4)
        dq[i] = 1e-6
        conf.update(q + dq)
        fd = (task.compute_error(conf)[0] + 0.3) / 1e-6
        assert fd == pytest.approx(J[0, i], abs=1e-5)
