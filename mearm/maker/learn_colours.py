r"""``mearm learn-colours``: teach each class its colour from the camera's own frames.

Click once on an object of each class (or give the pixel), and the class's colour is
fitted from the pixels there (:mod:`mearm.vision.teaching`): an ellipse in CIELAB's
a*b* plane with a lightness range, on frames white-balanced against the table. The new
config extends the old one with the learned colours, the table's median colour (each
frame is balanced to it: a lamp or the camera's auto white balance does not move the
colours) and the work area (the table's outline found around the samples, or
``--work-area``; ``whole_frame`` with ``--whole-frame`` or when no table is found, so that
no polygon of the config extended is kept); ``mearm detect --config NEW.yaml`` uses them.
The work area is in the first image's pixels: when its size is not the config's camera's
(``camera.width_px`` × ``camera.height_px``) and it does not cover the camera's whole
frame, a warning line says how much of it it covers. ::

    mearm learn-colours frame.png --sample red=212,340 --sample blue=400,236 \
        --config sim --out mine.yaml
    mearm learn-colours --camera --pick --config lab.yaml --out lab_learned.yaml

``--sample CLASS=U,V`` (repeatable; ``CLASS=U,V@I`` for the I-th image, from 0) names a
pixel of an object of the class; ``--pick`` shows the first frame and asks for a click
on each class in turn (needs a display; Esc skips a class, and with every class skipped
nothing is taught: refused). A class not sampled keeps its hue bands.
``--camera`` reads the frame ``mearm detect --camera`` reads (the twin's render under
``simulator: mujoco``). ``--set KEY=VALUE`` changes the config before teaching, and the
new config carries each value set. ``--work-area`` points may lie past the frame (from
-4096 to 8192 px; ``--work-area -5,3 ...`` and ``--work-area=-5,3 ...`` alike): the
polygon is clipped to it.

Refused (exit 2, one line; a sample quoted as typed): a sample outside its image, a
class the config does not have, two classes sampled on one colour or one class on two, a
sample on a grey or black pixel or on the table's colour, a first image with no table
around the samples, a ``--work-area`` with no area (as ``mearm detect`` refuses it in
``vision.work_area_px``), with a point out of that range, with no pixel in a frame (the
message gives the frame's size) or with none of a class's samples in it, a work area
whose median colour (taken for the table's) is a clicked object's, colours taught that
do not keep a clicked object as an object of its class on the frame it was clicked on
(the config would find nothing there), and an ``--out`` that is the ``--config`` or one
of the images (even with ``--force``).
"""

from __future__ import annotations

import argparse
import copy
import math
import os
import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from mearm.cli import (
    IMAGE_SUFFIXES,
    ArgumentParser,
    check_output_file,
    config_from_args,
    config_path_value,
    plain_float,
    run,
    say_on_stderr,
    write_text_atomic,
)
from mearm.config import Config
from mearm.config.compose import merge
from mearm.config.files import load_config, resolve_config_path
from mearm.config.loader import config_from_dict, parse_override
from mearm.config.sections import MAX_FRAME_SIDE_PX, WHOLE_FRAME
from mearm.errors import MearmError
from mearm.fileio import file_identity, write_atomic
from mearm.vision.calibration import camera_geometry, object_width_px
from mearm.vision.detector import ColorDetector
from mearm.vision.errors import SampleError
from mearm.vision.image import read_image
from mearm.vision.learned import lab_of
from mearm.vision.teaching import (
    TABLE_DELTA_E,
    TABLE_MIN_SHARE,
    Sample,
    Taught,
    click_lab,
    teach,
)
from mearm.vision.work_area import check_work_area, flat_work_area, pixels_inside
from mearm.yamlio import load_yaml_text

#: ASCII digits only: ``\d`` matches other scripts' digits too (``@١`` read as image 1).
_SAMPLE = re.compile(r"^([^=\s]+)=([-+0-9.eE]+),([-+0-9.eE]+)(?:@([0-9]+))?$")
#: A ``--work-area`` point as typed: U,V, each a plain decimal, either signed.
_POINT = re.compile(r"^[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?,[-+]?[0-9.]+(?:[eE][-+]?[0-9]+)?$")
#: The pixels a work-area point may be at: the config's bounds (past the frame: clipped).
WORK_AREA_RANGE_PX = (-MAX_FRAME_SIDE_PX, 2 * MAX_FRAME_SIDE_PX)


