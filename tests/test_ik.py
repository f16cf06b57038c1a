"""PD-PIJ: the algorithm as SPEC §3 states it, its record, its limits and its errors."""

import json

import numpy as np
import pytest
from conftest import run_cli

from mearm.config import ControllerConfig, config_from_dict
from mearm.exceptions import (
    ConfigError,
    InvalidJointsError,
    InvalidTargetError,
    JointLimitError,
    QPSolverError,
    TargetOutsideBoxError,
    UnreachableTargetError,
)
from mearm.ik import (
    STATUSES,
    AnalyticSolver,
    MinkSolver,
    PdPij,
    PseudoInverse,
    make_solver,
    solve_ik,
)
from mearm.ik.bounded import bounded_lstsq
from mearm.ik.reference import numpy_port_solve
from mearm.kinematics import COUPLING, analytic_ik_deg, check_target

M1 = (-10.99, 49.70, 12.76)  # SPEC §4, the first pick
#: From home this target needs θ3 to unfold from −132° to −78°; the paper's 4-joint step
#: folds it towards −160° instead (found by random search, see test_safeguard_*).
FOLDING_TARGET = (1.87477819, 23.55742561, 59.09713466)


def solver(model, config, **changes):
    return PdPij(model, config.controller.updated(**changes))


# --------------------------------------------------------------------------- algorithm


@pytest.mark.parametrize("mode", ["paper", "coupled"])
def test_reaches_the_closed_form_solution(model, config, mode):
    """With a tight tolerance both modes end on the closed-form joints."""
    result = solver(model, config, mode=mode, tolerance_cm2=1e-12).solve(model.home_rad, M1)
    assert result.converged
    np.testing.assert_allclose(result.q_deg, analytic_ik_deg(M1, config.robot), atol=1e-4)


def test_first_step_is_kp_pinv_e_without_kick(model, config):
    """e_{−1} = e_0, so the first update is kp·J⁺e_0 exactly (no derivative kick)."""
    result = solver(model, config, mode="paper").solve(model.home_rad, M1)
    e0 = np.asarray(M1) - model.fk_cm(model.home_rad)
    dq = np.linalg.pinv(model.jacobian(model.home_rad)) @ (0.1 * e0)
    expected = model.home_rad + dq
    expected[3] = -(expected[1] + expected[2])
    np.testing.assert_allclose(result.q_path_rad[1], expected, atol=1e-12)


def test_paper_mode_equals_the_numpy_port_iteration_for_iteration(model, config):
    """paper mode and a plain NumPy port of the paper (DH + pinv) take the same path."""
    status, q_path, ee_path = numpy_port_solve(model.home_rad, M1, config.robot, config.controller)
    result = solver(model, config, mode="paper").solve(model.home_rad, M1)
    assert status == result.status == "converged"
    assert q_path.shape == result.q_path_rad.shape
    np.testing.assert_allclose(result.q_path_rad, q_path, atol=1e-10)
    np.testing.assert_allclose(result.ee_path_cm, ee_path, atol=1e-8)


def test_coupled_error_contracts_by_the_pd_loops_root(model, config):
    """Away from the start |e| shrinks by the dominant root of r² − (1−kp−kd)r − kd."""
    kp, kd = config.controller.kp, config.controller.kd
    r = max(np.roots([1.0, -(1 - kp - kd), -kd]).real)
    errors = solver(model, config, mode="coupled").solve(model.home_rad, M1).error_path_cm
    ratios = errors[11:41] / errors[10:40]
    np.testing.assert_allclose(ratios, r, atol=2e-3)


def test_paper_mode_needs_more_iterations_than_coupled(model, config):
    """θ4's share of the paper's step is overwritten, so each update does less."""
    paper = solver(model, config, mode="paper").solve(model.home_rad, M1)
    coupled = solver(model, config, mode="coupled").solve(model.home_rad, M1)
    assert paper.iterations > coupled.iterations


