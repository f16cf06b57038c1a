"""Cross-validation for every reference arm: FK by Pinocchio, the DH product and yourdfpy;
Jacobians by finite differences; PD-PIJ, mink on MuJoCo and the closed form (where the
arm has one) reach the same joints.

Arms: the paper's (default config), the MeArm v1 and the 5-DOF desk arm (configs), and a
test-defined cylindrical arm with two prismatic joints and a passive joint coupled to
the base.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from built_once import computed_once
from conftest import yourdfpy_urdf

import mearm.ik  # MinkSolver on first use: mink costs each worker's collection 0.3 s
from mearm.config import ArmDescription, Config, load_config
from mearm.exceptions import TargetOutsideBoxError, UnreachableTargetError
from mearm.ik import IKTarget, PdPij
from mearm.kinematics import ArmModel, check_in_box, closed_form_for, dh_fk, jaw_joint_names

ROOT = Path(__file__).resolve().parent.parent
SQRT_TOL_CM = np.sqrt(1e-3)  # 0.0316 cm: the paper's stop criterion, |e|² < 1e-3 cm²


def _servo(channel: int) -> dict:
    return {"channel": channel, "zero_us": 1500.0, "us_per_unit": 5.0}


def cylinder_arm() -> ArmDescription:
    """A test arm: base yaw, a vertical lift and a radial slide (both prismatic), and a
    passive tool joint turning against the base (tool = 30° − base), TCP off its axis."""
    return ArmDescription.model_validate(
        {
            "name": "cylinder_test",
            "joints": [
                {
                    "name": "yaw",
                    "dh": {"d_cm": 8.0},
                    "limits": {"min": -60.0, "max": 60.0},
                    "home": 0.0,
                    "servo": _servo(0),
                },
                {
                    "name": "lift",
                    "type": "prismatic",
                    "dh": {"alpha_deg": -90.0, "d_cm": 2.0},
                    "limits": {"min": 0.0, "max": 20.0},
                    "home": 10.0,
                    "servo": _servo(1),
                },
                {
                    "name": "reach",
                    "type": "prismatic",
                    "dh": {"d_cm": 10.0, "alpha_deg": 90.0},
                    "limits": {"min": 0.0, "max": 15.0},
                    "home": 5.0,
                    "servo": _servo(2),
                },
                {
                    "name": "tool",
                    "dh": {"a_cm": 1.0},
                    "coupling": {"terms": {"yaw": -1.0}, "offset": 30.0},
                },
            ],
            "tool": {
                "tcp_cm": [2.0, 0.0, 1.0],
                "gripper": {
                    "servo": {"channel": 4, "zero_us": 2200.0, "direction": -1,
                              "us_per_unit": 300.0},
                    "open_cm": 4.0,
                    "closed_cm": 1.0,
                },
            },
            "target_box": {
                "x_cm": {"min": -60, "max": 60},
                "y_cm": {"min": -60, "max": 60},
                "z_cm": {"min": -60, "max": 60},
            },
        }
    )  # fmt: skip


def _arms() -> dict[str, ArmDescription]:
    return {
        "paper": Config().arm,
        "mearm_v1": load_config(ROOT / "configs" / "sim_mearm_v1.yaml").arm,
        "5dof": load_config(ROOT / "configs" / "sim_5dof.yaml").arm,
        "cylinder": cylinder_arm(),
    }


ARMS = _arms()
#: Joints whose solution is not unique (a roll about the approach axis): not compared.
FREE_JOINTS = {"5dof": {"wrist_roll"}}
N_TARGETS = 12


@pytest.fixture(scope="module", params=list(ARMS))
def arm_case(request):
    arm = ARMS[request.param]
    return request.param, arm, ArmModel(arm)


def random_poses(model: ArmModel, count: int, seed: int = 5) -> np.ndarray:
    """Full joint vectors (count, n) from actuated joints uniform within their limits."""
    ch = model.chain
    rng = np.random.default_rng(seed)
    qa = rng.uniform(ch.actuated_lower, ch.actuated_upper, size=(count, ch.m))
    return qa @ ch.C.T + ch.c


# --------------------------------------------------------------------------- FK


def test_fk_pinocchio_dh_and_yourdfpy_agree(arm_case):
    """The TCP of Pinocchio, the DH product and yourdfpy agree within 1e-9 cm."""
    _, arm, model = arm_case
    urdf = yourdfpy_urdf(model.urdf)
    left, _ = jaw_joint_names(arm)
    for q in random_poses(model, 25):
        p_pin = model.fk_cm(q)
        assert np.abs(p_pin - dh_fk(arm, q)).max() < 1e-9
        cfg = dict(zip(model.chain.names, q.tolist(), strict=True))
        cfg[left] = 0.01  # the jaws are joints too; they do not move the TCP
        urdf.update_cfg(cfg)
        p_urdf = urdf.get_transform("tcp")[:3, 3] * 100.0
        assert np.abs(p_pin - p_urdf).max() < 1e-9


def test_jacobians_match_finite_differences(arm_case):
    """J, J·C and the approach Jacobian against central differences (step 1e-6)."""
    _, _, model = arm_case
    ch = model.chain
    h = 1e-6
    for q in random_poses(model, 8, seed=11):
        _, J = model.fk_and_jacobian(q)
        _, Ja = model.approach_jacobian(q)
        for i in range(ch.n):
            dq = np.zeros(ch.n)
            dq[i] = h
            fd = (model.fk_cm(q + dq) - model.fk_cm(q - dq)) / (2 * h)
            np.testing.assert_allclose(J[:, i], fd, atol=1e-5 * max(1.0, np.abs(fd).max()))
            fda = (model.approach(q + dq) - model.approach(q - dq)) / (2 * h)
            np.testing.assert_allclose(Ja[:, i], fda, atol=1e-5)
        Jc = model.coupled_jacobian(q)
        qa = ch.actuated_of(q)
        for k in range(ch.m):
            da = np.zeros(ch.m)
            da[k] = h
            fd = (model.fk_cm(ch.full(qa + da)) - model.fk_cm(ch.full(qa - da))) / (2 * h)
            np.testing.assert_allclose(Jc[:, k], fd, atol=1e-5 * max(1.0, np.abs(fd).max()))


# --------------------------------------------------------------------------- MuJoCo


def test_mujoco_site_is_pinocchios_tcp_frame(arm_case):
    """The URDF in MuJoCo (jaws fixed) puts the tcp site where Pinocchio puts tcp."""
    from mearm.ik import mink_solver

    _, _, model = arm_case
    mj_model = mink_solver.mujoco_model(model)
    assert mj_model.njnt == model.chain.n
    data = mujoco.MjData(mj_model)
    for q in random_poses(model, 20, seed=3):
        data.qpos[:] = q
        mujoco.mj_kinematics(mj_model, data)
        np.testing.assert_allclose(
            data.site(mink_solver.TCP_SITE).xpos * 100, model.fk_cm(q), atol=1e-10
        )
        # the site's z axis is the tool's approach axis
        np.testing.assert_allclose(
            data.site(mink_solver.TCP_SITE).xmat.reshape(3, 3)[:, 2], model.approach(q), atol=1e-10
        )


def test_mujoco_limits_are_the_models(arm_case):
    from mearm.ik import mink_solver

    _, _, model = arm_case
    mj_model = mink_solver.mujoco_model(model)
    np.testing.assert_allclose(mj_model.jnt_range[:, 0], model.lower, atol=1e-12)
    np.testing.assert_allclose(mj_model.jnt_range[:, 1], model.upper, atol=1e-12)


def test_coupling_task_error_and_jacobian(arm_case):
    """e = q_p − C_p q_a − c_p, one row per passive joint, J by finite differences."""
    import mink

    from mearm.ik import mink_solver

    _, _, model = arm_case
    ch = model.chain
    mj_model = mink_solver.mujoco_model(model)
    task = mink_solver.CouplingTask(mj_model, ch)
    assert task.k == len(ch.passive_index)
    if task.k == 0:
        return
    q = random_poses(model, 1, seed=9)[0] + 0.1  # off the coupling
    conf = mink.Configuration(mj_model, q)
    expected = (q - ch.full(ch.actuated_of(q)))[ch.passive_index]
    np.testing.assert_allclose(task.compute_error(conf), expected, atol=1e-12)
    J = task.compute_jacobian(conf)
    for i in range(ch.n):
        dq = np.zeros(ch.n)
        dq[i] = 1e-6
        conf.update(q + dq)
        fd = (task.compute_error(conf) - expected) / 1e-6
        np.testing.assert_allclose(fd, J[:, i], atol=1e-5)


# --------------------------------------------------------------------------- solvers


def reachable_targets(name: str, arm: ArmDescription, model: ArmModel) -> list[IKTarget]:
    """FK of random poses inside the box; for an arm that picks from above, poses whose
    approach axis points straight down, with that approach."""
    ch = model.chain
    rng = np.random.default_rng(2024)
    down = arm.tool.pick_approach
    out: list[IKTarget] = []
    while len(out) < N_TARGETS:
        qa = rng.uniform(ch.actuated_lower, ch.actuated_upper)
        q = ch.full(qa)
        if down is not None:
            # point the approach axis down: the pitch joints' sum is fixed (planar wrist)
            k = ch.actuated.index("wrist_pitch")
            home = ch.home
            qa[k] = home[ch.actuated_index[k]] - (qa[1] - home[1]) - (qa[2] - home[2])
            q = ch.full(qa)
            if not ch.within_limits(q):
                continue
            np.testing.assert_allclose(model.approach(q), down, atol=1e-9)
        target = IKTarget(tuple(model.fk_cm(q)), None if down is None else tuple(down))
        try:
            check_in_box(target.position_cm, arm)
        except TargetOutsideBoxError:
            continue
        out.append(target)
    return out


@pytest.fixture(scope="module")
def solved(arm_case, tmp_path_factory):
    """PD-PIJ (coupled) and mink from home to every target at |e|² < 1e-8 cm²

    (1e-4 cm: tight enough that two solvers stopping at different points within it still
    agree to 0.05° on the 8 cm links of the MeArm v1). Solved once per test run."""
    name, arm, model = arm_case

    def solve() -> dict:
        controller = Config().controller.updated(tolerance_cm2=1e-8)
        targets = reachable_targets(name, arm, model)
        pd, mk = PdPij(model, controller), mearm.ik.MinkSolver(model, controller)
        return {
            "targets": targets,
            "pdpij": [pd.solve(t, model.home) for t in targets],
            "mink": [mk.solve(t, model.home) for t in targets],
        }

    return computed_once(tmp_path_factory, f"ik-crosscheck-{name}", solve)


@pytest.mark.parametrize("kind", ["pdpij", "mink"])
@pytest.mark.heavy
def test_solvers_reach_random_reachable_targets(arm_case, solved, kind):
    """Within 0.01 cm (and the approach tolerance), every pose within limits and coupled."""
    _, _, model = arm_case
    ch = model.chain
    for target, result in zip(solved["targets"], solved[kind], strict=True):
        assert result.converged, (target, result.status, result.final_error_cm)
        assert result.final_error_cm <= 0.01
        if target.approach is not None:
            assert result.final_approach_error_deg < 0.5
        else:
            assert result.final_approach_error_deg is None
        assert np.all(result.q_path >= ch.lower - 1e-12)
        assert np.all(result.q_path <= ch.upper + 1e-12)
        coupled = ch.actuated_of(result.q_path) @ ch.C.T + ch.c
        assert np.abs(result.q_path - coupled).max() < 1e-9


@pytest.mark.heavy
def test_pdpij_and_mink_agree_where_unique(arm_case, solved):
    """Joints agree within 0.05° (5e-4 cm for a prismatic joint), free joints aside."""
    name, _, model = arm_case
    ch = model.chain
    keep = [i for i, n in enumerate(ch.names) if n not in FREE_JOINTS.get(name, set())]
    for a, b in zip(solved["pdpij"], solved["mink"], strict=True):
        diff = np.abs(a.q_config - b.q_config)[keep]
        limit = np.where(ch.prismatic[keep], 5e-4, 0.05)
        assert np.all(diff <= limit), (name, diff)


@pytest.mark.heavy
def test_pdpij_leaves_a_free_joint_where_it_starts(arm_case, solved):
    """A joint that moves neither the TCP nor the approach axis (the 5-DOF wrist roll)
    stays where it starts: J⁺ is the least-norm step."""
    name, _, model = arm_case
    for joint in FREE_JOINTS.get(name, ()):
        k = model.chain.names.index(joint)
        for result in solved["pdpij"]:
            assert np.abs(result.q_path[:, k] - model.home[k]).max() < 1e-12


@pytest.mark.heavy
def test_closed_form_agrees(arm_case, solved):
    """Where the arm has a closed form, it gives the solvers' joints (within 0.05°)."""
    _, arm, model = arm_case
    closed_form = closed_form_for(arm)
    if closed_form is None:
        pytest.skip("no closed form for this arm")
    for target, result in zip(solved["targets"], solved["pdpij"], strict=True):
        q = closed_form.solve(target.position_cm)
        assert np.linalg.norm(model.fk_cm(q) - target.position) < 1e-9
        assert np.all(np.abs(result.q_config - q / model.chain.scale) < 0.05)


