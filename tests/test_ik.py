"""PD-PIJ: the algorithm as paper §3 states it, its record, its limits and its errors."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from badinput import run_in_process
from conftest import planar_yaw_arm_data, run_cli

import mearm.ik  # MinkSolver on first use: mink costs each worker's collection 0.3 s
from mearm.config import ControllerConfig, config_from_dict, load_config
from mearm.exceptions import (
    ConfigError,
    InvalidJointsError,
    InvalidTargetError,
    JointLimitError,
    ModelError,
    QPSolverError,
    TargetOutsideBoxError,
    UnreachableTargetError,
)
from mearm.ik import (
    STATUSES,
    AnalyticSolver,
    IKTarget,
    PdPij,
    PseudoInverse,
    make_solver,
    solve_ik,
)
from mearm.ik.bounded import bounded_lstsq
from mearm.ik.paper_port import numpy_port_solve
from mearm.kinematics import ArmModel, check_target, closed_form_for

M1 = (-10.99, 49.70, 12.76)  # paper §4, the first pick
#: From home this target needs θ3 to unfold from −132° to −78°; the paper's 4-joint step
#: folds it towards −160° instead (found by random search, see test_safeguard_*).
FOLDING_TARGET = (1.87477819, 23.55742561, 59.09713466)


ROOT = Path(__file__).resolve().parent.parent
#: The keys of IKResult.summary(), the CLI's JSON record.
SUMMARY_KEYS = {
    "status",
    "method",
    "failure_kind",
    "failure",
    "iterations",
    "initial_error_cm",
    "final_error_cm",
    "final_approach_error_deg",
    "joints",
    "joint_units",
    "ee_cm",
}


@pytest.fixture(scope="module")
def model(config):
    return ArmModel(config.arm)


def closed_form_deg(config, target):
    return np.degrees(closed_form_for(config.arm).solve(target))


def solver(model, config, **changes):
    return PdPij(model, config.controller.updated(**changes))


# --------------------------------------------------------------------------- algorithm


@pytest.mark.parametrize("mode", ["paper", "coupled"])
def test_reaches_the_closed_form_solution(model, config, mode):
    """With a tight tolerance both modes end on the closed-form joints."""
    result = solver(model, config, mode=mode, tolerance_cm2=1e-12).solve(M1, model.home)
    assert result.converged
    np.testing.assert_allclose(result.q_config, closed_form_deg(config, M1), atol=1e-4)


def test_first_step_is_kp_pinv_e_without_kick(model, config):
    """e_{−1} = e_0, so the first update is kp·J⁺e_0 exactly (no derivative kick)."""
    result = solver(model, config, mode="paper").solve(M1, model.home)
    e0 = np.asarray(M1) - model.fk_cm(model.home)
    dq = np.linalg.pinv(model.jacobian(model.home)) @ (0.1 * e0)
    expected = model.home + dq
    expected[3] = -(expected[1] + expected[2])
    np.testing.assert_allclose(result.q_path[1], expected, atol=1e-12)


def test_paper_mode_equals_the_numpy_port_iteration_for_iteration(model, config):
    """paper mode and a plain NumPy port of the paper (DH + pinv) take the same path."""
    status, q_path, ee_path = numpy_port_solve(model.home, M1, config.arm, config.controller)
    result = solver(model, config, mode="paper").solve(M1, model.home)
    assert status == result.status == "converged"
    assert q_path.shape == result.q_path.shape
    np.testing.assert_allclose(result.q_path, q_path, atol=1e-10)
    np.testing.assert_allclose(result.ee_path_cm, ee_path, atol=1e-8)


def test_coupled_error_contracts_by_the_pd_loops_root(model, config):
    """Away from the start |e| shrinks by the dominant root of r² − (1−kp−kd)r − kd."""
    kp, kd = config.controller.kp, config.controller.kd
    r = max(np.roots([1.0, -(1 - kp - kd), -kd]).real)
    errors = solver(model, config, mode="coupled").solve(M1, model.home).error_path_cm
    ratios = errors[11:41] / errors[10:40]
    np.testing.assert_allclose(ratios, r, atol=2e-3)


def test_paper_mode_needs_more_iterations_than_coupled(model, config):
    """θ4's share of the paper's step is overwritten, so each update does less."""
    paper = solver(model, config, mode="paper").solve(M1, model.home)
    coupled = solver(model, config, mode="coupled").solve(M1, model.home)
    assert paper.iterations > coupled.iterations


def test_stops_at_the_tolerance(model, config):
    """It stops at the first |e|² below the tolerance, as eq. 6 says."""
    result = solver(model, config).solve(M1, model.home)
    assert result.error_path_cm[-1] ** 2 < 1e-3 <= result.error_path_cm[-2] ** 2


# --------------------------------------------------------------------------- record


def test_result_record(model, config):
    result = solver(model, config).solve(M1, model.home)
    n = result.iterations
    assert result.status in STATUSES and result.solver == "pdpij-coupled"
    assert result.q_path.shape == (n + 1, 4)
    assert result.ee_path_cm.shape == (n + 1, 3)
    assert result.error_path_cm.shape == (n + 1,)
    np.testing.assert_allclose(result.q_path[0], model.home)
    np.testing.assert_array_equal(result.q, result.q_path[-1])
    np.testing.assert_array_equal(result.ee_cm, result.ee_path_cm[-1])
    for q, ee in zip(result.q_path, result.ee_path_cm, strict=True):
        np.testing.assert_allclose(model.fk_cm(q), ee, atol=1e-10)
    assert result.initial_error_cm == pytest.approx(np.linalg.norm(np.subtract(M1, ee_home(model))))
    assert result.final_error_cm == result.error_path_cm[-1]
    with pytest.raises(ValueError):
        result.q_path[0, 0] = 1.0  # read-only: a record, not a buffer
    assert set(result.summary()) == SUMMARY_KEYS
    assert list(result.summary()["joints"]) == ["base", "shoulder", "elbow", "wrist"]
    assert result.final_approach_error_deg is None and result.approach is None
    assert result.method == "direct" and result.recovered_from is None
    assert result.search_iterations == 0 and result.failure is None
    assert result.summary()["method"] == "direct" and result.summary()["failure_kind"] is None


def ee_home(model):
    return model.fk_cm(model.home)


def test_start_may_be_three_angles(model, config):
    s = solver(model, config)
    a = s.solve(M1, model.home[:3])
    b = s.solve(M1, model.home)
    np.testing.assert_array_equal(a.q_path, b.q_path)


def test_max_iterations_status(model, config):
    """The cap binds the recovery too: five updates reach nowhere, and the record says so."""
    result = solver(model, config, max_iterations=5).solve(M1, model.home)
    assert result.status == "max_iterations" and not result.converged
    assert result.iterations == 5 and len(result.q_path) == 6
    assert result.method == "direct" and result.failure.kind == "stalled"
    assert result.failure.message.startswith("the solver reached its iteration cap (5) ")


# --------------------------------------------------------------------------- limits


def test_safeguard_turns_a_stall_into_convergence(model, config):
    """The bare paper algorithm folds θ3 into its limit and stalls; the safeguard slides
    along the limit and gets there."""
    bare = solver(model, config, mode="paper", safeguard=False).solve(FOLDING_TARGET, model.home)
    assert bare.status == "stalled" and bare.blocked_steps > 0
    assert bare.final_error_cm > 10
    assert bare.method == "direct"  # safeguard false: the bare algorithm, no recovery
    guarded = solver(model, config, mode="paper").solve(FOLDING_TARGET, model.home)
    assert guarded.converged and guarded.blocked_steps > 0  # it slid along the limit
    assert np.all(np.diff(guarded.error_path_cm) < 0)
    for result in (bare, guarded):
        assert np.all(result.q_path >= model.lower)
        assert np.all(result.q_path <= model.upper)


def test_limit_rule_holds_the_joint(model, config):
    """A joint whose update would leave its limits gets Δθ = 0; the others move as J⁺Δs."""
    bare = solver(model, config, mode="paper", safeguard=False).solve(FOLDING_TARGET, model.home)
    q, ee = bare.q_path, bare.ee_path_cm
    held = np.flatnonzero(q[1:, 2] == q[:-1, 2])
    assert len(held) > 0
    k = int(held[0])
    e, e_prev = FOLDING_TARGET - ee[k], FOLDING_TARGET - ee[max(k - 1, 0)]
    ds = 0.1 * e + 0.01 * (e - e_prev)
    dq = np.linalg.pinv(model.jacobian(q[k])) @ ds
    assert q[k, 2] + dq[2] < model.lower[2]  # θ3's update would have left its limits
    for i in range(3):
        new = q[k, i] + dq[i]
        if model.lower[i] <= new <= model.upper[i]:
            assert q[k + 1, i] == pytest.approx(new, abs=1e-12)
        else:
            assert q[k + 1, i] == q[k, i]
    assert q[k + 1, 3] == -(q[k + 1, 1] + q[k + 1, 2])  # coupling re-imposed


@pytest.mark.parametrize("mode", ["paper", "coupled"])
def test_start_on_the_limits_stays_within(model, config, mode):
    """A start on three limits at once: every pose stays inside, θ2 + θ3 + θ4 = 0."""
    q0 = model.chain.full([model.lower[0], model.upper[1], model.upper[2]])
    result = solver(model, config, mode=mode).solve((0.0, 40.0, 30.0), q0)
    assert result.status in STATUSES
    assert np.all(result.q_path >= model.lower)
    assert np.all(result.q_path <= model.upper)
    assert np.abs(result.q_path[:, 1:].sum(axis=1)).max() < 1e-12


@pytest.mark.parametrize("damping", [0.0, 5.0])
def test_singular_start_on_the_base_axis(model, config, damping):
    """From a pose with the EE on the base axis (θ1 moves nothing) it still returns."""
    # ρ = a1 + a2 cos θ2 + a3 cos(θ2+θ3) + a4 = 0 at θ2 = 130°: solve for θ3
    a1, a2, a3, a4 = (j.dh.a_cm for j in config.arm.joints)
    t2 = np.radians(130.0)
    t23 = np.arccos(-(a1 + a2 * np.cos(t2) + a4) / a3)
    q0 = model.chain.full([np.radians(90.0), t2, t23 - t2])
    assert abs(model.fk_cm(q0)[:2]).max() < 1e-9
    J = model.jacobian(q0)
    assert np.linalg.svd(J, compute_uv=False)[-1] < 1e-9 * np.linalg.norm(J)
    result = solver(model, config, damping=damping).solve(M1, q0)
    assert result.status in STATUSES
    assert np.all(np.isfinite(result.q_path))
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
    result = solver(model, config, damping=2.0).solve(M1, model.home)
    assert result.converged and result.final_error_cm < 0.0316


# --------------------------------------------------------------------------- errors


def test_target_outside_box(model, config):
    with pytest.raises(TargetOutsideBoxError) as exc:
        solver(model, config).solve((-10.0, 65.0, 20.0), model.home)
    err = exc.value
    assert err.axis == "y" and err.bounds_cm == (20.0, 60.0)
    assert err.target_cm == (-10.0, 65.0, 20.0)
    assert "y = 65 is outside the target box y ∈ [20, 60] cm" in str(err)


def test_unreachable_target_in_box(model, config):
    target = (-40.0, 60.0, 60.0)  # in the box, 72 cm out and 42 cm up
    with pytest.raises(UnreachableTargetError) as exc:
        solver(model, config).solve(target, model.home)
    assert exc.value.target_cm == target
    assert "out of reach" in str(exc.value)


@pytest.mark.parametrize("bad", [(1.0, 2.0), (np.nan, 40.0, 20.0), "x"])
def test_malformed_target(model, config, bad):
    with pytest.raises(InvalidTargetError):
        solver(model, config).solve(bad, model.home)


def test_start_outside_limits(model, config):
    q0 = np.radians([10.0, 93.0, -132.0])
    with pytest.raises(JointLimitError) as exc:
        solver(model, config).solve(M1, q0)
    assert exc.value.joint == "base" and exc.value.value_deg == pytest.approx(10.0)
    assert "[20, 160]" in str(exc.value)


@pytest.mark.parametrize(
    "start, needle",
    [
        ([2.0, 1.6, -2.3, 0.5], "passive joint wrist = 0.5 is -0.2 off its coupling"),
        ([2.0, 1.6], "expected 4 joint values (base, shoulder, elbow, wrist) or the 3"),
        ([2.0, np.inf, -2.3], "finite"),
    ],
)
def test_bad_start(model, config, start, needle):
    with pytest.raises(InvalidJointsError) as exc:
        solver(model, config).solve(M1, start)
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
        mearm.ik.MinkSolver(model, config.controller.updated(qp_solver="nope"))
    assert "daqp" in exc.value.available


# --------------------------------------------------------------------------- dispatch


def test_solve_ik_dispatches_on_config(model, config):
    for name, kind in (
        ("pdpij", PdPij),
        ("analytic", AnalyticSolver),
        ("mink", mearm.ik.MinkSolver),
    ):
        controller = config.controller.updated(solver=name)
        assert isinstance(make_solver(model, controller), kind)
        result = solve_ik(model, controller, M1, model.home)
        assert result.converged and result.final_error_cm < 0.0316
        np.testing.assert_allclose(result.q_path[0], model.home)


def test_analytic_solver_record(model, config):
    result = solve_ik(model, config.controller.updated(solver="analytic"), M1, model.home)
    assert result.iterations == 1 and result.final_error_cm < 1e-9
    q = check_target(M1, config.arm, closed_form_for(config.arm))
    np.testing.assert_allclose(result.q, q)


# --------------------------------------------------------------------------- CLI


@pytest.mark.heavy
def test_cli_json_issue_example():
    """The issue's command, negative target coordinates included."""
    r = run_cli(
        "-m", "mearm.ik", "--config", "configs/lab.yaml", "--start", "120,93,-132",
        "--target", "-10.99,49.70,12.76", "--mode", "paper", "--json",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert set(out) == SUMMARY_KEYS
    assert out["status"] == "converged" and out["final_error_cm"] < 0.0316
    joints = out["joints"]
    assert list(joints) == ["base", "shoulder", "elbow", "wrist"]
    assert abs(joints["shoulder"] + joints["elbow"] + joints["wrist"]) < 1e-6
    np.testing.assert_allclose(out["ee_cm"], [-10.99, 49.70, 12.76], atol=0.0316)


@pytest.mark.heavy
def test_cli_solvers_and_tolerance():
    """In this process (``mearm ik``, the command ``python -m mearm.ik`` runs): the
    subprocess tests above and below prove the real process's exit and streams."""
    for solver_name in ("pdpij", "mink", "analytic"):
        r = run_in_process(
            ["ik", "--target", "0,40,20", "--solver", solver_name, "--tolerance", "1e-8",
             "--json"], within_s=60,
        )  # fmt: skip
        assert r.code == 0, r.stderr
        out = json.loads(r.stdout)
        assert out["final_error_cm"] ** 2 < 1e-8


def test_cli_json_gives_each_joints_unit_as_fk_does(tmp_path):
    """ik --json names each joint's unit (a prismatic rail's in cm) in fk's own key."""
    rail = tmp_path / "rail.yaml"
    rail.write_text(yaml.safe_dump({"arm": planar_yaw_arm_data(rail=True)}), encoding="utf-8")
    ik = run_in_process(["ik", "--config", rail, "--target=0,10,30", "--json"], within_s=30)
    fk = run_in_process(["fk", "--config", rail, "--joints", "2,90,80,-100", "--json"])
    assert ik.code == 0 and fk.code == 0, ik.stderr + fk.stderr
    units = json.loads(ik.stdout)["joint_units"]
    assert units == {"rail": "cm", "yaw": "deg", "upper": "deg", "fore": "deg"}
    assert units == json.loads(fk.stdout)["joint_units"]
    assert list(units) == list(json.loads(ik.stdout)["joints"])


def test_cli_text_output():
    """In this process (the two tests around it run the command as a process)."""
    r = run_in_process(["ik", "--target", "-10.99,49.70,12.76"], within_s=30)
    assert r.code == 0, r.stderr
    assert "pdpij-coupled: converged after" in r.stdout and "ee = (" in r.stdout
    assert "joints: base " in r.stdout


def test_cli_text_output_counts_one_iteration_in_the_singular():
    """The closed form solves in one step: "after 1 iteration", not "1 iterations"."""
    r = run_in_process(["ik", "--target", "0,55,30", "--solver", "analytic"], within_s=30)
    assert r.code == 0, r.stderr
    assert r.stdout.splitlines()[0] == "analytic: converged after 1 iteration"


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--target", "-10.99,65,12.76"], "y = 65 is outside the target box y ∈ [20, 60] cm"),
        (["--target", "-40,60,60"], "target (-40, 60, 60) cm: out of reach"),
        (["--target", "0,40,20", "--start", "10,93,-132"], "base = 10 deg is outside"),
        (["--target", "0,40,20", "--start", "10,93"], "--start needs 3 numbers"),
        (["--target", "0,40,20", "--approach", "0,0,0"], "non-zero 3-vector"),
        (["--target", "0,40,20", "--approach", "pick"], "has no tool.pick_approach"),
        (["--target", "0,40"], "needs 3 numbers"),
        (["--target", "0,40,20", "--tolerance", "0"], "must be a positive number"),
        (["--target", "0,40,20", "--mode", "fast"], "invalid choice"),
    ],
)
def test_cli_bad_input_exit_2_one_line(args, needle):
    """In this process (``mearm ik``: the same ``run`` guard maps the error to exit 2)."""
    r = run_in_process(["ik", *args], within_s=30)
    assert r.code == 2, r.stdout
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


