"""Simulated table layouts: scene files and random scenes.

A scene is a list of ``{color, x, y}`` objects in the base frame [cm]. Random scenes put
objects at least 1 cm apart (edge to edge, so centres at least 3 cm apart for the paper's
2 cm discs) where the camera sees them whole and the arm can pick them.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import yaml
from pydantic import TypeAdapter, ValidationError

from mearm.config import Config, SceneObject
from mearm.exceptions import ConfigError, MearmError
from mearm.kinematics import check_in_box, closed_form_for

#: Edge-to-edge gap between objects in a random scene [cm] (paper §5).
MIN_GAP_CM = 1.0


class SceneError(MearmError):
    """A scene cannot be built (bad file, or no room for the objects asked for)."""


def load_scene(path: str | Path, class_names: Sequence[str] | None = None) -> list[SceneObject]:
    """Read a scene file: a YAML list of ``{color, x, y}`` [cm], ``color`` a class name.

    Args:
        path: The file.
        class_names: The config's classes; an entry naming another is refused.

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
        scene = TypeAdapter(list[SceneObject]).validate_python(data)
    except ValidationError as exc:
        problems = []
        for e in exc.errors():
            loc = ".".join(str(v) for v in e["loc"])
            problems.append(f"[{loc}]: {e['msg']} (got {e.get('input')!r})")
        raise ConfigError(str(p), problems) from None
    if class_names is not None:
        bad = [
            f"[{i}.color]: {o.color!r} is not a class (classes: {', '.join(class_names)})"
            for i, o in enumerate(scene)
            if o.color not in class_names
        ]
        if bad:
            raise ConfigError(str(p), bad)
    return scene


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
    counts: dict[str, int] | int,
    seed: int,
    *,
    max_tries: int = 20000,
) -> list[SceneObject]:
    """Draw objects at least :data:`MIN_GAP_CM` apart in the reachable camera field.

    Args:
        config: Supplies the camera field (calibration), the pick height and the arm.
        counts: Objects per class, or a total split over the classes in turn.
        seed: Random seed; the same seed gives the same scene.
        max_tries: Give up after this many rejected draws.

    Raises:
        SceneError: the objects do not fit.
    """
    if isinstance(counts, int):
        if counts < 0:
            raise SceneError(f"the number of objects must be ≥ 0, got {counts}")
        names = config.task.class_names
        order: Sequence[str] = [names[i % len(names)] for i in range(counts)]
    else:
        unknown = sorted(set(counts) - set(config.task.class_names))
        if unknown:
            raise SceneError(f"no class {unknown}; classes: {', '.join(config.task.class_names)}")
        order = [c for c in config.task.class_names for _ in range(counts.get(c, 0))]
    rng = np.random.default_rng(seed)
    diameter = max(c.diameter_cm for c in config.task.classes)
    x0, x1, y0, y1 = camera_field_cm(config, margin_cm=diameter)
    closed_form = closed_form_for(config.arm)
    min_dist = diameter + MIN_GAP_CM
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
            cls = config.task.class_named(color)
            target = (x, y, cls.grip_z_cm + config.arm.tool.tcp_above_grip_cm)
            try:
                check_in_box(target, config.arm)
                if closed_form is not None:
                    closed_form.solve(target)
            except MearmError:
                continue
            placed.append(SceneObject(color=color, x=x, y=y))
            break
    rng.shuffle(placed)
    return placed
