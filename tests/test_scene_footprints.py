"""Scenes of shapes: footprints measured as they lie (squares and triangles at their yaw).

The random layout and the scene check reason with circles; these tests measure the
footprints themselves, exactly, as the kinematic renderer draws them and the twin builds
them: a cube's square and a prism's triangle turned by ``yaw_deg``, a cylinder's disc.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from mearm.config import ColorClass, Config, SceneObject, load_config
from mearm.kinematics.bodies import M_PER_CM, bin_half_outer_m
from mearm.task.scene import MIN_GAP_CM, SceneError, check_scene, random_scene


def _outline(cls: ColorClass, obj: SceneObject) -> np.ndarray | None:
    """The footprint's corners in the base frame, (k, 2) [cm]; ``None`` for a disc."""
    corners = cls.object_shape.corners_cm(cls.diameter_cm)
    if corners is None:
        return None
    a = math.radians(obj.yaw_deg)
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return np.asarray(corners) @ R.T + [obj.x, obj.y]


def _point_to_segments(p: np.ndarray, poly: np.ndarray) -> float:
    """The distance from point ``p`` to a closed polygon's edges [cm]."""
    a, b = poly, np.roll(poly, -1, axis=0)
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0.0, 1.0)
    return float(np.min(np.linalg.norm(a + t[:, None] * ab - p, axis=1)))


def _inside(p: np.ndarray, poly: np.ndarray) -> bool:
    """Whether ``p`` lies in a convex polygon (corners in either turn)."""
    edges = np.roll(poly, -1, axis=0) - poly
    rel = p - poly
    cross = edges[:, 0] * rel[:, 1] - edges[:, 1] * rel[:, 0]
    return bool(np.all(cross >= 0) or np.all(cross <= 0))


def _separated(p: np.ndarray, q: np.ndarray) -> bool:
    """Whether some edge normal of two convex polygons separates them (SAT)."""
    for poly in (p, q):
        edges = np.roll(poly, -1, axis=0) - poly
        for n in np.column_stack([-edges[:, 1], edges[:, 0]]):
            sp, sq = p @ n, q @ n
            if sp.max() < sq.min() or sq.max() < sp.min():
                return True
    return False


def footprint_gap_cm(config: Config, a: SceneObject, b: SceneObject) -> float:
    """Edge-to-edge distance between two objects' footprints [cm]; < 0 where they overlap."""
    ca, cb = config.task.class_named(a.color), config.task.class_named(b.color)
    pa, pb = _outline(ca, a), _outline(cb, b)
    centre_a, centre_b = np.array([a.x, a.y]), np.array([b.x, b.y])
    if pa is None and pb is None:
        return float(np.linalg.norm(centre_a - centre_b)) - (ca.diameter_cm + cb.diameter_cm) / 2
    if pa is None or pb is None:
        poly, centre, r = (
            (pb, centre_a, ca.diameter_cm / 2) if pa is None else (pa, centre_b, cb.diameter_cm / 2)
        )
        assert poly is not None
        if _inside(centre, poly):
            return -r
        return _point_to_segments(centre, poly) - r
    if not _separated(pa, pb):
        return -1.0
    return min(
        min(_point_to_segments(p, pb) for p in pa), min(_point_to_segments(p, pa) for p in pb)
    )


def least_gap_cm(config: Config, scene: list[SceneObject]) -> tuple[float, int, int]:
    """The smallest footprint gap in a scene [cm] and its pair's indices."""
    return min((footprint_gap_cm(config, scene[i], scene[j]), i, j)
               for i, j in itertools.combinations(range(len(scene)), 2))  # fmt: skip


def test_footprint_gap_measures_a_turned_cubes_corner() -> None:
    """The measure itself: a cube at 45° reaches half its diagonal towards a disc."""
    config = load_config("configs/sim_shapes.yaml")
    cube = SceneObject(color="red_cube", x=0.0, y=45.0, yaw_deg=45.0)
    disc = SceneObject(color="red_cylinder", x=2.2, y=45.0)
    assert footprint_gap_cm(config, cube, disc) == pytest.approx(2.2 - math.sqrt(2) - 1.0)
    square = cube.model_copy(update={"yaw_deg": 0.0})
    assert footprint_gap_cm(config, square, disc) == pytest.approx(0.2)
    other = SceneObject(color="red_cube", x=2.5, y=45.0, yaw_deg=45.0)
    assert footprint_gap_cm(config, cube, other) < 0  # corner into corner
    assert footprint_gap_cm(config, square, other.model_copy(update={"yaw_deg": 0.0})) == (
        pytest.approx(0.5)
    )


def test_random_shapes_scenes_keep_the_gap_between_footprints_at_any_yaw() -> None:
    """Every pair of a random scene of cubes, cylinders and prisms is MIN_GAP_CM apart, edge
    to edge, measured on the turned squares and triangles (12 seeds of 12 objects)."""
    config = load_config("configs/sim_shapes.yaml")
    for seed in range(993000, 993012):
        scene = random_scene(config, 12, seed)
        gap, i, j = least_gap_cm(config, scene)
        assert gap >= MIN_GAP_CM, (seed, scene[i], scene[j], gap)


def test_seed_992004_lays_its_shapes_apart() -> None:
    """The scene where a cube was later held 0.22 cm into a neighbour starts well apart:
    that cube slipped from the jaws on its way to the bin and landed beside the cylinder."""
    config = load_config("configs/sim_shapes_mujoco.yaml")
    scene = random_scene(config, 12, 992004)
    gap, _, _ = least_gap_cm(config, scene)
    assert gap >= MIN_GAP_CM
    check_scene(config, scene, "--random")


@pytest.mark.parametrize(
    ("neighbour", "rule"),
    [
        # the cylinder 2.2 cm away: its disc clears the cube's half side, not its corner
        ({"color": "red_cylinder", "x": 2.2, "y": 45.0}, "centres must be at least 2.41421 cm"),
        # another cube at 45°, 2.5 cm away: corner into corner
        ({"color": "red_cube", "x": 2.5, "y": 45.0, "yaw_deg": 45.0}, "at least 2.82843 cm"),
    ],
)
def test_a_scene_with_a_turned_cube_into_its_neighbour_is_refused(
    neighbour: dict[str, object], rule: str
) -> None:
    """A hand-laid cube whose corner reaches into its neighbour is refused, naming the rule."""
    config = load_config("configs/sim_shapes.yaml")
    cube = SceneObject(color="red_cube", x=0.0, y=45.0, yaw_deg=45.0)
    other = SceneObject.model_validate(neighbour)
    assert footprint_gap_cm(config, cube, other) < 0
    with pytest.raises(SceneError, match="overlaps") as err:
        check_scene(config, [cube, other], "scene.yaml")
    assert rule in str(err.value)


def test_a_turned_cubes_corner_in_a_bin_is_refused() -> None:
    """A cube at 45° whose corner reaches over a bin's wall is refused, as its disc would be."""
    config = load_config("configs/sim_shapes.yaml")
    cls = config.task.class_named("red_cylinder")
    half = bin_half_outer_m(cls) / M_PER_CM
    # 1.2 cm right of the wall's outer face: clear of it by its half side (1 cm), not by
    # its half diagonal (1.41 cm)
    x = cls.bin_cm[0] + half + 1.2
    cube = SceneObject(color="red_cube", x=x, y=cls.bin_cm[1], yaw_deg=45.0)
    with pytest.raises(SceneError, match="inside red_cylinder's bin"):
        check_scene(config, [cube], "scene.yaml")