def parse_sample(text: str) -> Sample:
    """``CLASS=U,V`` or ``CLASS=U,V@I`` as a :class:`Sample` (ValueError if malformed)."""
    m = _SAMPLE.match(text.strip())
    if m is None:
        raise ValueError(
            f"--sample {text!r}: expected CLASS=U,V, or CLASS=U,V@I for the I-th image from 0 "
            "(e.g. red=212,340 or red=212,340@1)"
        )
    u, v = float(m.group(2)), float(m.group(3))
    if not (math.isfinite(u) and math.isfinite(v)):
        raise ValueError(f"--sample {text!r}: U and V must be finite pixels")
    return Sample(m.group(1), u, v, int(m.group(4) or 0), typed=text.strip())


def parse_point(text: str) -> tuple[float, float]:
    """``U,V`` as a pixel (ValueError if malformed)."""
    parts = text.split(",")
    if not text.isascii() or "_" in text:  # float() reads 1_0 and other scripts' digits
        raise ValueError(f"--work-area {text!r}: expected U,V pixels in plain decimals")
    try:
        u, v = (float(p) for p in parts)
    except ValueError:
        raise ValueError(f"--work-area {text!r}: expected U,V pixels") from None
    if not (math.isfinite(u) and math.isfinite(v)):
        raise ValueError(f"--work-area {text!r}: U and V must be finite")
    lo, hi = WORK_AREA_RANGE_PX
    if not (lo <= u <= hi and lo <= v <= hi):
        raise ValueError(
            f"--work-area {text}: U and V must be from {lo} to {hi} px (a polygon past "
            "the image is clipped to it)"
        )
    return u, v


#: What a work-area point typed wrong looks like (``640,nan``, ``100,x``): a pair.
_PAIR = re.compile(r"^[-+\w.]+,[-+\w.]+$")


def _looks_like_point(arg: str) -> bool:
    """A point, or a pair typed as one that ``--work-area`` refuses in its own words.

    ``640,nan`` was left for an IMAGE and refused as "unrecognized arguments"; a picture's
    name with a comma (``shot,1.png``) stays an IMAGE.
    """
    if _POINT.match(arg):
        return True
    return bool(_PAIR.match(arg)) and Path(arg).suffix.lower() not in IMAGE_SUFFIXES


def attach_work_area_points(argv: Sequence[str]) -> list[str]:
    """``--work-area -5,3 700,-50 ...`` as ``--work-area=-5,3 --work-area=700,-50 ...``.

    argparse takes a value that starts with ``-`` for an option, so a polygon reaching
    past the frame's left or top edge was refused as "unrecognized arguments"; each
    point that follows ``--work-area`` (or ``--work-area=U,V``) is attached to it.
    """
    out: list[str] = []
    taking = False
    for arg in argv:
        if taking and _looks_like_point(arg):
            if out[-1] == "--work-area":
                out.pop()
            out.append(f"--work-area={arg}")
            continue
        taking = arg == "--work-area" or arg.startswith("--work-area=")
        out.append(arg)
    return out


def pick_samples(frame: np.ndarray, names: Sequence[str]) -> list[Sample]:
    """Ask for one click on an object of each class on ``frame`` (an OpenCV window)."""
    import cv2

    clicked: list[tuple[int, int]] = []

    def on_mouse(event: int, x: int, y: int, *_: Any) -> None:
        if event == cv2.EVENT_LBUTTONDOWN:
            clicked.append((x, y))

    title = "mearm learn-colours"
    try:
        cv2.namedWindow(title)
        cv2.setMouseCallback(title, on_mouse)
    except cv2.error:
        raise MearmError("--pick needs a display (give --sample CLASS=U,V instead)") from None
    out = []
    try:
        for name in names:
            shown = frame.copy()
            cv2.putText(
                shown,
                f"click on a {name} object (Esc: skip)",
                (10, 24),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.6,
                (255, 255, 255),
                2,
            )
            clicked.clear()
            while not clicked:
                cv2.imshow(title, shown)
                if cv2.waitKey(30) == 27:
                    break
            if clicked:
                out.append(Sample(name, float(clicked[0][0]), float(clicked[0][1])))
    finally:
        cv2.destroyWindow(title)
    return out