def test_stops_at_the_tolerance(model, config):
    """It stops at the first |e|² below the tolerance, as eq. 6 says."""
    result = solver(model, config).solve(model.home_rad, M1)
    assert result.error_path_cm[-1] ** 2 < 1e-3 <= result.error_path_cm[-2] ** 2


# --------------------------------------------------------------------------- record


def test_result_record(model, config):
    result = solver(model, config).solve(model.home_rad, M1)
    n = result.iterations
    assert result.status in STATUSES and result.solver == "pdpij-coupled"
    assert result.q_path_rad.shape == (n + 1, 4)
    assert result.ee_path_cm.shape == (n + 1, 3)
    assert result.error_path_cm.shape == (n + 1,)
    np.testing.assert_allclose(result.q_path_rad[0], model.home_rad)
    np.testing.assert_array_equal(result.q_rad, result.q_path_rad[-1])
    np.testing.assert_array_equal(result.ee_cm, result.ee_path_cm[-1])
    for q, ee in zip(result.q_path_rad, result.ee_path_cm, strict=True):
        np.testing.assert_allclose(model.fk_cm(q), ee, atol=1e-10)
    assert result.initial_error_cm == pytest.approx(np.linalg.norm(np.subtract(M1, ee_home(model))))
    assert result.final_error_cm == result.error_path_cm[-1]
    with pytest.raises(ValueError):
        result.q_path_rad[0, 0] = 1.0  # read-only: a record, not a buffer
    assert set(result.summary()) == {
        "status",
        "iterations",
        "initial_error_cm",
        "final_error_cm",
        "joints_deg",
        "ee_cm",
    }


def ee_home(model):
    return model.fk_cm(model.home_rad)


def test_start_may_be_three_angles(model, config):
    s = solver(model, config)
    a = s.solve(model.home_rad[:3], M1)
    b = s.solve(model.home_rad, M1)
    np.testing.assert_array_equal(a.q_path_rad, b.q_path_rad)


def test_max_iterations_status(model, config):
    result = solver(model, config, max_iterations=5).solve(model.home_rad, M1)
    assert result.status == "max_iterations" and not result.converged
    assert result.iterations == 5 and len(result.q_path_rad) == 6


# --------------------------------------------------------------------------- limits


def test_safeguard_turns_a_stall_into_convergence(model, config):
    """The bare paper algorithm folds θ3 into its limit and stalls; the safeguard slides
    along the limit and gets there."""
    bare = solver(model, config, mode="paper", safeguard=False).solve(
        model.home_rad, FOLDING_TARGET
    )
    assert bare.status == "stalled" and bare.blocked_steps > 0
    assert bare.final_error_cm > 10
    guarded = solver(model, config, mode="paper").solve(model.home_rad, FOLDING_TARGET)
    assert guarded.converged and guarded.blocked_steps > 0  # it slid along the limit
    assert np.all(np.diff(guarded.error_path_cm) < 0)
    for result in (bare, guarded):
        assert np.all(result.q_path_rad >= model.lower_rad)
        assert np.all(result.q_path_rad <= model.upper_rad)


def test_limit_rule_holds_the_joint(model, config):
    """A joint whose update would leave its limits gets Δθ = 0; the others move as J⁺Δs."""
    bare = solver(model, config, mode="paper", safeguard=False).solve(
        model.home_rad, FOLDING_TARGET
    )
    q, ee = bare.q_path_rad, bare.ee_path_cm
    held = np.flatnonzero(q[1:, 2] == q[:-1, 2])
    assert len(held) > 0
    k = int(held[0])
    e, e_prev = FOLDING_TARGET - ee[k], FOLDING_TARGET - ee[max(k - 1, 0)]
    ds = 0.1 * e + 0.01 * (e - e_prev)
    dq = np.linalg.pinv(model.jacobian(q[k])) @ ds
    assert q[k, 2] + dq[2] < model.lower_rad[2]  # θ3's update would have left its limits
    for i in range(3):
        new = q[k, i] + dq[i]
        if model.lower_rad[i] <= new <= model.upper_rad[i]:
            assert q[k + 1, i] == pytest.approx(new, abs=1e-12)
        else:
            assert q[k + 1, i] == q[k, i]
    assert q[k + 1, 3] == -(q[k + 1, 1] + q[k + 1, 2])  # coupling re-imposed


