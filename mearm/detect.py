"""Find the objects of each colour class in images or camera frames (mearm detect).

Examples::

    python -m mearm.detect --config configs/lab.yaml frame.png --json
    python -m mearm.detect --config configs/sim.yaml --camera --annotate out.png

With ``--json`` each image gives one line: a JSON list of
``{"color", "px": [u, v], "cm": [x, y], "area_px", "merged", "cut", "shape", "yaw_deg"}``
(``color`` is the class name), in the detector's order (the classes of ``task.classes``
in order; each by image row). ``cut``: the region touches the image border, so only
part of the object is seen (its centroid and shape are not to be trusted; the sort does
not pick it until it is seen whole); ``shape``: the shape its outline has (``null``
when merged or cut); ``yaw_deg``: a cube's sides' direction in the base frame, in
[0, 90) (``null`` for other shapes). ``--annotate OUT.png`` draws each region's contour,
centroid, class and table position in its class's ``draw_rgb`` (each label once, on a
filled box); with several images the i-th (from 0, in the order given) goes to
``OUT-i.png``. An annotated picture already there (a second run's, or the user's own
file of that name) is replaced only with ``--force``: without it the run is refused
before any work (exit 2). A ``wrote PATH`` line follows each image's objects (on stderr with
``--json``, whose stdout holds the JSON lists alone). A missing or
unreadable image stops the run before anything is printed: exit 2 with one line on
stderr. An image of another size than the calibration's, or with no colour (a grayscale
one), is read with a one-line warning on stderr. A ``vision.work_area_px`` polygon is
checked against each frame's size (:func:`~mearm.vision.work_area.check_work_area`): one
whose points lie on one line (no area: ``learn-colours --work-area`` and ``sort`` refuse
it too) or with no pixel in a frame stops the run the same way (nothing could be found
there), and
one that leaves out most of a frame while lying mostly outside it (drawn on frames of
another size: a config taught on a photo, used on the camera) is named in a warning.
``--camera`` on the MuJoCo twin warns, in one line on stderr, of the camera settings its
render does not use (``camera.brightness``, ``noise_std``, ``gradient``, ``table``,
``seed``: the kinematic renderer's; :func:`mearm.task.check.kinematic_camera_warning`).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from mearm import interrupts
from mearm.backends import grab_frame
from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    check_output_file,
    config_from_args,
    invoked_as,
    refuse_to_replace,
    run,
    say_on_stderr,
)
from mearm.fileio import file_identity, write_atomic
from mearm.vision.calibration import camera_geometry
from mearm.vision.detector import ColorDetector, Detection
from mearm.vision.errors import ImageError
from mearm.vision.image import opencv_takes_name, quiet_opencv, read_image
from mearm.vision.shapes import touches_border
from mearm.vision.work_area import check_work_area

#: Decoded frames kept between checking every image and detecting in each [px]; the
#: images past it are decoded twice (checked, dropped, read again) to bound the memory.
KEEP_PIXELS = 100_000_000


def _read_all(paths: Sequence[Path]) -> list[tuple[str, np.ndarray | None, tuple[int, int]]]:
    """Decode every image, so a bad one stops the run before any output.

    Each as its name, the frame, and its (width, height) [px]. The first
    :data:`KEEP_PIXELS` worth of frames are kept; ``None`` stands for the rest.
    """
    out: list[tuple[str, np.ndarray | None, tuple[int, int]]] = []
    kept = 0
    for path in paths:
        frame = read_image(path)
        h, w = frame.shape[:2]
        kept += w * h
        out.append((str(path), frame if kept <= KEEP_PIXELS else None, (w, h)))
    return out


def has_colour(frame: np.ndarray) -> bool:
    """Whether a BGR frame has any pixel whose channels differ (a grayscale one has none)."""
    b, g, r = frame[..., 0], frame[..., 1], frame[..., 2]
    return not (np.array_equal(b, g) and np.array_equal(g, r))


def _warn_if_odd(
    name: str, frame: np.ndarray, expected: tuple[int, int], area_note: str | None = None
) -> None:
    """One line on stderr for a frame that is read but whose result is not to be trusted.

    ``area_note``: how the work area fits the frame (:func:`_work_area_notes`), if amiss.
    """
    h, w = frame.shape[:2]
    if (w, h) != expected:
        say_on_stderr(
            f"warning: {name} is {w}x{h} px; the calibration is for "
            f"{expected[0]}x{expected[1]}, so its cm are not to be trusted",
            "python -m mearm.detect",
        )
    if not has_colour(frame):
        say_on_stderr(
            f"warning: {name} has no colour (every pixel grey: a grayscale image?), "
            "so no colour class can be found in it",
            "python -m mearm.detect",
        )
    if area_note is not None:
        say_on_stderr(f"warning: {area_note}", "python -m mearm.detect")


def _work_area_notes(
    polygon_px: Sequence[tuple[float, float]] | None,
    frames: Sequence[tuple[str, np.ndarray | None, tuple[int, int]]],
) -> list[str | None]:
    """Per frame, a warning about how the work area fits it (``None``: it fits).

    Raises:
        ConfigError: the work area has no pixel in one of the frames (before any output).
    """
    if polygon_px is None:
        return [None] * len(frames)
    return [check_work_area(polygon_px, size, name) for name, _, size in frames]


def annotation_paths(out: Path, count: int) -> list[Path]:
    """Where ``--annotate OUT`` writes for ``count`` images: OUT, or OUT-0, OUT-1, …."""
    if count == 1:
        return [out]
    return [out.with_name(f"{out.stem}-{i}{out.suffix}") for i in range(count)]


def to_records(detections: Sequence[Detection], frame_shape: Sequence[int]) -> list[dict]:
    """The JSON records of detections: class, positions, area, merged, cut, shape, yaw.

    The table position is the detector's (``Detection.table_cm``): the centroid's under
    the paper's homography, the top face's centre under a perspective calibration.
    ``cut``: the region touches the border of the frame of ``frame_shape`` (H, W, ...).
    A cube's yaw is the detector's on the table (``Detection.yaw_deg``; ``None``: none).
    """
    h, w = int(frame_shape[0]), int(frame_shape[1])
    out = []
    for d in detections:
        yaw = None if d.yaw_deg is None else round(d.yaw_deg, 2)
        out.append(
            {
                "color": d.color,
                "px": [round(float(v), 3) for v in d.centroid_px],
                "cm": None if d.table_cm is None else [round(float(v), 3) for v in d.table_cm],
                "area_px": d.area_px,
                "merged": d.merged,
                "cut": touches_border(d.bbox_px, w, h),
                "shape": d.shape,
                "yaw_deg": yaw,
            }
        )
    return out


#: Label text: font, scale, thickness [px] and the padding of its box [px].
LABEL_FONT, LABEL_SCALE, LABEL_THICKNESS, LABEL_PAD = cv2.FONT_HERSHEY_SIMPLEX, 0.4, 1, 2


def label_size(label: str) -> tuple[int, int, int]:
    """(width, height, baseline) [px] of a label's text, without its box padding."""
    (w, h), base = cv2.getTextSize(label, LABEL_FONT, LABEL_SCALE, LABEL_THICKNESS)
    return w, h, base