def set_values(config: Config, overrides: Sequence[str]) -> dict[str, Any]:
    """The keys ``--set`` changed, with their values in ``config``, as a config's mapping.

    ``config`` is the one loaded with every ``--set``: merged over the config extended
    (an ``extends``), the mapping gives it back. A list of named items (``task.classes``,
    ``arm.joints``) is entered by its items' names, as ``extends`` merges them; any other
    list is written whole.
    """
    data = config.model_dump(mode="json")
    out: dict[str, Any] = {}
    for text in overrides:
        path, _ = parse_override(text)
        value: Any = data
        keys: list[str] = []
        for part in path:
            if isinstance(value, list):
                if not all(isinstance(item, dict) and "name" in item for item in value):
                    break  # a list of values or points: written whole
                named = [item for item in value if item["name"] == part]
                value = named[0] if named else value[int(part)]  # by name or by index
                keys.append(value["name"])
            else:
                value = value[part]
                keys.append(part)
        node = out
        for key in keys[:-1]:
            node = node.setdefault(key, {})
            if not isinstance(node, dict):  # a whole list set: it holds this value already
                break
        else:
            node[keys[-1]] = copy.deepcopy(value)
    return out


def learned_yaml(base: str, taught: Taught, settings: dict[str, Any] | None = None) -> dict:
    """The new config's data: ``extends`` the old one, with what was learned.

    ``settings`` (:func:`set_values`: what ``--set`` changed) come first; what was
    learned is merged over them. No work area taught is ``whole_frame``, not nothing: the
    reference colour is the whole frame's, and the config extended may hold a polygon (or
    ``null``, the table's outline under a perspective calibration).
    """
    vision: dict[str, Any] = {"reference_bgr": [round(v, 2) for v in taught.reference_bgr]}
    area = taught.work_area_px
    vision["work_area_px"] = (
        WHOLE_FRAME if area is None else [[round(u, 1), round(v, 1)] for u, v in area]
    )
    classes = {}
    for name, m in taught.colours.items():
        classes[name] = {
            "learned_colour": {
                "ab_mean": [round(v, 3) for v in m.ab_mean],
                "ab_cov": [round(v, 3) for v in m.ab_cov],
                "lightness": [round(v, 2) for v in m.lightness],
                "max_distance": round(m.max_distance, 3),
                "chroma_min": round(m.chroma_min, 2),
                **(
                    {}
                    if m.chroma_lightness is None
                    else {"chroma_lightness": round(m.chroma_lightness, 2)}
                ),
            }
        }
    learned = {"vision": vision, "task": {"classes": classes}}
    return {"extends": base, **merge(settings or {}, learned)}


def _parser() -> ArgumentParser:
    """The command line of :func:`main`."""
    parser = ArgumentParser(
        prog="mearm learn-colours",
        description="Teach each class its colour from clicks on the camera's own frames.",
        epilog="Exit status: 0 written, 2 bad input (one line on stderr).",
    )
    parser.add_argument(
        "images", nargs="*", type=Path, metavar="IMAGE", help="frames to learn from"
    )
    parser.add_argument(
        "--config",
        type=config_path_value,
        required=True,
        help="the config to extend: a YAML file, or the name of one shipped with mearm",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="change one config value before teaching, e.g. --set camera.noise_std=0; "
        "NEW.yaml keeps it (repeatable)",
    )
    parser.add_argument(
        "--out", type=Path, required=True, metavar="NEW.yaml", help="config to write"
    )
    parser.add_argument(
        "--force", action="store_true", help="replace an existing NEW.yaml (never --config)"
    )
    parser.add_argument(
        "--sample",
        action="append",
        default=[],
        metavar="CLASS=U,V",
        help="a pixel on an object of CLASS (repeatable; CLASS=U,V@I: image I)",
    )
    parser.add_argument(
        "--camera", action="store_true", help="learn from one frame of the config's camera"
    )
    parser.add_argument("--pick", action="store_true", help="click the samples on the first frame")
    parser.add_argument(
        "--radius",
        type=plain_float,
        default=4.0,
        metavar="PX",
        help="pixels within this of a sample are its colour (default 4)",
    )
    parser.add_argument(
        "--work-area",
        nargs="+",
        action="extend",
        default=None,
        metavar="U,V",
        help="the work area's polygon in pixels, clipped to the frame (default: the table found)",
    )
    parser.add_argument(
        "--whole-frame",
        action="store_true",
        help="the work area is the whole frame (work_area_px: whole_frame)",
    )
    return parser


