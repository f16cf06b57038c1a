"""Standard rendered scenes for checking the detector: conditions and distractors.

The default config's layout (the paper's 12 objects, paper §4) under each of
:data:`CONDITIONS`, with or without :func:`distractors`, is what the tests and
``mearm vision-bench`` measure. The scenes are drawn by the simulator
(:mod:`mearm.sim.kinematic.renderer`), the layer above vision, which is imported only when a scene
is asked for.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from mearm.vision.calibration import Calibration
from mearm.vision.detector import Detection

if TYPE_CHECKING:
    from mearm.sim.kinematic.renderer import Extra


def distractors() -> tuple[Extra, ...]:
    """Things the default classes must ignore, placed around and over the paper's layout.

    Discs of hues ≈ 54°, 29° and 288° (the last falls in the paper's printed first band,
    280°–20°), a sheet of paper, shadows over objects and highlights on the table and on
    an object (the paper's third object, at (−0.40, 42.01) cm).
    """
    from mearm.sim.kinematic.renderer import Disc, Highlight, Paper, Shadow

    hue_54, hue_29, hue_288 = (40, 210, 230), (30, 130, 240), (150, 50, 130)  # BGR
    return (
        Disc(hue_54, -16.0, 55.0),
        Disc(hue_29, 16.0, 56.0),
        Disc(hue_288, 16.0, 33.0),
        Disc(hue_29, -4.0, 38.5, diameter_cm=3.0),
        Paper(-13.0, 33.5, width_cm=10.0, height_cm=6.0, angle_deg=8.0),
        Shadow(3.0, 47.0, radius_cm=5.0, depth=0.45),  # over objects of all three classes
        Shadow(-15.0, 42.0, radius_cm=3.0, depth=0.6),
        Highlight(10.0, 36.0, sigma_cm=1.5, strength=0.7),  # on the table
        Highlight(-0.40, 42.3, sigma_cm=0.25, strength=0.8),  # on the third object
    )


#: Renderer settings (over noise 2, brightness 1, gradient 0.15, wood, seed 0).
CONDITIONS: dict[str, dict] = {
    "nominal": {},
    "brightness -30%": {"brightness": 0.7},
    "brightness +30%": {"brightness": 1.3},
    "strong gradient": {"gradient": 0.3},
    "noise 5 levels": {"noise_std": 5.0},
    "grey table": {"table": "grey"},
    "dim, grey, noisy": {"brightness": 0.7, "table": "grey", "noise_std": 4.0, "seed": 3},
}

BASE_OPTIONS = {"noise_std": 2.0, "brightness": 1.0, "gradient": 0.15, "seed": 0}


def match_detections(
    found: Sequence[Detection],
    objects: Sequence[tuple[str, float, float]],
    calibration: Calibration,
) -> np.ndarray | None:
    """Position error [cm] of each object if detections and objects match one to one.

    Greedy by detection: each takes the nearest remaining object of its class.

    Args:
        found: Detections.
        objects: The true objects, (class name, x [cm], y [cm]).
        calibration: Maps the detections' centroids to the table.

    Returns:
        The errors [cm], (N,), or ``None`` when the counts or classes do not match.
    """
    if len(found) != len(objects):
        return None
    remaining = list(objects)
    errors = []
    for d in found:
        xy = calibration.pixel_to_table(d.centroid_px)
        dist = [np.hypot(xy[0] - x, xy[1] - y) if c == d.color else np.inf for c, x, y in remaining]
        k = int(np.argmin(dist))
        if not np.isfinite(dist[k]):
            return None
        errors.append(dist[k])
        remaining.pop(k)
    return np.array(errors)
