r"""``mearm learn-colours``: teach each class its colour from the camera's own frames.

Click once on an object of each class (or give the pixel), and the class's colour is
fitted from the pixels there (:mod:`mearm.vision.teaching`): an ellipse in CIELAB's
a*b* plane with a lightness range, on frames white-balanced against the table. The new
config extends the old one with the learned colours, the table's median colour (each
frame is balanced to it: a lamp or the camera's auto white balance does not move the
colours) and the work area (the table's outline found around the samples, or
``--work-area``); ``mearm detect --config NEW.yaml`` uses them. ::

    mearm learn-colours frame.png --sample red=212,340 --sample blue=400,236 \
        --config sim --out mine.yaml
    mearm learn-colours --camera --pick --config lab.yaml --out lab_learned.yaml

``--sample CLASS=U,V`` (repeatable; ``CLASS=U,V@I`` for the I-th image, from 0) names a
pixel of an object of the class; ``--pick`` shows the first frame and asks for a click
on each class in turn (needs a display). A class not sampled keeps its hue bands.

Refused (exit 2, one line): a sample outside its image, a class the config does not
have, two classes sampled on one colour or one class on two, a sample on a grey or black
pixel or on the table's colour, a first image with no table around the samples, a
``--work-area`` with no area or with none of a class's samples in it, and an ``--out``
that is the ``--config`` or one of the images (even with ``--force``).
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from mearm.cli import ArgumentParser, check_output_file, plain_float, run, write_text_atomic
from mearm.config import Config
from mearm.config.files import load_config, resolve_config_path
from mearm.config.loader import config_from_dict
from mearm.errors import MearmError
from mearm.fileio import file_identity
from mearm.vision.calibration import object_width_px
from mearm.vision.image import read_image
from mearm.vision.teaching import Sample, Taught, teach
from mearm.yamlio import load_yaml_text

#: ASCII digits only: ``\d`` matches other scripts' digits too (``@١`` read as image 1).
_SAMPLE = re.compile(r"^([^=\s]+)=([-+0-9.eE]+),([-+0-9.eE]+)(?:@([0-9]+))?$")


def parse_sample(text: str) -> Sample:
    """``CLASS=U,V`` or ``CLASS=U,V@I`` as a :class:`Sample` (ValueError if malformed)."""
    m = _SAMPLE.match(text.strip())
    if m is None:
        raise ValueError(f"--sample {text!r}: expected CLASS=U,V (e.g. red=212,340)")
    u, v = float(m.group(2)), float(m.group(3))
    if not (math.isfinite(u) and math.isfinite(v)):
        raise ValueError(f"--sample {text!r}: U and V must be finite pixels")
    return Sample(m.group(1), u, v, int(m.group(4) or 0))


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
    return u, v


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


def learned_yaml(base: str, taught: Taught) -> dict:
    """The new config's data: ``extends`` the old one, with what was learned."""
    vision: dict[str, Any] = {"reference_bgr": [round(v, 2) for v in taught.reference_bgr]}
    if taught.work_area_px is not None:
        vision["work_area_px"] = [[round(u, 1), round(v, 1)] for u, v in taught.work_area_px]
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
    return {"extends": base, "vision": vision, "task": {"classes": classes}}


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
    parser.add_argument("--config", type=str, required=True, help="the config to extend")
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
        default=None,
        metavar="U,V",
        help="the work area's polygon in pixels (default: the table found)",
    )
    parser.add_argument("--whole-frame", action="store_true", help="no work area: the whole frame")
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
    if area is not None and _enclosed_px2(area) < 1.0:
        parser.error(
            f"--work-area encloses {_enclosed_px2(area):g} px² (its points lie on one line): "
            "give the corners of the area around the objects"
        )
    return samples, area


def _enclosed_px2(polygon: Sequence[tuple[float, float]]) -> float:
    """The area a polygon (u, v) encloses [px²] (the shoelace formula)."""
    u = np.array([p[0] for p in polygon])
    v = np.array([p[1] for p in polygon])
    return float(abs(np.dot(u, np.roll(v, -1)) - np.dot(v, np.roll(u, -1))) / 2.0)


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
    """The frames to learn from and where each came from."""
    if args.camera:
        from mearm.backends import open_camera

        with open_camera(config) as camera:
            frames = [camera.read()]
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


def _print_taught(taught: Taught) -> None:
    """One line per learned colour, then the table's colour and the work area."""
    for name, m in taught.colours.items():
        print(
            f"{name}: a*b* ({m.ab_mean[0]:.1f}, {m.ab_mean[1]:.1f}), chroma >= {m.chroma_min:.1f}, "
            f"L* {m.lightness[0]:.0f}-{m.lightness[1]:.0f}, radius {m.max_distance:.2f}"
        )
    where = (
        "whole frame"
        if taught.work_area_px is None
        else f"{len(taught.work_area_px)}-point polygon"
    )
    print(f"table L*a*b* ({', '.join(f'{v:.1f}' for v in taught.table_lab)}); work area: {where}")


def main(argv: Sequence[str] | None = None) -> int:
    """Teach the classes their colours and write the new config; see the module docstring."""
    parser = _parser()
    args = parser.parse_args(argv)
    samples, area = _checked_arguments(parser, args)
    check_output_file(args.out, "--out")
    _check_not_replacing(args.out, args.config, force=args.force, images=args.images)
    config = load_config(args.config)
    names = config.task.class_names
    _check_samples(samples, names, args.config, len(args.images))
    frames, sources = _frames(args, config)
    if args.pick:
        samples += pick_samples(frames[0], [n for n in names if n not in {s.name for s in samples}])
    taught = teach(
        frames,
        samples,
        radius_px=args.radius,
        object_px=object_width_px(
            config.calibration,
            config.camera,
            max(c.diameter_cm for c in config.task.classes),
            frames[0].shape,
        ),
        work_area_px=area,
        find_area=not args.whole_frame,
    )
    given = Path(args.config)
    base = (
        os.path.relpath(resolve_config_path(args.config).resolve(), args.out.resolve().parent)
        if given.exists()
        else args.config
    )
    import yaml

    head = f"# mearm learn-colours: {' '.join(sources)}; samples {' '.join(map(str, samples))}\n"
    text = head + yaml.safe_dump(
        learned_yaml(base, taught), sort_keys=False, default_flow_style=None
    )
    # what will be written loads (its extends found from its folder), or exit 2 naming it,
    # before any file is touched
    config_from_dict(
        load_yaml_text(text, source=str(args.out)), source=str(args.out), path=args.out
    )
    write_text_atomic(args.out, text)
    load_config(args.out)  # and its calibration files are found from there
    _print_taught(taught)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    run(main)