@pytest.mark.heavy
def test_cli_bad_input_exits_2_with_one_line_from_a_real_process():
    """The process's exit status and stderr, as a shell sees them (one case of the above)."""
    r = run_cli("-m", "mearm.ik", "--target", "-10.99,65,12.76")
    assert r.returncode == 2, r.stdout
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "y = 65 is outside the target box" in lines[0], r.stderr


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


def test_bounded_lstsq_active_set_walk_is_the_enumerations_optimum(monkeypatch):
    """The active-set walk certifies the same optimum the 3ⁿ enumeration finds (n ≤ 6)."""
    from mearm.ik import bounded

    rng = np.random.default_rng(11)
    for n in (1, 2, 3, 3, 4, 6):
        for _ in range(40):
            rows = 3 if n <= 3 else 6
            A, b = rng.normal(size=(rows, n)), 3 * rng.normal(size=rows)
            lo, hi = -rng.random(n), rng.random(n)
            walked = bounded._active_set(A, b, lo, hi)
            assert walked is not None  # full column rank: always certified
            with monkeypatch.context() as m:
                m.setattr(bounded, "_active_set", lambda *args: None)
                enumerated = bounded_lstsq(A, b, lo, hi)
            np.testing.assert_allclose(walked, enumerated, atol=1e-9)