def _checked_arguments(
    parser: ArgumentParser, args: argparse.Namespace
) -> tuple[list[Sample], list[tuple[float, float]] | None]:
    """The samples and work area given; exit 2 (``parser.error``) on a bad argument."""
    if bool(args.images) == args.camera:
        parser.error("give IMAGE paths or --camera (one of the two)")
    if not args.sample and not args.pick:
        parser.error("give at least one --sample CLASS=U,V, or --pick")
    if not 0.5 <= args.radius <= 50 or not math.isfinite(args.radius):
        parser.error(f"--radius must be from 0.5 to 50 px, got {args.radius:g}")
    if args.work_area is not None and args.whole_frame:
        parser.error("give --work-area or --whole-frame, not both")
    try:
        samples = [parse_sample(s) for s in args.sample]
        area = None if args.work_area is None else [parse_point(p) for p in args.work_area]
    except ValueError as exc:
        parser.error(str(exc))
    if area is not None and len(area) < 3:
        parser.error(f"--work-area needs at least 3 points, got {len(area)}")
    flat = None if area is None else flat_work_area(area, "--work-area")
    if flat is not None:
        parser.error(flat)  # mearm detect and mearm sort refuse the same polygon
    return samples, area


def _check_samples(
    samples: list[Sample], names: Sequence[str], config_name: str, n_images: int
) -> None:
    """Every sample names a class of the config and an image given."""
    for s in samples:
        if s.name not in names:
            raise MearmError(
                f"sample {s}: no class '{s.name}' in {config_name} (classes: {', '.join(names)})"
            )
        if s.image >= max(1, n_images):
            raise MearmError(f"sample {s}: there is no image {s.image} (images from 0)")


def _frames(args: argparse.Namespace, config: Config) -> tuple[list[np.ndarray], list[str]]:
    """The frames to learn from and where each came from.

    ``--camera``: the frame ``mearm detect --camera`` reads, the twin's render under
    the MuJoCo twin (:func:`mearm.backends.grab_frame`), so what is taught is what is
    detected.
    """
    if args.camera:
        from mearm.backends import grab_frame
        from mearm.task.check import kinematic_camera_warning

        unused = kinematic_camera_warning(config)  # the twin's render: said before its frame
        if unused is not None:
            say_on_stderr(f"warning: {unused}", "mearm learn-colours")
        frames = [grab_frame(config)]
        sources = ["camera"]
    else:
        frames = [read_image(p) for p in args.images]
        sources = [str(p) for p in args.images]
    return frames, sources


def _check_not_replacing(
    out: Path, config_name: str, *, force: bool, images: Sequence[Path] = ()
) -> None:
    """Refuse, before any work, to write over the config extended, an image, or any file.

    With ``force`` an existing file other than the inputs is replaced: a second run must
    not lose a config a maker wrote unless asked to; the frames taught from are never
    replaced (``--force`` is for an older NEW.yaml).

    Raises:
        MearmError: ``out`` is the ``--config`` file or one of ``images`` (by any name),
            or exists and ``force`` is not set.
    """
    if not out.exists():
        return
    mine = file_identity(out)
    if mine is not None and any(file_identity(p) == mine for p in images):
        raise MearmError(
            f"--out {out} is one of the images it learns from: give another --out "
            "(NEW.yaml; --force never replaces an input)"
        )
    try:
        extended = resolve_config_path(config_name)
    except MearmError:  # not a config at all: load_config says so next
        extended = None
    if extended is not None and extended.exists() and out.resolve() == extended.resolve():
        raise MearmError(
            f"--out {out} is the config it extends (--config {config_name}): the taught "
            "colours go in a new file that extends it; give another --out"
        )
    if not force:
        raise MearmError(f"--out {out} exists: pass --force to replace it")