def label_box(
    label: str,
    bbox_px: tuple[int, int, int, int],
    shape: tuple[int, ...],
    taken: Sequence[tuple[int, int, int, int]] = (),
) -> tuple[int, int, int, int]:
    """Where a label's box goes: (x, y, w, h) [px], inside the frame.

    Above the region's box, else below it; moved down a box height at a time past the
    boxes already ``taken`` (as far as the frame allows), so labels do not cover one
    another.
    """
    tw, th, base = label_size(label)
    w, h = tw + 2 * LABEL_PAD, th + base + 2 * LABEL_PAD
    fh, fw = shape[0], shape[1]
    x, y, _, bh = bbox_px
    bx = min(max(x, 0), max(fw - w, 0))
    starts = [y - h - 1, y + bh + 1] + [y + bh + 1 + i * h for i in range(1, 8)]

    def overlaps(by: int) -> bool:
        return any(
            bx < ox + ow and ox < bx + w and by < oy + oh and oy < by + h
            for ox, oy, ow, oh in taken
        )

    for by in starts:
        by = min(max(by, 0), max(fh - h, 0))
        if not overlaps(by):
            return bx, by, w, h
    return bx, min(max(starts[0], 0), max(fh - h, 0)), w, h


def text_bgr(box_bgr: Sequence[int]) -> tuple[int, int, int]:
    """Black or white, whichever reads better on ``box_bgr`` (Rec. 601 luma)."""
    b, g, r = box_bgr
    return (0, 0, 0) if 0.114 * b + 0.587 * g + 0.299 * r >= 128 else (255, 255, 255)