@pytest.mark.parametrize("mode", ["paper", "coupled"])
def test_start_on_the_limits_stays_within(model, config, mode):
    """A start on three limits at once: every pose stays inside, θ2 + θ3 + θ4 = 0."""
    q0 = COUPLING @ np.array([model.lower_rad[0], model.upper_rad[1], model.upper_rad[2]])
    result = solver(model, config, mode=mode).solve(q0, (0.0, 40.0, 30.0))
    assert result.status in STATUSES
    assert np.all(result.q_path_rad >= model.lower_rad)
    assert np.all(result.q_path_rad <= model.upper_rad)
    assert np.abs(result.q_path_rad[:, 1:].sum(axis=1)).max() < 1e-12


@pytest.mark.parametrize("damping", [0.0, 5.0])
def test_singular_start_on_the_base_axis(model, config, damping):
    """From a pose with the EE on the base axis (θ1 moves nothing) it still returns."""
    # ρ = a1 + a2 cos θ2 + a3 cos(θ2+θ3) + a4 = 0 at θ2 = 130°: solve for θ3
    a1, a2, a3, a4 = (r.a_cm for r in config.robot.dh)
    t2 = np.radians(130.0)
    t23 = np.arccos(-(a1 + a2 * np.cos(t2) + a4) / a3)
    q0 = COUPLING @ np.array([np.radians(90.0), t2, t23 - t2])
    assert abs(model.fk_cm(q0)[:2]).max() < 1e-9
    J = model.jacobian(q0)
    assert np.linalg.svd(J, compute_uv=False)[-1] < 1e-9 * np.linalg.norm(J)
    result = solver(model, config, damping=damping).solve(q0, M1)
    assert result.status in STATUSES
    assert np.all(np.isfinite(result.q_path_rad))
    assert np.all(np.diff(result.error_path_cm) <= 1e-12)


# --------------------------------------------------------------------------- J⁺


def test_pseudoinverse_matches_numpy():
    rng = np.random.default_rng(0)
    for rows, cols in ((3, 4), (3, 3)):
        pinv = PseudoInverse(rows, cols, cutoff=1e-6)
        for _ in range(20):
            J, b = rng.normal(size=(rows, cols)), rng.normal(size=rows)
            np.testing.assert_allclose(pinv.solve(J, b), np.linalg.pinv(J) @ b, atol=1e-12)


def test_pseudoinverse_cutoff_drops_a_tiny_direction():
    """σ at or below cutoff·σ_max counts as zero (numpy's rcond rule)."""
    J = np.array([[2.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, 1e-8, 0]])
    b = np.ones(3)
    np.testing.assert_allclose(PseudoInverse(3, 4, 1e-6).solve(J, b), [0.5, 1.0, 0, 0])
    np.testing.assert_allclose(PseudoInverse(3, 4, 1e-9).solve(J, b), [0.5, 1.0, 1e8, 0])


def test_damped_pseudoinverse_formula():
    rng = np.random.default_rng(1)
    J, b = rng.normal(size=(3, 4)), rng.normal(size=3)
    got = PseudoInverse(3, 4, 1e-6, damping=0.7).solve(J, b)
    np.testing.assert_allclose(got, J.T @ np.linalg.solve(J @ J.T + 0.49 * np.eye(3), b))


def test_pseudoinverse_rejects_bad_settings():
    with pytest.raises(ValueError, match="cutoff"):
        PseudoInverse(3, 4, 0.0)
    with pytest.raises(ValueError, match="damping"):
        PseudoInverse(3, 4, 1e-6, damping=-1.0)


