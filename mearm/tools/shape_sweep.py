r"""How well the detector tells the shapes apart on rendered frames, at every size and yaw.

    mearm shape-sweep --objects 2400 --seed 0        # the sweep docs/vision.md reports

Renders frames of the simulated camera (the config's calibration and frame size,
``configs/sim.yaml`` unless ``--config``), each with 24 objects on a grid 6 cm apart:
every shape of the catalogue in turn, each of a size drawn uniformly in
``--min-cm``–``--max-cm`` and a yaw drawn uniformly in [0°, 360°), its centre jittered by
up to 0.5 cm (a calibration under which the grid leaves the frame is refused); the
frames alternate a wooden and a grey table and each has its own noise.
The detector's classes are the config's first class with each size allowed
(``diameter_cm`` = ``--max-cm``), so only the shape is judged. Prints, per shape, the
objects drawn, found, and classified right, the range of their fill (area over the
smallest enclosing circle's) and, for cubes, the largest yaw error, and a last line
labelled simulated; exits 1 when an object is missed or misclassified.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, plain_float, plain_int
from mearm.config import Config
from mearm.config.shape_catalogue import SHAPES
from mearm.errors import MearmError

#: The grid's columns and rows [cm] (a 3 cm cube's diagonal is 4.2 cm).
GRID_X_CM = (-15.0, -9.0, -3.0, 3.0, 9.0, 15.0)
GRID_Y_CM = (35.0, 41.0, 47.0, 53.0)
#: How far an object's centre is moved off its grid point, at most, along x and y [cm].
JITTER_CM = 0.5
#: Most objects one sweep draws.
MAX_OBJECTS = 100_000


@dataclass
class ShapeTally:
    """One shape's results."""

    drawn: int = 0
    found: int = 0
    right: int = 0
    fills: list[float] = field(default_factory=list)
    yaw_errors_deg: list[float] = field(default_factory=list)


def check_grid_in_frame(config: Config, max_cm: float) -> None:
    """Refuse a calibration under which the grid's objects would be drawn off the frame.

    A nearer camera (a larger scale) or another frame size can put the grid's outer
    objects past the frame's edge, where no detector sees them: the sweep would report
    them as missed, a fault of the sweep's layout, not of the shapes.

    Raises:
        MearmError: an object of the grid, at its largest size and jitter, leaves the frame.
    """
    from mearm.vision.calibration import Calibration

    reach = JITTER_CM + max_cm / math.sqrt(2)  # a cube's half diagonal, the widest shape
    corners = [
        (x + dx, y + dy)
        for x in (GRID_X_CM[0], GRID_X_CM[-1])
        for y in (GRID_Y_CM[0], GRID_Y_CM[-1])
        for dx in (-reach, reach)
        for dy in (-reach, reach)
    ]
    uv = Calibration.from_config(config.calibration).table_to_pixel(corners)
    w, h = config.camera.width_px, config.camera.height_px
    if not (np.all(np.isfinite(uv)) and np.all(uv >= 0) and np.all(uv[:, 0] < w - 1)
            and np.all(uv[:, 1] < h - 1)):  # fmt: skip
        raise MearmError(
            f"the sweep's grid (x {GRID_X_CM[0]:g} to {GRID_X_CM[-1]:g}, y {GRID_Y_CM[0]:g} to "
            f"{GRID_Y_CM[-1]:g} cm, objects up to {max_cm:g} cm) reaches past the {w}x{h} px "
            "frame under this calibration (pixels u "
            f"{uv[:, 0].min():.0f} to {uv[:, 0].max():.0f}, v {uv[:, 1].min():.0f} to "
            f"{uv[:, 1].max():.0f}): the grid lies where the paper's camera looks "
            "(configs/sim.yaml); give a --config whose camera sees all of it"
        )