def test_bounded_lstsq_singular_and_bad_input():
    A = np.array([[1.0, 0, 0], [0, 0, 0], [0, 0, 0]])  # rank 1
    x = bounded_lstsq(A, [5.0, 1.0, 1.0], [-1, -1, -1], [1, 1, 1])
    np.testing.assert_allclose(x, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="feasible"):
        bounded_lstsq(A, [1.0, 0, 0], [0.1, -1, -1], [1, 1, 1])


def test_bounded_lstsq_a_column_nought_to_rounding_stays_at_zero_without_the_enumeration(
    monkeypatch,
):
    """A variable that moves nothing (a 5-DOF wrist roll's column under a position-and-
    approach target is 1e-16 of the others) stays at 0 and the walk certifies the rest:
    the others are the enumeration's optimum of the problem without it, and no
    enumeration runs. (The 3ⁿ enumeration itself may put such a variable on a bound: with
    every other variable on one, its free set is the nought column alone, whose
    pseudoinverse is huge.)"""
    from mearm.ik import bounded

    rng = np.random.default_rng(5)
    for _ in range(40):
        A, b = rng.normal(size=(6, 5)), 3 * rng.normal(size=6)
        dead = int(rng.integers(5))
        A[:, dead] = rng.normal(size=6) * 1e-17
        lo, hi = -rng.random(5), rng.random(5)
        live = np.arange(5) != dead
        with monkeypatch.context() as m:
            m.setattr(bounded, "_active_set", lambda *args: None)
            enumerated = bounded_lstsq(A[:, live], b, lo[live], hi[live])
        with monkeypatch.context() as m:
            m.setattr(bounded, "_SETS", {})
            m.setattr(bounded, "_active_sets", lambda n: pytest.fail("enumerated"))
            walked = bounded_lstsq(A, b, lo, hi)
        assert walked[dead] == 0.0
        np.testing.assert_allclose(walked[live], enumerated, atol=1e-9)


