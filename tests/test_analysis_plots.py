"""Every plot is a real PNG that decodes, has the expected size and shows its data's colours."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mearm.analysis import fit_weibull, plots, success_vs_error
from mearm.analysis.paths import SolvedRoute
from mearm.config import Config
from mearm.kinematics import ArmModel, closed_form_for


@pytest.fixture(autouse=True)
def _matplotlib() -> None:
    """Skip without the plots extra; imported when a test runs, not in every worker's
    collection."""
    pytest.importorskip("matplotlib.image")


BLUE = (0x31, 0x82, 0xBD)  # first series / histogram edges
ORANGE = (0xE6, 0x55, 0x0D)  # second series
RED = (0xDE, 0x2D, 0x26)  # the fit, failed picks
GREEN = (0x31, 0xA3, 0x54)  # success bars


def read_png(path: Path) -> np.ndarray:
    assert path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from matplotlib import image as matplotlib_image

    image = matplotlib_image.imread(path)  # (H, W, 4) floats in [0, 1]
    assert image.ndim == 3 and image.shape[0] > 300 and image.shape[1] > 500
    rgb = (image[..., :3] * 255).round()
    assert rgb.std() > 10, "the image is (nearly) one flat colour"
    return rgb


def pixels_of(rgb: np.ndarray, color: tuple[int, int, int], tol: float = 12) -> int:
    return int((np.abs(rgb - np.array(color)).max(axis=-1) <= tol).sum())


def joint_path_route(label: str, target_cm: tuple[float, float, float], n: int = 60) -> SolvedRoute:
    """A real joint path: joints interpolated from home to the closed-form solution, FK'd."""
    config = Config()
    model = ArmModel(config.arm)
    closed_form = closed_form_for(config.arm)
    assert closed_form is not None
    q0 = model.home
    q1 = closed_form.solve(target_cm)
    s = (1 - np.cos(np.linspace(0, np.pi, n + 1))) / 2
    q_path = q0 + s[:, None] * (q1 - q0)
    ee_path = np.array([model.fk_cm(q) for q in q_path])
    target = np.asarray(target_cm)
    return SolvedRoute(
        label=label,
        kp=0.1,
        kd=0.01,
        mode="coupled",
        status="converged",
        iterations=n,
        target_cm=target,
        q_path=q_path,
        joint_names=model.chain.names,
        scale=model.chain.scale,
        ee_path_cm=ee_path,
        error_path_cm=np.linalg.norm(ee_path - target, axis=1),
        logged_ee_cm=target + [0.3, -0.2, 0.4],
    )


@pytest.fixture(scope="module")
def sample() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    errors = 0.7059 * rng.weibull(2.045, size=1200)
    success = (errors < 1.2) | (rng.random(errors.size) < 0.5)
    return errors, success


@pytest.mark.heavy
def test_histogram_with_fit(tmp_path: Path, sample) -> None:
    errors, _ = sample
    path = plots.error_histogram(errors, fit_weibull(errors), tmp_path / "h.png")
    rgb = read_png(path)
    assert pixels_of(rgb, (0x9E, 0xCA, 0xE1)) > 5000, "no histogram bars"
    assert pixels_of(rgb, RED) > 200, "no fitted density curve"


def test_histogram_without_fit(tmp_path: Path, sample) -> None:
    rgb = read_png(plots.error_histogram(sample[0], None, tmp_path / "h.png"))
    assert pixels_of(rgb, RED) == 0


def test_success_against_error(tmp_path: Path, sample) -> None:
    errors, success = sample
    sve = success_vs_error(errors, success)
    rgb = read_png(plots.success_against_error(errors, success, sve, tmp_path / "s.png"))
    assert pixels_of(rgb, (0xA1, 0xD9, 0x9B)) > 3000, "no success-rate bars"
    assert pixels_of(rgb, RED) > 50, "no failed picks or bound line"


def test_ee_paths_3d(tmp_path: Path) -> None:
    routes = [
        joint_path_route("pick red1", (-10.99, 49.7, 12.76)),
        joint_path_route("place red1", (-20.0, 35.0, 20.0)),
    ]
    rgb = read_png(plots.ee_paths_3d(routes, tmp_path / "p.png", title="pick and place"))
    assert pixels_of(rgb, BLUE) > 100 and pixels_of(rgb, ORANGE) > 100


@pytest.mark.heavy
def test_joint_angles_one_panel_per_route(tmp_path: Path) -> None:
    routes = [
        joint_path_route("pick", (5.0, 45.0, 12.76)),
        joint_path_route("place", (-20, 45, 20)),
    ]
    one = read_png(plots.joint_angles(routes[:1], tmp_path / "j1.png"))
    two = read_png(plots.joint_angles(routes, tmp_path / "j2.png"))
    assert two.shape[0] > 1.7 * one.shape[0]
    for color in (BLUE, ORANGE, GREEN):
        assert pixels_of(two, color) > 100


def test_joint_angles_any_number_of_joints(tmp_path: Path) -> None:
    """A chain of seven joints, one prismatic, draws one curve per joint, each by name."""
    n, names = 40, tuple(f"j{k}" for k in range(7))
    scale = np.array([np.pi / 180] * 6 + [0.01])
    q_path = np.linspace(0, 1, n + 1)[:, None] * np.arange(1, 8) * scale * 10
    ee_path = np.cumsum(np.ones((n + 1, 3)), axis=0)
    route = SolvedRoute(
        label="seven",
        kp=0.1,
        kd=0.01,
        mode="coupled",
        status="converged",
        iterations=n,
        target_cm=ee_path[-1],
        q_path=q_path,
        joint_names=names,
        scale=scale,
        ee_path_cm=ee_path,
        error_path_cm=np.linalg.norm(ee_path - ee_path[-1], axis=1),
    )
    assert route.joint_units == ("deg",) * 6 + ("cm",)
    assert route.start_joints == dict.fromkeys(names, 0.0)
    np.testing.assert_allclose(route.joint_path[-1], 10 * np.arange(1, 8))
    rgb = read_png(plots.joint_angles([route], tmp_path / "j7.png"))
    for color in (BLUE, ORANGE, GREEN):
        assert pixels_of(rgb, color) > 100


@pytest.mark.heavy
def test_gain_sweep(tmp_path: Path) -> None:
    routes = [
        joint_path_route(f"kp = {kp}", (-10.99, 49.7, 12.76), n=n)
        for kp, n in ((0.01, 300), (0.1, 60), (0.5, 12))
    ]
    rgb = read_png(plots.gain_sweep(routes, tmp_path / "g.png", title="kp"))
    assert rgb.shape[1] > 1200
    for color in (BLUE, ORANGE, GREEN):
        assert pixels_of(rgb, color) > 100