def _check_extends_found(out: Path, config_name: Path) -> None:
    """Refuse, before any work, an ``--out`` whose ``extends`` would name another file.

    A packaged ``--config`` (a name, not a file) is written as ``extends: NAME``, which
    the loader reads as the file ``NAME`` beside ``out`` if there is one
    (:func:`mearm.config.compose.expand_config`): ``--out rig/sim`` would then extend
    itself, and a file ``rig/sim`` beside ``--out`` would be extended instead of the
    packaged config. Either config would not be what was asked, so nothing is written.

    Raises:
        MearmError: ``out`` is named ``NAME``, or its folder holds a file of that name.
    """
    if config_name.exists():  # a file: written as a path relative to out's folder
        return
    name = str(config_name)
    if out.name == name:
        raise MearmError(
            f"--out {out}: the taught config extends the packaged {name}, but a file "
            f"named {name} extends itself and would not load: give --out another name "
            f"(e.g. {name}_learned.yaml)"
        )
    if (out.parent / name).is_file():
        raise MearmError(
            f"--out {out}: the taught config extends the packaged {name}, but the file "
            f"{out.parent / name} would be read instead: write it in another folder"
        )


def _check_area_on_frames(
    area: Sequence[tuple[float, float]], frames: Sequence[np.ndarray], sources: Sequence[str]
) -> None:
    """Refuse a ``--work-area`` that keeps no pixel of a frame taught on.

    Its points are in the frames' pixels and may lie past them (clipped), but a polygon
    wholly off a frame keeps nothing of it: the user must move its points into the frame,
    so the message says where the polygon lies and the frame's size (the samples, all
    outside it then, are not the cause). The check is ``mearm detect``'s
    (:func:`~mearm.vision.work_area.check_work_area`); its warning (a polygon drawn on
    frames of another size) cannot apply to one given for these frames.

    Raises:
        ConfigError: no pixel of one of the frames lies in the polygon.
    """
    for frame, source in zip(frames, sources, strict=True):
        h, w = frame.shape[:2]
        check_work_area(
            area,
            (w, h),
            source,
            name="--work-area",
            advice=f"give its points in that frame's pixels (0 <= U < {w}, 0 <= V < {h}; "
            "a polygon past the frame is clipped to it)",
        )


def clicked_region_px(mask: np.ndarray, s: Sample, radius_px: float) -> int:
    """The largest 8-connected region of ``mask`` within ``radius_px`` of a click [px].

    8-connected, as the detector's regions are; 0: the mask keeps nothing there.
    """
    h, w = mask.shape[:2]
    r = math.ceil(radius_px)
    u, v = int(s.u_px), int(s.v_px)
    x0, x1, y0, y1 = max(u - r, 0), min(u + r + 1, w), max(v - r, 0), min(v + r + 1, h)
    ys, xs = np.mgrid[y0:y1, x0:x1]
    near = (xs - s.u_px) ** 2 + (ys - s.v_px) ** 2 <= radius_px**2
    if not mask[y0:y1, x0:x1][near].any():
        return 0
    _, labels, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    touched = np.unique(labels[y0:y1, x0:x1][near & (mask[y0:y1, x0:x1] > 0)])
    return int(stats[touched, cv2.CC_STAT_AREA].max())


def _check_reference_is_not_an_object(
    taught: Taught, frames: Sequence[np.ndarray], samples: Sequence[Sample], radius_px: float
) -> None:
    """Refuse a work area whose median colour is a clicked object's.

    The work area's median colour is taken for the table's (``vision.reference_bgr``):
    every frame is balanced to it, and a detection is kept only where it stands on that
    colour. A ``--work-area`` drawn tightly around an object makes the object the table:
    the config written found nothing, even on the frame it was taught on. The rule is
    the teaching's own for a click on the table's colour (within ΔE
    :data:`~mearm.vision.teaching.TABLE_DELTA_E`), the other way round: a table on a
    click's colour. Bad input (exit 2): the work area given is at fault.

    Raises:
        SampleError: the reference colour is within that ΔE of a click's colour.
    """
    reference = lab_of(np.clip(np.round(taught.reference_bgr), 0, 255))
    table_lab = np.array(taught.table_lab)
    for s in samples:
        off = float(np.linalg.norm(click_lab(frames[s.image], s, radius_px, table_lab) - reference))
        if off <= TABLE_DELTA_E:
            raise SampleError(
                str(s),
                f"the work area's median colour, which stands for the table's "
                f"(vision.reference_bgr), is this object's (ΔE {off:.0f}; the table's must "
                f"differ by more than {TABLE_DELTA_E:g}), so the config would find nothing: "
                "give a --work-area around the table, not around the object (or --whole-frame)",
            )