def draw_label(
    out: np.ndarray, label: str, box: tuple[int, int, int, int], box_bgr: Sequence[int]
) -> None:
    """Draw ``label`` once in ``out``: a filled box of ``box_bgr``, the text on it."""
    x, y, w, h = box
    cv2.rectangle(out, (x, y), (x + w - 1, y + h - 1), tuple(int(c) for c in box_bgr), cv2.FILLED)
    _, th, _ = label_size(label)
    org = (x + LABEL_PAD, y + LABEL_PAD + th)
    cv2.putText(
        out, label, org, LABEL_FONT, LABEL_SCALE, text_bgr(box_bgr), LABEL_THICKNESS, cv2.LINE_AA
    )


def label_text(record: dict) -> str:
    """A detection's label: class, table position [cm], ``merged`` and ``cut`` if flagged."""
    x_cm, y_cm = record["cm"]
    flags = "".join(f" {flag}" for flag in ("merged", "cut") if record[flag])
    return f"{record['color']} ({x_cm:.2f}, {y_cm:.2f}){flags}"


def annotate(
    frame: np.ndarray, detector: ColorDetector, records: list[dict], detections: list[Detection]
) -> np.ndarray:
    """A copy of ``frame`` with contours, centroids, classes and table positions drawn.

    Each class's contours are drawn in its ``draw_rgb``; each detection gets a cross at
    its centroid and one label (class, table position, ``merged``), drawn once: dark or
    light text on a filled box of its class's colour, placed clear of the other labels
    (:func:`label_box`). Labels are drawn last, over everything else.
    """
    out = frame.copy()
    draw_bgr = {c.name: tuple(reversed(c.draw_rgb)) for c in detector.classes}
    masks = detector.masks(frame)
    for color, mask in masks.items():
        contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        big = [c for c in contours if cv2.contourArea(c) >= detector.vision.min_area_px / 2]
        cv2.drawContours(out, big, -1, draw_bgr[color], 1, cv2.LINE_AA)
    for det in detections:
        u, v = det.centroid_px
        cv2.drawMarker(
            out, (round(u), round(v)), (255, 255, 255), cv2.MARKER_CROSS, 9, 1, cv2.LINE_AA
        )
    taken: list[tuple[int, int, int, int]] = []
    for rec, det in zip(records, detections, strict=True):
        label = label_text(rec)
        box = label_box(label, det.bbox_px, out.shape, taken)
        taken.append(box)
        draw_label(out, label, box, draw_bgr[rec["color"]])
    return out


