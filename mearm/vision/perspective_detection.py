"""The detector's perspective path: regions seen by a calibrated camera placed in 3-D.

A perspective camera (:class:`~mearm.vision.pinhole.PerspectiveCamera`) sees each
object's side walls with its top face. So a region's shape is judged by its top face
fitted to the far side of its outline (:func:`top_fits`), an object is located by its
top (:func:`locate_in_perspective`), and touching objects are split by fitting their
silhouettes (:func:`split_by_silhouettes`) rather than at their cores.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import cv2
import numpy as np

from mearm.config import ColorClass
from mearm.vision.detection import Detection, _with_table_yaw
from mearm.vision.pinhole import PerspectiveCamera, TopFace, TopFit
from mearm.vision.regions import Part, _axis_ratio
from mearm.vision.shapes import ClassMatcher, measure_shape, touches_border

#: The fitted silhouettes of a split must get at most this share of the region's area
#: wrong (touching pairs stay well under it; one object too few, well over).
SILHOUETTE_WRONG = 0.08
#: At most this many objects are fitted to one region.
MAX_SPLIT = 4


def _disc_diameter_cm(color_class: ColorClass) -> float:
    """The diameter of the disc with the area of one object's footprint [cm]."""
    area = color_class.object_shape.area_cm2(color_class.diameter_cm)
    return 2.0 * math.sqrt(area / math.pi)


def _top_face(color_class: ColorClass) -> TopFace:
    """A class's top face: a disc of its diameter, or its shape's polygon of its size."""
    spec = color_class.object_shape
    corners = spec.corners_cm(color_class.diameter_cm)
    if corners is None:
        return TopFace(color_class.diameter_cm / 2.0)
    c = np.asarray(corners, dtype=float)
    return TopFace(float(np.max(np.linalg.norm(c, axis=1))), c, spec.symmetry_deg)


def top_fits(
    cam: PerspectiveCamera,
    matcher: ClassMatcher,
    class_of: Mapping[str, ColorClass],
    found: Sequence[Detection],
    regions: Sequence[np.ndarray],
    frame: np.ndarray,
) -> list[dict[str, TopFit] | None]:
    """Each region's top face fitted as each class it may be of.

    The silhouette a perspective camera sees adds the side walls to the top face, and
    a tall object's fill leaves its shape's band (2.5 cm cylinders read as squares).
    Where a region's colour has classes that name shapes, each of their top faces
    (a disc, a square, a triangle of the class's size, at its height) is fitted to
    the far half of the outline (:meth:`PerspectiveCamera.fit_top`) and the closest
    fit names the shape (:func:`best_shape`); the region is then located by its
    class's fit. ``None`` for a region merged or cut by the border, or of a colour
    whose classes name no shape: the silhouette's measure stands. Each fit is keyed
    by its class's name.
    """
    h, w = frame.shape[:2]
    out: list[dict[str, TopFit] | None] = []
    for d, region in zip(found, regions, strict=True):
        classes = [class_of[n] for n in matcher.candidates[d.color]]
        if d.merged or touches_border(d.bbox_px, w, h) or all(c.shape is None for c in classes):
            out.append(None)
            continue
        origin = (d.bbox_px[0], d.bbox_px[1])
        out.append(
            {c.name: cam.fit_top(region, origin, _top_face(c), c.height_cm, frame)
             for c in classes}
        )  # fmt: skip
    return out


def best_shape(fits: Mapping[str, TopFit], class_of: Mapping[str, ColorClass]) -> str:
    """The shape whose class's top face fits a region's outline best (least rms)."""
    return min((f.rms_cm, class_of[n].object_shape.name) for n, f in fits.items())[1]


def locate_in_perspective(
    cam: PerspectiveCamera,
    class_of: Mapping[str, ColorClass],
    classed: Sequence[tuple[int, Detection, np.ndarray]],
    frame: np.ndarray,
    fits: Sequence[dict[str, TopFit] | None] | None,
) -> list[Detection]:
    """Each detection of a class with its table position and a cube's table yaw.

    ``classed`` holds each detection's index in ``fits`` (:func:`top_fits`) and its
    region. A disc is located by its top's rim, a square or a triangle by its top's
    outline (:meth:`PerspectiveCamera.fit_top`, the fit already made for its class
    where there is one) once its shape is measured (a merged region's or one cut by the
    border is taken as a disc); a cube's yaw is its top's turn.
    """
    out = []
    for k, d, region in classed:
        if d.table_cm is not None:  # placed by the silhouette fit of a split
            out.append(_with_table_yaw(d, cam))  # its part of the silhouette's yaw
            continue
        origin = (d.bbox_px[0], d.bbox_px[1])
        cls = class_of[d.color]
        spec = cls.object_shape
        if d.shape == spec.name and spec.corners_cm(cls.diameter_cm) is not None:
            of_region = None if fits is None else fits[k]
            fit = None if of_region is None else of_region.get(cls.name)
            if fit is None:  # its shape came from the silhouette: no fit made yet
                fit = cam.fit_top(region, origin, _top_face(cls), cls.height_cm, frame)
            yaw = fit.yaw_deg if spec.name == "cube" else None
            out.append(d.evolve(table_cm=fit.centre_cm, yaw_deg=yaw))
        else:
            r = _disc_diameter_cm(cls) / 2.0
            at = cam.locate_object(region, origin, r, cls.height_cm, frame)
            out.append(d.evolve(table_cm=at))
    return out