# --------------------------------------------------------------------------- paper arm


PAPER = ARMS["paper"]
PAPER_MODEL = ArmModel(PAPER)
PAPER_CF = closed_form_for(PAPER)
N_PAPER_TARGETS = 200


@pytest.fixture(scope="module")
def paper_targets():
    """Uniform in the paper's box, kept when the closed form reaches them (fixed seed)."""
    rng = np.random.default_rng(2024)
    box = PAPER.target_box
    lo = np.array([box.x_cm.min, box.y_cm.min, box.z_cm.min])
    hi = np.array([box.x_cm.max, box.y_cm.max, box.z_cm.max])
    out = []
    while len(out) < N_PAPER_TARGETS:
        t = rng.uniform(lo, hi)
        try:
            PAPER_CF.solve(t)
        except UnreachableTargetError:
            continue
        out.append(t)
    return np.array(out)


def make(kind, tolerance_cm2):
    controller = Config().controller.updated(tolerance_cm2=tolerance_cm2)
    if kind == "mink":
        return mearm.ik.MinkSolver(PAPER_MODEL, controller)
    return PdPij(PAPER_MODEL, controller.updated(mode=kind))


SOLVERS = ["paper", "coupled", "mink"]


def _solve_all(targets, tolerance_cm2: float) -> dict:
    return {
        kind: [make(kind, tolerance_cm2).solve(t, PAPER_MODEL.home) for t in targets]
        for kind in SOLVERS
    }