def _check_annotate_outputs(parser: ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse, before any work, ``--annotate`` pictures that cannot or must not be written.

    An unknown image type, one of the input images, a folder or a path under a file, and
    a picture already there without ``--force`` (a second run must not replace it
    silently): each exit 2 with one line.
    """
    suffix = Path(args.annotate).suffix  # OpenCV picks the writer by it alone
    if not opencv_takes_name(suffix) or not cv2.haveImageWriter(f"annotated{suffix}"):
        parser.error(f"--annotate {args.annotate}: unknown image type (use .png or .jpg)")
    inputs = {file_identity(p) for p in args.images} - {None}
    for out in annotation_paths(args.annotate, max(1, len(args.images))):
        if file_identity(out) in inputs:
            parser.error(f"--annotate {out}: is one of the input images (write elsewhere)")
        check_output_file(out, "--annotate")  # a folder, a path under a file: now
        refuse_to_replace(out, "--annotate", args.force)


def main(argv: Sequence[str] | None = None) -> int:  # noqa: PLR0912 (one branch per option)
    """Detect objects in each image and print them (text or JSON lines)."""
    parser = ArgumentParser(
        prog=invoked_as("python -m mearm.detect"), description=__doc__.splitlines()[0]
    )
    add_config_argument(parser)
    parser.add_argument("images", nargs="*", type=Path, metavar="IMAGE", help="images to read")
    parser.add_argument(
        "--camera", action="store_true", help="grab one frame from the config's camera instead"
    )
    parser.add_argument("--json", action="store_true", help="one JSON list per image")
    parser.add_argument(
        "--annotate",
        type=Path,
        metavar="OUT.png",
        help="write an annotated copy (several images: OUT-0.png, OUT-1.png, ...)",
    )
    parser.add_argument(
        "--force", action="store_true", help="replace an --annotate picture that is already there"
    )
    args = parser.parse_args(argv)
    if bool(args.images) == args.camera:
        parser.error("give IMAGE paths or --camera (one of the two)")
    if args.annotate is not None:
        _check_annotate_outputs(parser, args)
    config = config_from_args(args)
    calibration = camera_geometry(config.calibration, config.camera)
    detector = ColorDetector.from_config(
        config.vision, config.calibration, config.camera, config.task.classes, geometry=calibration
    )

    frames: list[tuple[str, np.ndarray | None, tuple[int, int]]]
    if args.camera:
        from mearm.task.check import kinematic_camera_warning  # noqa: PLC0415  (--camera's)

        unused = kinematic_camera_warning(config)  # the twin's render: said before its frame
        if unused is not None:
            say_on_stderr(f"warning: {unused}", "python -m mearm.detect")
        grabbed = grab_frame(config)
        frames = [("camera", grabbed, (grabbed.shape[1], grabbed.shape[0]))]
    else:
        frames = _read_all(args.images)  # all readable, or exit 2 before any output
    area_notes = _work_area_notes(config.vision.work_area_px, frames)

    expected = (config.camera.width_px, config.camera.height_px)
    width = max(len(name) for name in config.task.class_names)
    outs = annotation_paths(args.annotate, len(frames)) if args.annotate else []
    for i, (name, kept, _) in enumerate(frames):
        frame = kept if kept is not None else read_image(Path(name))
        _warn_if_odd(name, frame, expected, area_notes[i])
        detections = detector.detect(frame)
        # about to print this image's answer: a Ctrl-C that C code swallowed meanwhile (a
        # module initialised on first use, as ``numpy.random`` was by the simulated camera
        # before the start's checkpoint loaded it) stops here, as it would have where it
        # came; a command with no sorter has no other point between its work and its output
        interrupts.raise_swallowed_ctrl_c()
        records = to_records(detections, frame.shape)
        if args.json:
            print(json.dumps(records))
        else:
            print(f"{name}: {len(records)} object(s)")
            for r in records:
                (u, v), (x, y) = r["px"], r["cm"]
                flags = "".join(f"  {flag}" for flag in ("merged", "cut") if r[flag])
                shape = r["shape"] or "?"
                if r["yaw_deg"] is not None:
                    shape += f" {r['yaw_deg']:.1f}°"
                print(
                    f"  {r['color']:<{width}} px ({u:7.2f}, {v:7.2f})  cm ({x:7.2f}, {y:6.2f})"
                    f"  area {r['area_px']:5d}  {shape}{flags}"
                )
        if outs:
            drawn = annotate(frame, detector, records, detections)
            ext = outs[i].suffix.lower() or ".png"
            try:
                with quiet_opencv():
                    encoded, data = cv2.imencode(ext, drawn)
            except cv2.error:
                encoded = False
            if not encoded:
                raise ImageError(str(outs[i]), f"cannot encode the annotated image as {ext}")
            try:
                write_atomic(outs[i], data.tobytes())
            except OSError as exc:
                raise ImageError(str(outs[i]), f"cannot write the annotated image: {exc}") from None
            # stdout under --json holds only the JSON lists: the file is a note there
            print(f"wrote {outs[i]}", file=sys.stderr if args.json else sys.stdout)
    return 0


if __name__ == "__main__":
    run(main)