def _check_taught_finds(
    config: Config,
    learned: Config,
    frames: Sequence[np.ndarray],
    sources: Sequence[str],
    samples: Sequence[Sample],
    radius_px: float,
) -> None:
    """Refuse colours that do not keep the objects they were taught on.

    The detector of ``learned`` (the config to be written; the camera's geometry is
    ``config``'s: teaching changes only the vision and the classes) classifies the
    frames taught on as ``mearm detect --config NEW.yaml`` does: the work area, each
    frame balanced to ``vision.reference_bgr``, the colours taught. Each clicked object
    must be kept as its class, a region (:func:`clicked_region_px`) of at least
    ``vision.min_area_px``, the least the detector takes for an object; otherwise the
    config finds nothing there, on the very frames it was taught on. What the detector
    does with a region after its colour (the class's shape, how regions merge) is not
    what teaching changes, so it is not judged here. Bad input (exit 2): the clicks or
    the work area given are at fault, and the message names the click.

    Raises:
        SampleError: a clicked object is not kept as its class with the colours taught.
    """
    detector = ColorDetector.from_config(
        learned.vision,
        config.calibration,
        config.camera,
        learned.task.classes,
        geometry=camera_geometry(config.calibration, config.camera),
    )
    least = learned.vision.min_area_px
    masks: dict[int, dict[str, np.ndarray]] = {}
    for s in samples:
        if s.image not in masks:
            masks[s.image] = detector.masks(frames[s.image])
        kept = clicked_region_px(masks[s.image][s.name], s, radius_px)
        if kept < least:
            raise SampleError(
                str(s),
                f"the colours taught keep {kept} px of '{s.name}' at the click in "
                f"{sources[s.image]} (an object needs vision.min_area_px, {least:g}), so "
                "the config would find nothing there: click on the middle of an object of "
                "the class, or give a work area that holds the whole object",
            )


def frame_object_px(config: Config, shape: Sequence[int]) -> float:
    """About one object's width [px] in a frame of ``shape`` (H, W, ...).

    The calibration's, at the centre of its frame; a frame of another size (a photo
    resized, a camera set to another resolution) is taken for the same view at another
    scale: the width times the mean (geometric) of the two sides' ratios. The table's
    colour is read 1-2.5 object widths from the samples, so on a 4000x3000 photo of a
    640x480 calibration an unscaled width read it inside the objects.
    """
    camera = config.camera
    width = object_width_px(
        config.calibration, camera, max(c.diameter_cm for c in config.task.classes)
    )
    h, w = int(shape[0]), int(shape[1])
    return width * math.sqrt((w / camera.width_px) * (h / camera.height_px))


def _warn_if_another_size(
    taught: Taught, config: Config, size_px: tuple[int, int], source: str
) -> None:
    """One line on stderr when the work area is not in the camera's pixels.

    The polygon is in the first frame's pixels (``size_px``, (width, height)); the
    config's camera gives frames of ``camera.width_px`` × ``camera.height_px`` (and refuses
    any other), where the polygon keeps other pixels unless it covers them all: taught on
    a photo, a config used on the camera saw nothing outside that part and said nothing.
    """
    camera = (config.camera.width_px, config.camera.height_px)
    if taught.work_area_px is None or size_px == camera:
        return
    share = pixels_inside(taught.work_area_px, camera) / (camera[0] * camera[1])
    if share == 1.0:
        return
    say_on_stderr(
        f"warning: vision.work_area_px is in the pixels of {source} ({size_px[0]}x{size_px[1]} "
        f"px), but the config's camera gives {camera[0]}x{camera[1]} px frames "
        f"(camera.width_px, camera.height_px), of which it covers {_percent(share)}: to "
        "detect on "
        "the camera, teach on its frames (--camera) or give --whole-frame",
        "mearm learn-colours",
    )


def _percent(share: float) -> str:
    """``share`` (0 … 1) as a percentage that reads 100 % or 0 % only when it is.

    Whole percents, or as many decimals as keep a share short of all (or above none)
    from reading as all (or none): 0.9964 is ``99.6%``, not ``100%``.
    """
    for decimals in range(6):
        text = f"{share:.{decimals}%}"
        number = float(text[:-1])
        if (number < 100 or share >= 1) and (number > 0 or share <= 0):
            return text
    return text