@pytest.fixture(scope="module")
def loose(paper_targets, tmp_path_factory):
    """Every solver's result for every target at the paper's tolerance (once per run)."""
    return computed_once(
        tmp_path_factory, "ik-paper-loose", lambda: _solve_all(paper_targets, 1e-3)
    )


@pytest.fixture(scope="module")
def tight(paper_targets, tmp_path_factory):
    """The same at |e|² < 1e-10 cm²."""
    return computed_once(
        tmp_path_factory, "ik-paper-tight", lambda: _solve_all(paper_targets, 1e-10)
    )


@pytest.mark.parametrize("kind", SOLVERS)
@pytest.mark.heavy
def test_paper_arm_all_reach_within_the_papers_tolerance(loose, kind):
    """PD-PIJ (both modes) and mink converge to within 0.0316 cm of every target."""
    errors = np.array([r.final_error_cm for r in loose[kind]])
    assert all(r.converged for r in loose[kind])
    assert errors.max() < SQRT_TOL_CM


def test_paper_arm_closed_form_reaches_every_target(paper_targets):
    for t in paper_targets:
        q = PAPER_CF.solve(t)
        assert np.linalg.norm(PAPER_MODEL.fk_cm(q) - t) < 1e-9
        assert PAPER_MODEL.within_limits(q)