def object_image_bounds(
    cam: PerspectiveCamera,
    centroids_px: np.ndarray,
    diameter_cm: np.ndarray,
    height_cm: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """One object's image area [px] and principal-axis ratio [-] at each centroid, each (N,).

    The calibrated camera's own outline of the object standing where the centroid's ray
    meets half its height.
    """
    at = cam.pixel_to_plane(centroids_px, height_cm / 2.0)
    bounds = [
        cam.object_image(p, d / 2.0, hh)
        for p, d, hh in zip(at, diameter_cm, height_cm, strict=True)
    ]
    area, ratio = (
        np.array(v, dtype=float).reshape(len(centroids_px)) for v in zip(*bounds, strict=True)
    )
    return area, ratio


def split_by_silhouettes(
    cam: PerspectiveCamera,
    d: Detection,
    region: np.ndarray,
    frame: np.ndarray,
    *,
    radius_cm: float,
    height_cm: float,
    most: int,
    min_area_px: float,
) -> tuple[list[Part] | None, np.ndarray | None]:
    """A region of touching objects seen in perspective: its parts and their places.

    Fits 2, 3, … ``most`` objects' silhouettes to the region
    (:meth:`PerspectiveCamera.fit_silhouettes`) and takes the fewest that explain it
    (at most :data:`SILHOUETTE_WRONG` of its area wrong); each pixel goes to the
    nearest fitted object that covers it. ``(None, None)`` if no count explains it.
    """
    r, h = radius_cm, height_cm
    origin = (d.bbox_px[0], d.bbox_px[1])
    for count in range(2, most + 1):
        centres, wrong = cam.fit_silhouettes(region, origin, r, h, count)
        if wrong <= SILHOUETTE_WRONG:
            break
    else:
        return None, None
    centres = cam.rim_centres(region, origin, centres, r, h, frame)
    # each pixel: the nearest (on the plane of the tops) of the objects covering it
    ys, xs = np.nonzero(region)
    pixels = np.column_stack([xs + origin[0], ys + origin[1]]).astype(float)
    on_top = cam.pixel_to_plane(pixels, h)
    dist = np.linalg.norm(on_top[:, None, :] - centres[None, :, :], axis=2)
    covers = np.stack(
        [cam.silhouette_coverage(c, r, h, origin, region.shape)[ys, xs] > 0.5 for c in centres],
        axis=1,
    )
    owner = np.argmin(np.where(covers, dist, dist + 1e6), axis=1)
    parts = []
    for i in range(len(centres)):
        piece = np.zeros_like(region)
        piece[ys[owner == i], xs[owner == i]] = 1
        m = cv2.moments(piece, binaryImage=True)
        if m["m00"] < min_area_px:
            return None, None
        x, y, w, hh = cv2.boundingRect(piece)
        parts.append(
            Part(
                int(m["m00"]),
                (m["m10"] / m["m00"], m["m01"] / m["m00"]),
                (x, y, w, hh),
                _axis_ratio(m),
                piece[y : y + hh, x : x + w],
            )
        )
    return parts, centres


def _classify_regions(
    matcher: ClassMatcher,
    found: Sequence[Detection],
    regions: Sequence[np.ndarray],
    frame_shape: Sequence[int],
    tops: Sequence[str | None] | None = None,
) -> list[tuple[int, Detection, np.ndarray]]:
    """Detections of colours (``color`` a colour's name) as detections of classes.

    Each region's shape is measured (:func:`measure_shape`) unless it is merged or cut
    by the image border (then ``shape`` is ``None``), and its class is
    :meth:`ClassMatcher.match`'s; regions of no class are left out.

    Args:
        matcher: The classes.
        found: The regions' detections, ``color`` the colour's name.
        regions: Each one's mask over its box, 0/1 uint8.
        frame_shape: The frame's (H, W, ...).
        tops: Each region's shape judged by its top face in perspective, where known
            (:func:`~mearm.vision.perspective_detection.top_fits`): it stands for the silhouette's.

    Returns:
        Each detection of a class, with its index in ``found`` and its region.
    """
    height, width = int(frame_shape[0]), int(frame_shape[1])
    out = []
    for k, (d, region) in enumerate(zip(found, regions, strict=True)):
        measured = None
        if not d.merged and not touches_border(d.bbox_px, width, height):
            measured = measure_shape(region)
        shape = None if measured is None else measured.shape
        if tops is not None and tops[k] is not None:
            shape = tops[k]
        name = matcher.match(d.color, shape)
        if name is None:
            continue
        yaw = None if measured is None or shape != "cube" else measured.yaw_px_deg
        out.append((k, d.evolve(color=name, shape=shape, yaw_px_deg=yaw), region))
    return out
