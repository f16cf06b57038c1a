"""The paper's demo (paper §1, §4): its 24 routes, straight paths, and the two tools."""

import json
import math

import numpy as np
import pytest
from badinput import run_in_process
from conftest import ROOT, run_cli

from mearm.config import load_config
from mearm.ik import PdPij, demo_routes, run_routes
from mearm.ik.paper_port import numpy_port_solve
from mearm.kinematics import ArmModel


@pytest.fixture(scope="module")
def model(config):
    return ArmModel(config.arm)


@pytest.fixture(scope="module")
def routes(config):
    return demo_routes(config.arm.tool, config.task)


@pytest.fixture(scope="module")
def results(model, config, routes):
    return {
        mode: run_routes(PdPij(model, config.controller.updated(mode=mode)), model.home, routes)
        for mode in ("paper", "coupled")
    }


def test_demo_routes(config, routes):
    """Reds, then greens, then blues; pick at 12.76 cm, place in the class's bin."""
    assert len(routes) == 24
    names = [r.name for r in routes[::2]]
    assert names == [f"{c}{i}" for c in ("red", "green", "blue") for i in range(1, 5)]
    assert [r.action for r in routes] == ["pick", "place"] * 12
    assert routes[0].target_cm == (-10.99, 49.70, 12.76)
    for route in routes[1::2]:
        assert route.target_cm == config.task.class_named(route.class_name).bin_cm
    assert all(r.target.approach is None for r in routes)  # the paper arm: position only
    assert routes[-2].target_cm == (12.15, 51.86, 12.76)  # B4


@pytest.mark.parametrize("mode", ["paper", "coupled"])
def test_every_route_converges_like_the_paper(results, mode):
    """All 24 converge, final errors just under √1e-3 cm like the paper's 0.0297–0.0315."""
    final = np.array([r.final_error_cm for r in results[mode]])
    assert all(r.converged for r in results[mode])
    assert np.all(final < np.sqrt(1e-3)) and np.all(final > 0.025)


def test_routes_chain(model, results):
    """Each route starts where the previous one ended; the first at home."""
    for mode in results:
        rs = results[mode]
        np.testing.assert_allclose(rs[0].q_path[0], model.home)
        for prev, nxt in zip(rs, rs[1:], strict=False):
            np.testing.assert_array_equal(nxt.q_path[0], prev.q)


def test_coupled_paths_stay_within_half_a_cm_of_straight(results):
    """kp = 0.1 in coupled mode: every EE path within 0.5 cm of its straight segment."""
    deviations = [r.path_deviation_cm for r in results["coupled"]]
    assert max(deviations) < 0.5


def test_path_deviation_measures_distance_to_the_segment(results):
    r = results["coupled"][0]
    a, b = r.ee_path_cm[0], r.target_cm
    # brute force over a fine sampling of the segment
    seg = a + np.linspace(0, 1, 20001)[:, None] * (b - a)
    brute = max(np.min(np.linalg.norm(seg - p, axis=1)) for p in r.ee_path_cm)
    assert r.path_deviation_cm == pytest.approx(brute, abs=1e-3)


@pytest.mark.heavy
def test_paper_mode_is_the_bare_paper_algorithm_on_the_demo(model, config, routes, results):
    """The safeguard never acts on the demo: the whole chain equals the NumPy port's."""
    q = model.home
    for route, result in zip(routes, results["paper"], strict=True):
        assert result.blocked_steps == result.fallback_steps == 0
        _, q_path, _ = numpy_port_solve(q, route.target_cm, config.arm, config.controller)
        assert len(q_path) == len(result.q_path)
        np.testing.assert_allclose(result.q_path, q_path, atol=1e-9)
        q = q_path[-1]


def test_coupled_iterations_follow_the_linear_prediction(config, results):
    """n ≈ ln(e0/√tol)/−ln r with r the PD loop's dominant root: within 2 iterations."""
    kp, kd = config.controller.kp, config.controller.kd
    r = max(np.roots([1.0, -(1 - kp - kd), -kd]).real)
    for result in results["coupled"]:
        predicted = np.log(result.initial_error_cm / np.sqrt(1e-3)) / -np.log(r)
        assert predicted - 0.5 <= result.iterations <= predicted + 2


@pytest.mark.heavy
def test_reproduce_paper_json():
    r = run_cli("tools/reproduce_paper.py", "--mode", "paper", "--json")
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    assert report["mode"] == "paper" and len(report["rows"]) == 24
    summary = report["summary"]
    assert summary["converged"] == 24
    assert summary["min_iterations"] <= summary["mean_iterations"] <= summary["max_iterations"]
    assert report["paper"]["mean_iterations"] == 82
    assert abs(summary["mean_initial_error_cm"] - 24.99) < 0.1  # the same 24 routes


