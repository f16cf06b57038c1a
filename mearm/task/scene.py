"""Simulated table layouts: scene files and random scenes (SPEC §4, §5).

A scene is a list of ``{color, x, y}`` objects in the base frame [cm]. Random scenes put
objects at least 1 cm apart (edge to edge, so centres at least 3 cm apart for the 2 cm
discs of SPEC §1) where the camera sees them whole and the arm can pick them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import yaml
from pydantic import TypeAdapter, ValidationError

from mearm.config import COLORS, Color, Config, SceneObject
from mearm.exceptions import ConfigError, MearmError
from mearm.kinematics import check_target
from mearm.world import OBJECT_DIAMETER_CM

#: Edge-to-edge gap between objects in a random scene [cm] (SPEC §5).
MIN_GAP_CM = 1.0


class SceneError(MearmError):
    """A scene cannot be built (bad file, or no room for the objects asked for)."""


def load_scene(path: str | Path) -> list[SceneObject]:
    """Read a scene file: a YAML list of ``{color, x, y}`` [cm].

    Raises:
        ConfigError: the file is missing, not YAML, or an entry is malformed.
    """
    p = Path(path)
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(str(p), ["scene file not found"]) from None
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ConfigError(str(p), [f"cannot read scene: {first}"]) from None
    if not isinstance(data, list):
        raise ConfigError(str(p), ["a scene is a list of {color, x, y} entries"])
    try:
        return TypeAdapter(list[SceneObject]).validate_python(data)
    except ValidationError as exc:
        problems = []
        for e in exc.errors():
            loc = ".".join(str(v) for v in e["loc"])
            problems.append(f"[{loc}]: {e['msg']} (got {e.get('input')!r})")
        raise ConfigError(str(p), problems) from None


def camera_field_cm(config: Config, margin_cm: float) -> tuple[float, float, float, float]:
    """The table area the camera sees, shrunk by ``margin_cm``: (x_min, x_max, y_min, y_max).

    Computed from the calibration homography at the image corners (an axis-aligned box
    inside the imaged quadrilateral).
    """
    H_inv = np.asarray(config.calibration.homography, dtype=float)
    w, h = config.camera.width_px, config.camera.height_px
    corners = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1]], dtype=float)
    xy = corners @ H_inv.T
    xy = xy[:, :2] / xy[:, 2:3]
    xs, ys = np.sort(xy[:, 0]), np.sort(xy[:, 1])
    # the inner box of a (near-)rectangle: second smallest and second largest
    return (xs[1] + margin_cm, xs[2] - margin_cm, ys[1] + margin_cm, ys[2] - margin_cm)


def random_scene(
    config: Config,
    counts: dict[Color, int] | int,
    seed: int,
    *,
    max_tries: int = 20000,
) -> list[SceneObject]:
    """Draw objects at least :data:`MIN_GAP_CM` apart in the reachable camera field.

    Args:
        config: Supplies the camera field (calibration), the pick height and the arm.
        counts: Objects per colour, or a total split over the colours in turn.
        seed: Random seed; the same seed gives the same scene.
        max_tries: Give up after this many rejected draws.

    Raises:
        SceneError: the objects do not fit.
    """
    if isinstance(counts, int):
        if counts < 0:
            raise SceneError(f"the number of objects must be ≥ 0, got {counts}")
        order: Sequence[Color] = [COLORS[i % len(COLORS)] for i in range(counts)]
    else:
        order = [c for c in COLORS for _ in range(counts.get(c, 0))]
    rng = np.random.default_rng(seed)
    x0, x1, y0, y1 = camera_field_cm(config, margin_cm=OBJECT_DIAMETER_CM)
    z = config.robot.gripper.pick_height_cm
    min_dist = OBJECT_DIAMETER_CM + MIN_GAP_CM
    placed: list[SceneObject] = []
    tries = 0
    for color in order:
        while True:
            tries += 1
            if tries > max_tries:
                raise SceneError(
                    f"could not place {len(order)} objects {MIN_GAP_CM:g} cm apart in the "
                    f"reachable camera field after {max_tries} draws; ask for fewer"
                )
            x, y = round(rng.uniform(x0, x1), 2), round(rng.uniform(y0, y1), 2)
            if any(np.hypot(o.x - x, o.y - y) < min_dist for o in placed):
                continue
            try:
                check_target((x, y, z), config.robot)
            except MearmError:
                continue
            placed.append(SceneObject(color=color, x=x, y=y))
            break
    rng.shuffle(placed)
    return placed