def test_all_names_exist():
    """Every name in mearm.ik.__all__ is importable (MinkSolver lazily)."""
    import mearm.ik

    for name in mearm.ik.__all__:
        assert getattr(mearm.ik, name) is not None
    with pytest.raises(AttributeError):
        mearm.ik.NoSuchSolver  # noqa: B018


def test_bounded_lstsq_six_variables_matches_scipy():
    """Up to six variables (3⁶ active sets), stacked 6-row problems included."""
    from scipy.optimize import lsq_linear

    rng = np.random.default_rng(8)
    for n in (5, 6):
        for _ in range(20):
            A, b = rng.normal(size=(6, n)), 3 * rng.normal(size=6)
            lo, hi = -rng.random(n), rng.random(n)
            x = bounded_lstsq(A, b, lo, hi)
            ref = lsq_linear(A, b, bounds=(lo, hi), method="bvls", tol=1e-14).x
            assert np.sum((A @ x - b) ** 2) <= np.sum((A @ ref - b) ** 2) + 1e-12
    with pytest.raises(ValueError, match="1 to 6 variables"):
        bounded_lstsq(np.ones((3, 7)), np.ones(3), -np.ones(7), np.ones(7))


# --------------------------------------------------------------------------- targets


def test_target_forms_are_equivalent(model, config):
    """A plain (x, y, z) and an IKTarget without approach give the same solve."""
    s = solver(model, config)
    a = s.solve(M1, model.home)
    b = s.solve(IKTarget(M1), model.home)
    np.testing.assert_array_equal(a.q_path, b.q_path)