@pytest.mark.parametrize("kind", SOLVERS)
@pytest.mark.heavy
def test_paper_arm_tight_tolerance_joints_agree_with_the_closed_form(paper_targets, tight, kind):
    """At |e|² < 1e-10 cm² every solver's joints match the closed form within 0.001°."""
    worst = 0.0
    for t, result in zip(paper_targets, tight[kind], strict=True):
        assert result.converged
        diff = np.abs(np.degrees(result.q - PAPER_CF.solve(t)))
        worst = max(worst, diff.max())
    assert worst < 1e-3


@pytest.mark.parametrize("kind", SOLVERS)
@pytest.mark.heavy
def test_paper_arm_coupling_holds_in_every_pose(loose, tight, kind):
    """θ2 + θ3 + θ4 = 0 within 1e-9 rad in every solution and along every path."""
    for result in loose[kind] + tight[kind]:
        assert abs(result.q[1:].sum()) < 1e-9
        assert np.abs(result.q_path[:, 1:].sum(axis=1)).max() < 1e-9


@pytest.mark.parametrize("kind", SOLVERS)
@pytest.mark.heavy
def test_paper_arm_limits_hold_in_every_pose(loose, kind):
    for result in loose[kind]:
        assert np.all(result.q_path >= PAPER_MODEL.lower - 1e-12)
        assert np.all(result.q_path <= PAPER_MODEL.upper + 1e-12)