def sweep(
    config: Config, objects: int, seed: int, min_cm: float, max_cm: float
) -> dict[str, ShapeTally]:
    """Draw, render and detect ``objects`` objects; per shape, what the detector said."""
    from mearm.sim.kinematic.renderer import Disc, TableRenderer, class_bgr
    from mearm.vision.calibration import Calibration
    from mearm.vision.detector import ColorDetector
    from mearm.vision.shapes import measure_shape

    calibration = Calibration.from_config(config.calibration)
    first = config.task.classes[0]
    cls = first.model_copy(update={"diameter_cm": max_cm, "shape": None})
    bgr = class_bgr(cls)
    # the colour's objects come in every size from min_cm (a class of its own) to max_cm
    small = cls.model_copy(update={"name": f"{cls.name}_small", "diameter_cm": min_cm})
    detector = ColorDetector(config.vision, calibration, [cls, small])
    rng = np.random.default_rng(seed)
    tally = {name: ShapeTally() for name in SHAPES}
    names = list(SHAPES)
    grid = [(x, y) for x in GRID_X_CM for y in GRID_Y_CM]
    renderers = {
        table: TableRenderer.from_config(
            config.camera.model_copy(update={"table": table}), calibration
        )
        for table in ("wood", "grey")
    }
    drawn = 0
    frame_index = 0
    while drawn < objects:
        discs = []
        for x, y in grid[: objects - drawn]:
            shape = names[drawn % len(names)]
            jitter = rng.uniform(-JITTER_CM, JITTER_CM, 2)
            discs.append(
                Disc(bgr, x + jitter[0], y + jitter[1], float(rng.uniform(min_cm, max_cm)),
                     shape, float(rng.uniform(0.0, 360.0)))
            )  # fmt: skip
            drawn += 1
        renderer = renderers["wood" if frame_index % 2 == 0 else "grey"]
        frame = renderer.render(discs, frame_index)
        frame_index += 1
        found = detector.detect(frame)
        mask = detector.masks(frame)[detector.class_names[0]]
        for d in discs:
            t = tally[d.shape]
            t.drawn += 1
            near = [
                f for f in found if f.table_cm is not None
                and math.dist(f.table_cm, (d.x_cm, d.y_cm)) < d.diameter_cm / 2
            ]  # fmt: skip
            if len(near) != 1:
                continue
            f = near[0]
            t.found += 1
            t.right += f.shape == d.shape
            x, y, w, h = f.bbox_px
            t.fills.append(measure_shape((mask[y : y + h, x : x + w] > 0).view(np.uint8)).fill)
            if d.shape == "cube" and f.yaw_deg is not None:
                t.yaw_errors_deg.append(abs((f.yaw_deg - d.yaw_deg + 45.0) % 90.0 - 45.0))
    return tally


def report(tally: dict[str, ShapeTally]) -> list[str]:
    """The table's lines."""
    lines = ["shape      drawn  found  right   fill min  fill max  cube yaw error max"]
    for name, t in tally.items():
        lo = f"{min(t.fills):.3f}" if t.fills else "-"
        hi = f"{max(t.fills):.3f}" if t.fills else "-"
        yaw = f"{max(t.yaw_errors_deg):.2f}°" if t.yaw_errors_deg else "-"
        lines.append(
            f"{name:<9} {t.drawn:6d} {t.found:6d} {t.right:6d}   {lo:>8}  {hi:>8}  {yaw:>18}"
        )
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Run the sweep and print its table."""
    parser = ArgumentParser(prog="mearm shape-sweep", description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument(
        "--objects", type=plain_int, default=240, help="objects to draw (default 240)"
    )
    parser.add_argument("--seed", type=plain_int, default=0, help="seed of the draws (default 0)")
    parser.add_argument("--min-cm", type=plain_float, default=1.0, help="smallest size (default 1)")
    parser.add_argument("--max-cm", type=plain_float, default=3.0, help="largest size (default 3)")
    args = parser.parse_args(argv)
    if not 1 <= args.objects <= MAX_OBJECTS:
        raise MearmError(f"--objects must be in [1, {MAX_OBJECTS}], got {args.objects}")
    if not 0 <= args.seed < 2**32:
        raise MearmError(f"--seed must be in [0, 2^32), got {args.seed}")
    if not 0.5 <= args.min_cm <= args.max_cm <= 4.0:
        raise MearmError(
            f"sizes must satisfy 0.5 <= --min-cm <= --max-cm <= 4 (objects on the 6 cm grid), "
            f"got {args.min_cm:g} and {args.max_cm:g}"
        )
    config = config_from_args(args)
    check_grid_in_frame(config, args.max_cm)
    tally = sweep(config, args.objects, args.seed, args.min_cm, args.max_cm)
    for line in report(tally):
        print(line)
    drawn = sum(t.drawn for t in tally.values())
    right = sum(t.right for t in tally.values())
    print(
        f"{right} of {drawn} objects found once with the right shape (simulated: rendered frames)"
    )
    return 0 if right == drawn else 1


if __name__ == "__main__":
    from mearm.cli import run

    run(main)