def test_damped_mode_converges(model, config):
    result = solver(model, config, damping=2.0).solve(model.home_rad, M1)
    assert result.converged and result.final_error_cm < 0.0316


# --------------------------------------------------------------------------- errors


def test_target_outside_box(model, config):
    with pytest.raises(TargetOutsideBoxError) as exc:
        solver(model, config).solve(model.home_rad, (-10.0, 65.0, 20.0))
    err = exc.value
    assert err.axis == "y" and err.bounds_cm == (20.0, 60.0)
    assert err.target_cm == (-10.0, 65.0, 20.0)
    assert "y = 65 is outside the target box y ∈ [20, 60] cm" in str(err)


def test_unreachable_target_in_box(model, config):
    target = (-40.0, 60.0, 60.0)  # in the box, 72 cm out and 42 cm up
    with pytest.raises(UnreachableTargetError) as exc:
        solver(model, config).solve(model.home_rad, target)
    assert exc.value.target_cm == target
    assert "out of reach" in str(exc.value)


@pytest.mark.parametrize("bad", [(1.0, 2.0), (np.nan, 40.0, 20.0), "x"])
def test_malformed_target(model, config, bad):
    with pytest.raises(InvalidTargetError):
        solver(model, config).solve(model.home_rad, bad)


def test_start_outside_limits(model, config):
    q0 = np.radians([10.0, 93.0, -132.0])
    with pytest.raises(JointLimitError) as exc:
        solver(model, config).solve(q0, M1)
    assert exc.value.joint == "joint1" and exc.value.value_deg == pytest.approx(10.0)
    assert "[20, 160]" in str(exc.value)


@pytest.mark.parametrize(
    "start, needle",
    [
        ([2.0, 1.6, -2.3, 0.5], "θ2 + θ3 + θ4"),
        ([2.0, 1.6], "expected 3 or 4"),
        ([2.0, np.inf, -2.3], "finite"),
    ],
)
def test_bad_start(model, config, start, needle):
    with pytest.raises(InvalidJointsError) as exc:
        solver(model, config).solve(start, M1)
    assert needle in str(exc.value)


@pytest.mark.parametrize(
    "controller, needle",
    [
        ({"kp": 0}, "controller.kp"),
        ({"kp": -0.1}, "controller.kp"),
        ({"kd": -0.01}, "controller.kd"),
        ({"kd": 1.0}, "kd = 1 must be below 1"),
        ({"kp": 1.9, "kd": 0.1}, "kp + 2·kd = 2.1 must be below 2"),
        ({"mode": "fast"}, "controller.mode"),
    ],
)
def test_bad_gains_in_config(controller, needle):
    with pytest.raises(ConfigError) as exc:
        config_from_dict({"controller": controller})
    assert needle in str(exc.value)


def test_updated_validates():
    with pytest.raises(ConfigError, match="controller.tolerance_cm2"):
        ControllerConfig().updated(tolerance_cm2=0.0)
    assert ControllerConfig().updated(mode="paper").mode == "paper"


def test_unknown_qp_solver(model, config):
    with pytest.raises(QPSolverError) as exc:
        MinkSolver(model, config.controller.updated(qp_solver="nope"))
    assert "daqp" in exc.value.available


# --------------------------------------------------------------------------- dispatch


def test_solve_ik_dispatches_on_config(model, config):
    for name, kind in (("pdpij", PdPij), ("analytic", AnalyticSolver), ("mink", MinkSolver)):
        controller = config.controller.updated(solver=name)
        assert isinstance(make_solver(model, controller), kind)
        result = solve_ik(model, model.home_rad, M1, controller)
        assert result.converged and result.final_error_cm < 0.0316
        np.testing.assert_allclose(result.q_path_rad[0], model.home_rad)