@pytest.mark.parametrize(
    "position, approach, needle",
    [
        ((1.0, 2.0), None, "three finite numbers"),
        ((1.0, 2.0, np.inf), None, "three finite numbers"),
        ((1.0, 2.0, 3.0), (0.0, 0.0, 0.0), "non-zero 3-vector"),
        ((1.0, 2.0, 3.0), (0.0, 1.0), "non-zero 3-vector"),
        ((1.0, 2.0, 3.0), (0.0, np.nan, 1.0), "non-zero 3-vector"),
    ],
)
def test_bad_ik_target(position, approach, needle):
    with pytest.raises(InvalidTargetError, match=needle):
        IKTarget(position, approach)


def test_ik_target_normalises_the_approach():
    t = IKTarget((1, 2, 3), (0, 0, -2))
    assert t.approach == (0.0, 0.0, -1.0) and t.position_cm == (1.0, 2.0, 3.0)


@pytest.fixture(scope="module")
def desk():
    """The 5-DOF desk arm: picks from above, no closed form."""
    config = load_config(ROOT / "configs" / "sim_5dof.yaml")
    return config, ArmModel(config.arm)


@pytest.mark.parametrize("mode", ["paper", "coupled"])
def test_approach_target_is_met(desk, mode):
    """With an approach both the position and the approach axis converge; roll stays."""
    config, model = desk
    target = IKTarget((5.0, 15.0, 3.0), config.arm.tool.pick_approach)
    result = PdPij(model, config.controller.updated(mode=mode)).solve(target, model.home)
    assert result.converged and result.final_error_cm**2 < 1e-3
    assert result.final_approach_error_deg < 0.5
    np.testing.assert_allclose(model.approach(result.q), [0, 0, -1], atol=np.radians(0.5))
    roll = model.chain.names.index("wrist_roll")
    assert np.all(result.q_path[:, roll] == model.home[roll])