def test_reproduce_paper_text_coupled():
    """In this process (``mearm reproduce-paper``, the tool's command; the JSON test above
    runs the script as a user would)."""
    r = run_in_process(["reproduce-paper", "--mode", "coupled"], within_s=60)
    assert r.code == 0, r.stderr
    assert "mean iterations" in r.stdout and "paper: 82 (73–93)" in r.stdout
    assert r.stdout.count("converged") >= 24


def test_reproduce_paper_needs_a_scene():
    r = run_in_process(["reproduce-paper", "--config", ROOT / "configs" / "lab.yaml"])
    assert r.code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "task.scene is empty" in lines[0]


@pytest.mark.heavy
def test_bench_ik_section_runs():
    """The benchmark's ik section runs whole, on 5 of its 500 peer targets, and reports
    figures (never asserted on): its peers, the demo routes and their ratios."""
    from mearm.tools.bench import BenchOptions, bench_ik

    rows = bench_ik(BenchOptions(repeat=1, ik_targets=5))
    names = {row.name for row in rows}
    assert "PD-PIJ paper: per iteration" in names
    assert "numpy port / PD-PIJ paper, per iteration" in names
    assert "mearm fastest (closed form): per solve" in names
    assert all(row.section == "ik" for row in rows)
    # the target is held whether or not its peer could run: without Robotics Toolbox it
    # is not measured, so not met (it vanished, and the bench said "targets: none")
    (held,) = [row for row in rows if row.name == "mearm fastest / RTB ik_LM, per solve"]
    assert held.target == "≤ 0.25×"
    if not math.isfinite(held.value):
        assert held.met is False and "not measured" in held.note


def test_bench_prints_json(capsys):
    """``bench --json`` prints the machine and the chosen sections' rows as JSON (the
    motion section: a prediction, quick; the script as a process: the test below)."""
    from mearm.tools.bench import main

    assert main(["--only", "motion", "--repeat", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert "load average" in out["machine"]
    # the figures move with the libraries that make them: the line names their versions
    import mujoco
    import pinocchio

    assert f"MuJoCo {mujoco.__version__}" in out["machine"]
    assert f"Pinocchio {pinocchio.__version__}" in out["machine"]
    assert out["rows"] and all(row["section"] == "motion" for row in out["rows"])


@pytest.mark.heavy
def test_bench_rejects_unknown_section():
    r = run_cli("tools/bench.py", "--only", "nope")
    assert r.returncode == 2 and "invalid choice" in r.stderr


def test_demo_routes_follow_the_config(config):
    """Class order, grip height, TCP height above the grip and pick approach are data."""
    desk = load_config(ROOT / "configs" / "sim_5dof.yaml")
    routes = demo_routes(desk.arm.tool, desk.task)
    assert len(routes) == 2 * len(desk.task.scene)
    assert [r.class_name for r in routes[::2]] == [
        o.color for c in desk.task.classes for o in desk.task.scene if o.color == c.name
    ]
    first = desk.task.classes[0]
    obj = next(o for o in desk.task.scene if o.color == first.name)
    z = first.grip_z_cm + desk.arm.tool.tcp_above_grip_cm
    assert routes[0].target_cm == (obj.x, obj.y, z)
    assert all(r.target.approach == (0.0, 0.0, -1.0) for r in routes)
    reordered = config.model_copy(
        update={"task": config.task.model_copy(update={"classes": config.task.classes[::-1]})}
    )
    assert demo_routes(reordered.arm.tool, reordered.task)[0].name == "blue1"


def test_desk_arm_runs_its_demo_from_above():
    """The 5-DOF arm's demo: every route converges with the gripper pointing down."""
    desk = load_config(ROOT / "configs" / "sim_5dof.yaml")
    model = ArmModel(desk.arm)
    routes = demo_routes(desk.arm.tool, desk.task)
    results = run_routes(PdPij(model, desk.controller), model.home, routes)
    for r in results:
        assert r.converged and r.final_approach_error_deg < 0.5


def test_demo_iteration_counts_are_the_papers_arms(results):
    """The generic solver reproduces the 4-joint one: 64.25 (coupled) and 86.83 (paper)."""
    coupled = [r.iterations for r in results["coupled"]]
    paper = [r.iterations for r in results["paper"]]
    assert sum(coupled) == 1542 and (min(coupled), max(coupled)) == (58, 67)
    assert sum(paper) == 2084 and (min(paper), max(paper)) == (78, 98)