def _print_taught(taught: Taught, *, whole_frame: bool) -> None:
    """One line per learned colour, then the table's colour and the work area.

    A work area of the whole frame not asked for (``whole_frame``) says why: no table
    was found around the samples.
    """
    for name, m in taught.colours.items():
        print(
            f"{name}: a*b* ({m.ab_mean[0]:.1f}, {m.ab_mean[1]:.1f}), chroma >= {m.chroma_min:.1f}, "
            f"L* {m.lightness[0]:.0f}-{m.lightness[1]:.0f}, radius {m.max_distance:.2f}"
        )
    if taught.work_area_px is not None:
        where = f"{len(taught.work_area_px)}-point polygon"
    elif whole_frame:
        where = "whole frame"
    else:
        where = (
            "whole frame (no table found: the pixels of the colour read around the samples "
            f"cover under {TABLE_MIN_SHARE:.0%} of the frame; --work-area U,V ... gives one)"
        )
    print(f"table L*a*b* ({', '.join(f'{v:.1f}' for v in taught.table_lab)}); work area: {where}")


def main(argv: Sequence[str] | None = None) -> int:
    """Teach the classes their colours and write the new config; see the module docstring."""
    parser = _parser()
    args = parser.parse_args(attach_work_area_points(sys.argv[1:] if argv is None else argv))
    samples, area = _checked_arguments(parser, args)
    check_output_file(args.out, "--out")
    _check_not_replacing(args.out, args.config, force=args.force, images=args.images)
    _check_extends_found(args.out, args.config)
    config = config_from_args(args)
    names = config.task.class_names
    _check_samples(samples, names, str(args.config), len(args.images))
    frames, sources = _frames(args, config)
    if area is not None:
        _check_area_on_frames(area, frames, sources)
    if args.pick:
        samples += pick_samples(frames[0], [n for n in names if n not in {s.name for s in samples}])
        if not samples:  # each class skipped: a config taught nothing is not written
            raise MearmError(
                "--pick: no class was clicked (Esc skipped each), so nothing was taught"
            )
    taught = teach(
        frames,
        samples,
        radius_px=args.radius,
        object_px=frame_object_px(config, frames[0].shape),
        work_area_px=area,
        find_area=not args.whole_frame,
    )
    _check_reference_is_not_an_object(taught, frames, samples, args.radius)
    base = (
        os.path.relpath(resolve_config_path(args.config).resolve(), args.out.resolve().parent)
        if args.config.exists()
        else str(args.config)
    )
    import yaml

    sizes = " ".join(
        f"{src} ({f.shape[1]}x{f.shape[0]} px)" for src, f in zip(sources, frames, strict=True)
    )
    said = f"{sizes}; samples {' '.join(map(str, samples))}"
    said += "".join(f"; --set {s}" for s in args.set)
    said = said if said.isprintable() else repr(said)  # a line break would end the comment
    text = f"# mearm learn-colours: {said}\n" + yaml.safe_dump(
        learned_yaml(base, taught, set_values(config, args.set)),
        sort_keys=False,
        default_flow_style=None,
    )
    # what will be written loads (its extends found from its folder), or exit 2 naming it,
    # before any file is touched; in a folder not made yet, "new/../rig/c.yaml" is found
    # by the path it stands for (the system finds no "new/..")
    data = load_yaml_text(text, source=str(args.out))
    if args.config.exists() and not args.out.parent.exists():
        data["extends"] = str(resolve_config_path(args.config).resolve())
    learned = config_from_dict(data, source=str(args.out), path=args.out)
    _check_taught_finds(config, learned, frames, sources, samples, args.radius)
    before = args.out.read_bytes() if args.out.is_file() else None
    write_text_atomic(args.out, text)
    try:
        load_config(args.out)  # and its calibration files are found from there
    except MearmError:  # a config that does not load is not left behind (nor an old one lost)
        if before is None:
            args.out.unlink(missing_ok=True)
        else:
            write_atomic(args.out, before)
        raise
    first = (frames[0].shape[1], frames[0].shape[0])
    _warn_if_another_size(taught, config, first, sources[0])
    _print_taught(taught, whole_frame=args.whole_frame)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    run(main)