def test_approach_from_a_tilted_start(desk):
    """From a start whose tool points sideways, the approach error falls to tolerance."""
    config, model = desk
    q0 = model.chain.from_named(
        {"base_yaw": 60, "shoulder": 90, "elbow": -90, "wrist_pitch": 0, "wrist_roll": 20}
    )
    assert np.degrees(np.arccos(-model.approach(q0)[2])) > 60
    target = IKTarget((-5.0, 18.0, 5.0), (0, 0, -1))
    for kind in ("pdpij", "mink"):
        result = solve_ik(model, config.controller.updated(solver=kind), target, q0)
        assert result.converged and result.final_approach_error_deg < 0.5, kind


def test_analytic_solver_needs_a_closed_form(desk):
    config, model = desk
    with pytest.raises(ModelError) as exc:
        make_solver(model, config.controller.updated(solver="analytic"))
    message = str(exc.value)
    assert "'desk_5dof' has no closed form" in message and "'pdpij' or 'mink'" in message


def test_start_in_actuated_or_full_form_for_any_arm(desk):
    config, model = desk
    s = PdPij(model, config.controller)
    a = s.solve((5.0, 15.0, 3.0), model.chain.actuated_of(model.home))
    b = s.solve((5.0, 15.0, 3.0), model.home)
    np.testing.assert_array_equal(a.q_path, b.q_path)
    with pytest.raises(InvalidJointsError, match="expected 5 joint values"):
        s.solve((5.0, 15.0, 3.0), [0.1, 0.2])


def test_desk_arm_summary_names_its_joints(desk):
    config, model = desk
    result = PdPij(model, config.controller).solve(
        IKTarget((5.0, 15.0, 3.0), (0, 0, -1)), model.home
    )
    summary = result.summary()
    assert list(summary["joints"]) == list(model.chain.names)
    assert summary["final_approach_error_deg"] < 0.5