def test_analytic_solver_record(model, config):
    result = solve_ik(model, model.home_rad, M1, config.controller.updated(solver="analytic"))
    assert result.iterations == 1 and result.final_error_cm < 1e-9
    np.testing.assert_allclose(result.q_deg, check_target(M1, config.robot))


# --------------------------------------------------------------------------- CLI


def test_cli_json_issue_example():
    """The issue's command, negative target coordinates included."""
    r = run_cli(
        "-m", "mearm.ik", "--config", "configs/lab.yaml", "--start", "120,93,-132",
        "--target", "-10.99,49.70,12.76", "--mode", "paper", "--json",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert set(out) == {
        "status",
        "iterations",
        "initial_error_cm",
        "final_error_cm",
        "joints_deg",
        "ee_cm",
    }
    assert out["status"] == "converged" and out["final_error_cm"] < 0.0316
    assert len(out["joints_deg"]) == 4 and abs(sum(out["joints_deg"][1:])) < 1e-6
    np.testing.assert_allclose(out["ee_cm"], [-10.99, 49.70, 12.76], atol=0.0316)


def test_cli_solvers_and_tolerance():
    for solver_name in ("pdpij", "mink", "analytic"):
        r = run_cli(
            "-m", "mearm.ik", "--target", "0,40,20", "--solver", solver_name,
            "--tolerance", "1e-8", "--json",
        )  # fmt: skip
        assert r.returncode == 0, r.stderr
        out = json.loads(r.stdout)
        assert out["final_error_cm"] ** 2 < 1e-8


def test_cli_text_output():
    r = run_cli("-m", "mearm.ik", "--target", "-10.99,49.70,12.76")
    assert r.returncode == 0, r.stderr
    assert "pdpij-coupled: converged after" in r.stdout and "ee = (" in r.stdout


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--target", "-10.99,65,12.76"], "y = 65 is outside the target box y ∈ [20, 60] cm"),
        (["--target", "-40,60,60"], "target (-40, 60, 60) cm: out of reach"),
        (["--target", "0,40,20", "--start", "10,93,-132"], "joint1 = 10 deg is outside"),
        (["--target", "0,40"], "needs 3 numbers"),
        (["--target", "0,40,20", "--tolerance", "0"], "must be a positive number"),
        (["--target", "0,40,20", "--mode", "fast"], "invalid choice"),
    ],
)
def test_cli_bad_input_exit_2_one_line(args, needle):
    r = run_cli("-m", "mearm.ik", *args)
    assert r.returncode == 2, r.stdout
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


def test_bounded_lstsq_matches_scipy_bvls():
    """The 27-active-set solver finds scipy's bounded optimum (residual within 1e-12)."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(7)
    for _ in range(200):
        A, b = rng.normal(size=(3, 3)), 3 * rng.normal(size=3)
        lo, hi = -rng.random(3), rng.random(3)
        x = bounded_lstsq(A, b, lo, hi)
        assert np.all(x >= lo) and np.all(x <= hi)
        ref = lsq_linear(A, b, bounds=(lo, hi), method="bvls", tol=1e-14).x
        assert np.sum((A @ x - b) ** 2) <= np.sum((A @ ref - b) ** 2) + 1e-12


def test_bounded_lstsq_singular_and_bad_input():
    A = np.array([[1.0, 0, 0], [0, 0, 0], [0, 0, 0]])  # rank 1
    x = bounded_lstsq(A, [5.0, 1.0, 1.0], [-1, -1, -1], [1, 1, 1])
    np.testing.assert_allclose(x, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="feasible"):
        bounded_lstsq(A, [1.0, 0, 0], [0.1, -1, -1], [1, 1, 1])


def test_all_names_exist():
    """Every name in mearm.ik.__all__ is importable (MinkSolver lazily)."""
    import mearm.ik

    for name in mearm.ik.__all__:
        assert getattr(mearm.ik, name) is not None
    with pytest.raises(AttributeError):
        mearm.ik.NoSuchSolver  # noqa: B018
