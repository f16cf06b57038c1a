"""Work-area polygons in pixels: the area one encloses, and why one can hold no object.

Here, below the config's models, so that ``vision.work_area_px`` is refused as the config
loads (a file, an ``extends``, a ``--set``) in the same words every command that takes a
polygon uses (:func:`mearm.vision.work_area.flat_work_area`).
"""

from __future__ import annotations

from collections.abc import Sequence

#: A polygon enclosing less than this [px²] has its points on one line (or on one point):
#: it holds no object, and a frame's pixels it keeps are the line's, by rounding.
MIN_ENCLOSED_PX2 = 1.0


def enclosed_px2(polygon_px: Sequence[tuple[float, float]]) -> float:
    """The area a polygon (u, v) encloses [px²] (the shoelace formula)."""
    n = len(polygon_px)
    twice = sum(
        float(polygon_px[i][0]) * float(polygon_px[(i + 1) % n][1])
        - float(polygon_px[(i + 1) % n][0]) * float(polygon_px[i][1])
        for i in range(n)
    )
    return abs(twice) / 2.0


def extent(polygon_px: Sequence[tuple[float, float]]) -> str:
    """Where a polygon's points lie, for messages: ``u U0 to U1, v V0 to V1 px``."""
    u = [p[0] for p in polygon_px]
    v = [p[1] for p in polygon_px]
    return f"u {min(u):g} to {max(u):g}, v {min(v):g} to {max(v):g} px"


def why_flat(polygon_px: Sequence[tuple[float, float]]) -> str | None:
    """Why a polygon can hold no object whatever the frame, or ``None``.

    Its points on one line enclose no area. The reason follows the name the polygon was
    given by (``vision.work_area_px``, ``--work-area``).
    """
    area = enclosed_px2(polygon_px)
    if area >= MIN_ENCLOSED_PX2:
        return None
    return (
        f"encloses {area:g} px² (its points, {extent(polygon_px)}, lie on one line), "
        "so nothing can be detected in it: give the corners of the area around the objects"
    )
