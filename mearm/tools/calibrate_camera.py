r"""Fit the camera → table calibration and write it into a config file (paper §4).

From an image showing four (or more) ArUco markers whose centres' table positions you
measured (base frame, cm; the marker's top edge towards +y)::

    mearm calibrate-camera --config configs/lab.yaml --image table.png \
        --marker 0:-17,56 --marker 1:16,56 --marker 2:16,32 --marker 3:-17,32 \
        [--marker-side-cm 4] [--dictionary DICT_4X4_50]

or from pixel ↔ table point pairs ``U,V:X,Y``::

    mearm calibrate-camera --config configs/lab.yaml \
        --point 0,0:-20.5,59 --point 640,0:19.5,59 --point 640,480:19.5,29 --point 0,480:-20.5,29

It replaces ``calibration.homography``, ``calibration.reprojection_error_cm`` and
``calibration.image_size_px`` (the frame size the homography maps: the --image's, which
must be the config's camera's, or with --point the camera's) in the file, keeping
everything else and its comments, and prints the reprojection error. The
new file is validated before it replaces the old one (atomically; on any failure the
old file is untouched). ``--output`` writes elsewhere, ``--dry-run`` writes nothing.
Print markers with ``mearm aruco-sheet``.

A config that holds a calibration with a known error (``reprojection_error_cm``) is not
given a worse one without ``--force``, nor one of unknown error: 4 pairs fit exactly, so
their error (0 by construction) measures nothing and is recorded as ``null``.

**The camera's pose (perspective calibration).** With the camera's intrinsics file
(``mearm calibrate-intrinsics``), the same image and markers give the camera's pose in
the base frame instead, by solvePnP on the undistorted marker corners (tilted cameras
included)::

    mearm calibrate-camera --intrinsics camera_intrinsics.yaml --out camera_pose.yaml \
        --image table.png --marker-side-cm 4 --marker 0:-17,56 --marker 1:16,56 ... \
        [--config configs/lab.yaml]

It writes the pose file (never over a better one without ``--force``), prints the
reprojection error of the corners [px] and the marker centres' table error [cm], and,
with ``--config``, points that config's ``calibration`` at the two files
(``model: perspective``).

**A pose that holds above the table.** Fitted to one plane, the pose turns the camera
to make up for a principal point a pixel off, which is right on that plane only. A
second picture of markers lying on a box of measured height (``--raised-image``,
``--raised-height-cm``, ``--raised-marker ID:X,Y`` each, the centres measured as on
the table) puts points at two heights into one (non-planar) pose fit, which that
rotation no longer fits.

A file replaced is kept beside it as ``<name>.bak`` (a config whenever its text changes,
a pose file always), named on stdout before the file that replaced it: ``wrote <name>.bak
(the old <name>)``.
"""

from __future__ import annotations

import argparse
import io
import itertools
import math
import os
import stat
import sys
from collections.abc import Sequence
from dataclasses import dataclass, replace
from datetime import date
from pathlib import Path

import numpy as np
from ruamel.yaml import YAML, YAMLError
from ruamel.yaml.comments import CommentedMap, CommentedSeq

from mearm.cli import (
    PLAIN_DECIMAL,
    ArgumentParser,
    backup_existing,
    backup_written,
    check_output_file,
    check_plain_number,
    plain_float,
    refuse_own_inputs,
    refuse_picture_name,
    run,
)
from mearm.config import config_from_dict, load_config
from mearm.config.base import MAX_LENGTH_CM, short_repr
from mearm.config.compose import EXTENDS_KEY, FILE_KEYS, expand_config
from mearm.config.errors import CalibrationError
from mearm.config.sections import CameraConfig
from mearm.data import packaged_config
from mearm.errors import ConfigError, InputFileError, MearmError
from mearm.fileio import file_identity, write_atomic
from mearm.vision.aruco import (
    DEFAULT_DICTIONARY,
    calibration_from_markers,
    diagonal_center,
    find_markers,
    table_corners_cm,
)
from mearm.vision.calibration import Calibration
from mearm.vision.image import read_image
from mearm.vision.pinhole import (
    Extrinsics,
    Intrinsics,
    PerspectiveCamera,
    load_calibration,
    save_calibration,
    solve_pose,
)
from mearm.yamlio import load_yaml_text, read_text_file

#: Largest pixel coordinate of a --point [px] (an image side is at most 65 535 px).
MAX_PIXEL = 65_535.0
#: Largest printed marker side [cm].
MAX_MARKER_SIDE_CM = 100.0
#: Largest corner reprojection error of a pose fit that is written [px]. A marker centre
#: measured a millimetre off moves its corners about a pixel at the paper's 50 cm; above
#: this, positions are wrong by several millimetres on every marker, or one is mistyped.
MAX_POSE_RMS_PX = 5.0
#: Largest reprojection error of a homography fit that is written [cm, rms]. The same
#: 5 mm that :data:`MAX_POSE_RMS_PX` stands for at the paper's 50 cm (1 px ≈ 1 mm), and
#: ten times what the homography reached on the twin's tilted, distorting camera
#: (0.054 cm, docs/calibration.md): above it a marker is mistyped or the side is wrong.
MAX_HOMOGRAPHY_RMS_CM = 0.5
#: Largest turn of a marker on the table, in a marker fit, from lying with its top edge
#: towards +y [deg]: halfway to a quarter turn, the nearest other way a square marker lies.
MAX_MARKER_TURN_DEG = 45.0
#: Tallest support of the raised view [cm]: the camera must see its markers whole.
MAX_RAISED_HEIGHT_CM = 100.0
#: Fewest markers on the raised support: spread along x and y.
MIN_RAISED_MARKERS = 3


def _numbers(text: str, n: int, what: str, limit: float) -> list[float]:
    shown = short_repr(text, 40)
    check_plain_number(text, f"{what} must be plain decimal numbers ({PLAIN_DECIMAL})")
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what} must be numbers, got {shown}") from None
    if len(values) != n or not all(abs(v) <= limit for v in values):
        raise argparse.ArgumentTypeError(f"{what} needs {n} numbers within ±{limit:g}, got {shown}")
    return values


def parse_point(text: str) -> tuple[list[float], list[float]]:
    """``U,V:X,Y`` → ((u, v) [px], (x, y) [cm])."""
    if text.count(":") != 1:
        raise argparse.ArgumentTypeError(f"--point wants U,V:X,Y, got {text!r}")
    px, cm = text.split(":")
    return (
        _numbers(px, 2, "--point pixel U,V", MAX_PIXEL),
        _numbers(cm, 2, "--point table X,Y", MAX_LENGTH_CM),
    )


def parse_marker(text: str) -> tuple[int, tuple[float, float]]:
    """``ID:X,Y`` → (id, (x, y) [cm])."""
    if text.count(":") != 1:
        raise argparse.ArgumentTypeError(f"--marker wants ID:X,Y, got {text!r}")
    ident, cm = text.split(":")
    if not ident.strip().isascii() or not ident.strip().isdigit() or len(ident.strip()) > 6:
        raise argparse.ArgumentTypeError(
            f"--marker id must be an integer 0 … 999999, got {short_repr(ident, 20)}"
        )
    marker_id = int(ident)
    x, y = _numbers(cm, 2, "--marker table X,Y", MAX_LENGTH_CM)
    return marker_id, (x, y)


def _yaml() -> YAML:
    y = YAML()  # round-trip: keeps comments, order and flow style
    y.preserve_quotes = True
    y.width = 4096  # never fold a line
    y.indent(mapping=2, sequence=4, offset=2)  # the style of configs/*.yaml
    y.representer.add_representer(
        type(None), lambda r, _: r.represent_scalar("tag:yaml.org,2002:null", "null")
    )
    return y


def _calibration_section(text: str, source: str) -> tuple[YAML, CommentedMap, CommentedMap]:
    """A config's text loaded for a round trip: the YAML, its top level, its calibration.

    Raises:
        ConfigError: the text is not YAML, YAML that every config read refuses
            (:func:`mearm.yamlio.load_yaml_text`), or not a mapping.
    """
    load_yaml_text(text, source=source)  # size, depth, aliases, tags, duplicate keys, empty
    y = _yaml()
    try:
        data = y.load(text)
    except YAMLError as exc:
        raise ConfigError(source, [f"malformed YAML: {str(exc).splitlines()[0]}"]) from None
    if not isinstance(data, CommentedMap):
        raise ConfigError(source, ["top level must be a mapping"])
    section = data.get("calibration")
    if not isinstance(section, CommentedMap):
        section = CommentedMap()
        data["calibration"] = section
    return y, data, section


def _dumped(y: YAML, data: CommentedMap, source: str, target: Path | None = None) -> str:
    """The config's new text, which must load where it is written (else ConfigError).

    ``target``: where that is, if not over ``source``.
    """
    out = io.StringIO()
    y.dump(data, out)
    result = out.getvalue()
    where = Path(source) if target is None else target
    config_from_dict(load_yaml_text(result, source=str(where)), source=str(where), path=where)
    return result


def _moved(data: CommentedMap, source: Path, target: Path) -> None:
    """Rewrite the relative paths ``data`` names for the config written to ``target``.

    ``extends:`` and the file keys (:data:`~mearm.config.compose.FILE_KEYS`) are relative
    to the folder of the config that names them. Copied as they are into a config written
    in another folder (``--output sub/cfg.yaml``), they named files that are not there,
    and the written config did not load. Each that names a file beside ``source`` now
    names it from ``target``'s folder (by its absolute path while that folder is still
    to be made); an absolute path, or a name that is no file there (a config mearm ships,
    by its name), stays as it was.
    """
    here, there = source.absolute().parent, target.absolute().parent
    if here.resolve() == there.resolve():
        return

    def moved(text: str) -> str:
        full = here / text
        if Path(text).is_absolute() or not (full.exists() or full.is_symlink()):
            return text
        if not there.is_dir():  # made on writing: "new/../base.yaml" cannot be read yet
            return str(full.resolve())
        return os.path.relpath(full, there)

    if isinstance(data.get(EXTENDS_KEY), str):
        data[EXTENDS_KEY] = moved(data[EXTENDS_KEY])
    for section, key in FILE_KEYS:
        part = data.get(section)
        if isinstance(part, CommentedMap) and isinstance(part.get(key), str):
            part[key] = moved(part[key])


def update_config_text(
    text: str,
    calibration: Calibration,
    note: str,
    source: str,
    target: Path | None = None,
    size_px: tuple[int, int] | None = None,
) -> str:
    """``text`` (a YAML config) with its calibration block replaced; comments kept.

    ``target``: where it is written, if not over ``source`` (its relative paths follow,
    :func:`_moved`). ``size_px``: the frame size (width, height) the pixels were measured
    in, written as ``calibration.image_size_px``; ``None`` writes ``null`` (unknown), as a
    size the homography it replaces was recorded with is not this one's.

    Raises:
        ConfigError: the text is not YAML, or YAML that every config read refuses
            (:func:`mearm.yamlio.load_yaml_text`), or the result is not a valid config.
    """
    y, data, section = _calibration_section(text, source)
    rows = [[float(v) for v in row] for row in calibration.H]
    old = section.get("homography")
    if (
        isinstance(old, list)
        and len(old) == 3
        and all(isinstance(r, list) and len(r) == 3 for r in old)
    ):
        for i in range(3):  # in place, so the rows keep their style and comments
            for j in range(3):
                old[i][j] = rows[i][j]
    else:
        seq = CommentedSeq()
        for row in rows:
            r = CommentedSeq(row)
            r.fa.set_flow_style()
            seq.append(r)
        section["homography"] = seq
    err = calibration.reprojection_error_cm
    section["reprojection_error_cm"] = None if err is None else float(err)
    size = None
    if size_px is not None:
        size = CommentedSeq([int(size_px[0]), int(size_px[1])])
        size.fa.set_flow_style()
    section["image_size_px"] = size
    section.yaml_add_eol_comment(note, "homography")
    if target is not None:
        _moved(data, Path(source), target)
    return _dumped(y, data, source, target)


def point_config_at_files(
    text: str, intrinsics: Path, extrinsics: Path, config: Path, source: str
) -> str:
    """``text`` with ``calibration`` set to ``model: perspective`` and the two files.

    The paths are written relative to the config's folder when they lie under it.

    Raises:
        ConfigError: the text is not a config, or the result does not load.
    """
    y, data, section = _calibration_section(text, source)
    folder = config.resolve().parent

    def rel(p: Path) -> str:
        full = p.resolve()
        try:
            return str(full.relative_to(folder))
        except ValueError:
            return str(full)

    _moved(data, Path(source), config)
    section["model"] = "perspective"
    section["intrinsics_file"] = rel(intrinsics)
    section["extrinsics_file"] = rel(extrinsics)
    return _dumped(y, data, source, config)


@dataclass(frozen=True)
class RaisedView:
    """Markers lying on a support above the table, and the picture of them.

    Attributes:
        frame: The picture, (h, w, 3) uint8 BGR.
        centers: Marker id → its centre (x, y) in the base frame [cm].
        height_cm: The support's top above the table [cm].
        name: What the messages call the picture (its file name).
    """

    frame: np.ndarray
    centers: dict[int, tuple[float, float]]
    height_cm: float
    name: str


def _marker_points(
    frame: np.ndarray,
    centers: dict[int, tuple[float, float]],
    side_cm: float,
    dictionary: str,
    z_cm: float,
) -> tuple[dict[int, np.ndarray], np.ndarray, np.ndarray]:
    """The markers found, their corners' pixels (N, 2) and base-frame points (N, 3) [cm]."""
    found = find_markers(frame, centers, dictionary)
    pixels: list[np.ndarray] = []
    points: list[np.ndarray] = []
    for marker_id, centre in sorted(centers.items()):
        pixels.extend(found[marker_id])
        points.extend(table_corners_cm(centre, side_cm))
    pts3 = np.column_stack([np.array(points), np.full(len(points), z_cm)])
    return found, np.array(pixels), pts3


def _check_size(frame: np.ndarray, intrinsics: Intrinsics, name: str) -> None:
    h, w = frame.shape[:2]
    if (w, h) != intrinsics.size_px:
        raise CalibrationError(
            f"{name}is {w}x{h} px but the intrinsics are for "
            f"{intrinsics.size_px[0]}x{intrinsics.size_px[1]} px: take the picture at that size"
        )


def fit_pose(
    frame: object,
    intrinsics: Intrinsics,
    centers: dict[int, tuple[float, float]],
    side_cm: float,
    dictionary: str,
    raised: RaisedView | None = None,
) -> tuple[Extrinsics, float, float]:
    """The camera's pose from the markers, and the centres' table error (rms, max) [cm].

    With ``raised``, the raised view's corners (at z = its height) join the table's in
    one fit: points at two heights, so no rotation can stand in for a principal-point
    error as it does on one plane.

    Raises:
        CalibrationError: a picture is not the intrinsics' size, a marker is missing, or
            no pose fits.
    """
    assert isinstance(frame, np.ndarray)
    _check_size(frame, intrinsics, "the image ")
    found, pixels, pts3 = _marker_points(frame, centers, side_cm, dictionary, 0.0)
    markers = len(centers)
    if raised is not None:
        _check_size(raised.frame, intrinsics, f"the raised view {raised.name} ")
        try:
            _, px_up, pts_up = _marker_points(
                raised.frame, raised.centers, side_cm, dictionary, raised.height_cm
            )
        except CalibrationError as exc:
            raise CalibrationError(f"the raised view {raised.name}: {exc.reason}") from None
        pixels, pts3 = np.vstack([pixels, px_up]), np.vstack([pts3, pts_up])
        markers += len(raised.centers)
    pose = solve_pose(intrinsics, pixels, pts3, markers=markers)
    if raised is not None:
        if pose.position_cm[2] <= raised.height_cm:
            raise CalibrationError(
                f"the fitted pose puts the camera at {pose.position_cm[2]:.1f} cm, not above "
                f"the {raised.height_cm:g} cm support: check --raised-height-cm and the markers"
            )
        pose = replace(pose, raised_cm=raised.height_cm)
    camera = PerspectiveCamera(intrinsics, pose)
    seen = camera.pixel_to_table(np.array([diagonal_center(found[i]) for i in sorted(centers)]))
    err = np.linalg.norm(seen - np.array([centers[i] for i in sorted(centers)]), axis=1)
    if pose.rms_px > MAX_POSE_RMS_PX:
        names = [f"--marker {i}" for i in sorted(centers)]
        if raised is not None:
            names += [f"--raised-marker {i}" for i in sorted(raised.centers)]
        raise CalibrationError(
            f"the markers' corners are {pose.rms_px:.1f} px rms from the fitted pose (a good "
            f"fit is under 1 px; refused above {MAX_POSE_RMS_PX:g}): "
            + _culprit(intrinsics, pixels, pts3, names)
        )
    return pose, float(np.sqrt(np.mean(err**2))), float(err.max())


def _culprit(intrinsics: Intrinsics, pixels: np.ndarray, pts3: np.ndarray, names: list[str]) -> str:
    """Which marker's given position a bad pose fit points at (4 corners a marker, in order).

    The fit is repeated without each marker in turn: where one leaves the rest within
    :data:`MAX_POSE_RMS_PX`, that one is named.
    """
    best: tuple[float, str] | None = None
    for k, name in enumerate(names):
        keep = np.ones(len(pixels), dtype=bool)
        keep[4 * k : 4 * k + 4] = False
        try:
            rms = solve_pose(intrinsics, pixels[keep], pts3[keep]).rms_px
        except CalibrationError:
            continue
        if rms <= MAX_POSE_RMS_PX and (best is None or rms < best[0]):
            best = (rms, name)
    if best is None:
        return "the markers' positions or --marker-side-cm do not match the picture"
    return f"{best[1]}'s position looks wrong (without it the rest fit to {best[0]:.2f} px)"


def _homography_no_worse(data: dict[str, object], calibration: Calibration, where: Path) -> None:
    """Refuse to replace a homography of known error with a worse one, or one of unknown error.

    An exact fit (4 pairs) has no measured error (``None``): it cannot be weighed against
    one that has, so it does not replace it without ``--force``.
    """
    section = data.get("calibration")
    old = section.get("reprojection_error_cm") if isinstance(section, dict) else None
    new = calibration.reprojection_error_cm
    if not isinstance(old, (int, float)):
        return
    if new is None:
        raise CalibrationError(
            f"{where} holds a calibration of measured error ({old:.4f} cm); the new one fits "
            "4 pairs exactly, so its error is unknown: kept; add pairs (or --marker-side-cm), "
            "or pass --force to replace it"
        )
    if new > old:
        raise CalibrationError(
            f"{where} holds a better calibration (reprojection error {old:.4f} cm) than the "
            f"new one ({new:.4f} cm): kept; pass --force to replace it"
        )


def write_atomically(path: Path, text: str) -> None:
    """Replace ``path`` with ``text`` in one step (:func:`mearm.fileio.write_atomic`).

    A symlink is followed (the file it names is replaced, the link kept); anything but a
    regular file (a device such as /dev/null, a FIFO, a directory) is refused, so no
    write can block or land outside a file.

    Raises:
        MearmError: ``path`` exists and is not a regular file.
        OSError: the write failed; the old file is untouched.
    """
    try:
        info = path.stat()
    except FileNotFoundError:
        pass
    else:
        if not stat.S_ISREG(info.st_mode):
            raise MearmError(f"{path}: not a regular file; write the calibration to a file")
    write_atomic(path, text)


def _parser() -> ArgumentParser:
    """The command line of :func:`main`."""
    parser = ArgumentParser(
        description="Fit pixel → table calibration into a config, or the camera's pose.",
    )
    parser.add_argument(
        "--config", type=Path,
        help="config file to update (its path: a config mearm ships is not edited)",
    )  # fmt: skip
    parser.add_argument("--output", type=Path, help="write the config here instead of --config")
    parser.add_argument("--image", type=Path, help="image showing the ArUco markers")
    parser.add_argument(
        "--marker", type=parse_marker, action="append", default=[], metavar="ID:X,Y",
        help="a marker's id and its centre's table position [cm] (4 or more; with "
        "--marker-side-cm each marker's corners count too)",
    )  # fmt: skip
    parser.add_argument(
        "--marker-side-cm", type=plain_float, help="printed marker side [cm]: use the corners too"
    )
    parser.add_argument("--dictionary", default=DEFAULT_DICTIONARY, help="ArUco dictionary")
    parser.add_argument(
        "--point", type=parse_point, action="append", default=[], metavar="U,V:X,Y",
        help="a pixel and its table position [cm] (4 or more)",
    )  # fmt: skip
    parser.add_argument(
        "--intrinsics", type=Path,
        help="the camera's intrinsics file: fit the camera's pose (perspective) instead",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, help="with --intrinsics: the pose file to write")
    parser.add_argument(
        "--raised-image", type=Path,
        help="with --intrinsics: a picture of markers on a support above the table",
    )  # fmt: skip
    parser.add_argument(
        "--raised-height-cm", type=plain_float, help="the support's top above the table [cm]"
    )
    parser.add_argument(
        "--raised-marker", type=parse_marker, action="append", default=[], metavar="ID:X,Y",
        help="a marker on the support: its id and its centre's position [cm] (3 or more)",
    )  # fmt: skip
    parser.add_argument(
        "--force", action="store_true", help="replace a better calibration than the new one"
    )
    parser.add_argument("--dry-run", action="store_true", help="fit and print; write nothing")
    return parser


def _check_arguments(parser: ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 (``parser.error``) on arguments that do not go together, before any fit."""
    if args.intrinsics is None and args.config is None:
        parser.error("the following arguments are required: --config (or --intrinsics)")
    if bool(args.point) == bool(args.image or args.marker):
        parser.error("give either --image with --marker, or --point (not both, not neither)")
    if args.image and not args.marker:
        parser.error(
            "--image needs --marker ID:X,Y for each marker (4 or more; with --marker-side-cm "
            "each marker's corners count too)"
        )
    if args.marker and not args.image:
        parser.error("--marker needs --image")
    if not args.dry_run:  # every file this run would write, before the fit
        for flag, path in (("--output", args.output), ("--out", args.out)):
            if path is not None:
                check_output_file(path, flag)
        _check_own_inputs(args)
        for flag, path in (("--output", args.output), ("--out", args.out)):
            if path is not None:
                refuse_picture_name(path, flag)
    _check_raised(parser, args)
    if args.marker_side_cm is not None and not 0 < args.marker_side_cm <= MAX_MARKER_SIDE_CM:
        parser.error(
            f"--marker-side-cm must be in (0, {MAX_MARKER_SIDE_CM:g}] cm, "
            f"got {args.marker_side_cm:g}"
        )
    _check_marker_places(parser, args.marker, args.marker_side_cm)


def _check_marker_places(
    parser: ArgumentParser,
    markers: Sequence[tuple[int, tuple[float, float]]],
    side_cm: float | None,
) -> None:
    """Exit 2 on two --marker ids given one place, or places too close for the markers.

    Two printed markers of side s cannot lie with their centres less than s apart (each
    holds a disc of diameter s): one of the positions is mistyped. Said by the ids given,
    not by the fit's point numbers (a marker's corners count as points too).
    """
    for (a, pa), (b, pb) in itertools.combinations(markers, 2):
        if a == b:
            continue  # the same id given twice: said as such where the markers are read
        apart = math.dist(pa, pb)
        if apart == 0:
            parser.error(
                f"--marker {a} and --marker {b} are both at ({pa[0]:g}, {pa[1]:g}) cm: "
                "each marker lies at its own place on the table; check their positions"
            )
        if side_cm is not None and apart < side_cm:
            parser.error(
                f"--marker {a} at ({pa[0]:g}, {pa[1]:g}) and --marker {b} at ({pb[0]:g}, "
                f"{pb[1]:g}) cm are {apart:.3g} cm apart, less than --marker-side-cm "
                f"{side_cm:g}: markers that close would overlap; check their positions"
            )


def _check_own_inputs(args: argparse.Namespace) -> None:
    """Refuse (exit 2) outputs that are inputs, and an existing --output without --force.

    Writing into --config itself is the command's normal mode (a better calibration in
    it is kept); any other existing --output is replaced only with --force, and kept as
    ``.bak``.
    """
    inputs = [
        ("--image", args.image),
        ("--raised-image", args.raised_image),
        ("--intrinsics", args.intrinsics),
    ]
    output = args.output
    if (
        output is not None
        and args.config is not None
        and file_identity(output) == file_identity(args.config)
    ):
        output = None  # the same as writing into --config
    refuse_own_inputs([("--output", output)], [*inputs, ("--out", args.out)])
    refuse_own_inputs([("--out", args.out)], [*inputs, ("--config", args.config)])
    if output is not None and output.exists() and not args.force:
        raise MearmError(
            f"--output {output}: the file exists; pass --force to replace it (the old file "
            "is kept as .bak), or write elsewhere"
        )


def _check_raised(parser: ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 on a raised view's arguments that are missing, alone or out of range."""
    given = args.raised_height_cm is not None or bool(args.raised_marker)
    if args.raised_image is None:
        if given:
            parser.error("--raised-height-cm and --raised-marker need --raised-image")
        return
    if args.intrinsics is None:
        parser.error("--raised-image is for the camera's pose: it needs --intrinsics")
    h = args.raised_height_cm
    if h is None:
        parser.error("--raised-image needs --raised-height-cm (the support's measured height)")
    if not (math.isfinite(h) and 0 < h <= MAX_RAISED_HEIGHT_CM):
        parser.error(
            f"--raised-height-cm must be in (0, {MAX_RAISED_HEIGHT_CM:g}] cm, got {h:g}: the "
            "height of the support's top above the table"
        )
    ids = [i for i, _ in args.raised_marker]
    if len(set(ids)) < MIN_RAISED_MARKERS:
        parser.error(
            f"--raised-image needs --raised-marker ID:X,Y for {MIN_RAISED_MARKERS} or more "
            f"markers on the support, got {len(set(ids))}"
        )
    if len(set(ids)) != len(ids):
        parser.error("each --raised-marker id may be given once")


def _fit_homography(
    parser: ArgumentParser, args: argparse.Namespace
) -> tuple[Calibration, int, str, tuple[int, int] | None]:
    """The homography fitted to --point pairs or --image markers, its pair count and how.

    And the size (width, height) [px] of the --image (``None`` for --point pairs).
    """
    size: tuple[int, int] | None = None
    if args.point:
        pixels = [p for p, _ in args.point]
        table = [c for _, c in args.point]
        calibration = Calibration.fit(pixels, table)
        n_pairs = len(pixels)
        how = f"{n_pairs} point pairs"
    else:
        centers = dict(args.marker)
        if len(centers) != len(args.marker):
            parser.error("each --marker id may be given once")
        frame = read_image(args.image)
        size = (int(frame.shape[1]), int(frame.shape[0]))
        calibration = calibration_from_markers(
            frame, centers, side_cm=args.marker_side_cm, dictionary=args.dictionary
        )
        _refuse_mirrored(calibration, centers)
        found = find_markers(frame, centers, args.dictionary)
        _refuse_turned(calibration, {i: found[i] for i in centers})
        corners = " and corners" if args.marker_side_cm else ""
        n_pairs = len(centers) * (5 if args.marker_side_cm else 1)
        how = f"{len(centers)} ArUco marker centres{corners} in {args.image.name}"
    rms = calibration.reprojection_error_cm
    if rms is not None and rms > MAX_HOMOGRAPHY_RMS_CM:
        given = "--point pairs" if args.point else "--marker positions or --marker-side-cm"
        raise CalibrationError(
            f"the fit is {rms:.3f} cm rms (max {calibration.max_error_cm:.3f} cm) from the "
            f"given points (the twin's camera fits to 0.05 cm; refused above "
            f"{MAX_HOMOGRAPHY_RMS_CM:g} cm): the {given} do not match the picture; nothing written"
        )
    return calibration, n_pairs, how, size


def _refuse_mirrored(calibration: Calibration, centers: dict[int, tuple[float, float]]) -> None:
    """Refuse a marker fit that maps the image mirrored onto the table.

    Seen from above, the image's axes (u right, v down) and the table's (x, y, with z up)
    have opposite handedness, so a camera's pixel → table map reverses orientation: its
    Jacobian determinant ``det H / w³`` is negative. An ArUco marker cannot be decoded in
    a mirrored image, so a positive one means two --marker ids were swapped; with only
    their centres that fit can even be exact. (--point pairs are not checked: a camera
    may mirror its picture, and its detections with it.)

    Raises:
        CalibrationError: the fitted map keeps orientation.
    """
    pixels = calibration.table_to_pixel(np.array(list(centers.values()), dtype=float))
    w = pixels @ calibration.H[2, :2] + calibration.H[2, 2]
    if np.all(np.linalg.det(calibration.H) / w**3 > 0):
        raise CalibrationError(
            "the fit maps the picture mirrored onto the table, which a picture of ArUco "
            "markers cannot be: --marker ids are swapped (left for right, or near for far); "
            "nothing written"
        )


def marker_turns_deg(calibration: Calibration, found: dict[int, np.ndarray]) -> dict[int, float]:
    """How far each marker lies turned on the table in ``calibration``'s map [deg].

    0 for a marker lying as :func:`~mearm.vision.aruco.table_corners_cm` has it, its top
    edge towards +y; positive anticlockwise seen from above, within ±180.

    Args:
        calibration: The fitted pixel → table map.
        found: Marker id → its corners in the picture, in ArUco's order (TL, TR, BR, BL).
    """
    turns: dict[int, float] = {}
    for marker_id, corners in found.items():
        tl, tr, br, bl = calibration.pixel_to_table(corners)
        right = (tr - tl) + (br - bl)  # along +x, laid as it should be
        up = (tl - bl) + (tr - br)  # along +y
        along_x = right + np.array([up[1], -up[0]])  # up turned back a quarter: +x too
        turns[marker_id] = float(np.degrees(np.arctan2(along_x[1], along_x[0])))
    return turns


def _refuse_turned(calibration: Calibration, found: dict[int, np.ndarray]) -> None:
    """Refuse a marker fit in which the markers do not lie with their top edge towards +y.

    ArUco reads each marker's corners in its own order (TL, TR, BR, BL), so a marker's
    picture says which way it lies, whatever the camera's turn; mapped by the fit, the
    top edge of each must face +y, as the markers are laid. Ids swapped diagonally (0 for
    2 and 1 for 3 of a rectangle) turn the fit half a turn, which keeps its orientation
    (so :func:`_refuse_mirrored` passes it) and, with only the centres, fits exactly.

    Args:
        calibration: The fitted pixel → table map.
        found: Marker id → its corners in the picture (ArUco's order), every --marker's.

    Raises:
        CalibrationError: a marker lies turned more than :data:`MAX_MARKER_TURN_DEG`.
    """
    turns = marker_turns_deg(calibration, found)
    turned = {i: t for i, t in sorted(turns.items()) if abs(t) > MAX_MARKER_TURN_DEG}
    if not turned:
        return
    if len(turned) == len(turns) and all(
        abs(t) > 180.0 - MAX_MARKER_TURN_DEG for t in turned.values()
    ):
        raise CalibrationError(
            "the fit turns the picture half a turn on the table: every marker's top edge "
            "would face -y (towards the robot): --marker ids are swapped diagonally (e.g. "
            "0 for 2 and 1 for 3), or the markers lie upside down; nothing written"
        )
    listed = ", ".join(f"marker {i} by {t:+.0f} deg" for i, t in turned.items())
    raise CalibrationError(
        f"the fit has markers turned from lying with their top edge towards +y ({listed}): "
        "a --marker position belongs to another id, or a marker is not laid top edge "
        "towards +y; nothing written"
    )


def _write_config(
    target: Path, new_text: str, calibration: Calibration, *, force: bool, keep: bool = False
) -> None:
    """Write the updated config, unless (without ``force``) it holds a better homography.

    A replaced file is kept as ``.bak``: with ``keep`` (an --output other than --config)
    always, else when the new text changes it (the homography it held is not lost to a
    second run that fits a better one).
    """
    if not force and target.exists():
        try:
            old = load_yaml_text(read_text_file(target, what="config file"), source=str(target))
        except (ConfigError, InputFileError):
            old = None
        if isinstance(old, dict):
            _homography_no_worse(old, calibration, target)
    try:
        backup_existing(target, None if keep else new_text)
        write_atomically(target, new_text)
    except OSError as exc:
        raise MearmError(f"cannot write {target}: {exc.strerror or exc}") from None


def main(argv: Sequence[str] | None = None) -> int:
    """Fit the calibration and write it; 0 on success, 1 if it fails, 2 on bad input."""
    parser = _parser()
    args = parser.parse_args(argv)
    _check_arguments(parser, args)
    if args.intrinsics is not None:
        if args.point:
            parser.error("--intrinsics fits the pose from --image and --marker, not --point")
        if args.marker_side_cm is None:
            parser.error("--intrinsics needs --marker-side-cm (the pose is fitted to corners)")
        if args.out is None and not args.dry_run:
            parser.error("--intrinsics needs --out FILE (the camera pose file to write)")
        return _pose(parser, args)
    if args.out is not None:
        parser.error("--out is for the camera pose (with --intrinsics); the config is --output")

    text = _config_text(args.config)
    data = load_yaml_text(text, source=str(args.config))  # refused before any fitting
    if not isinstance(data, dict):
        raise ConfigError(str(args.config), ["top level must be a mapping"])
    composed = expand_config(data, source=str(args.config), path=args.config)  # its extends

    frame_px = _camera_size(composed)
    calibration, n_pairs, how, image_px = _fit_homography(parser, args)
    if image_px is not None and image_px != frame_px:
        raise ConfigError(
            str(args.config),
            [
                f"{args.image} is {image_px[0]}x{image_px[1]} px but the camera gives "
                f"{frame_px[0]}x{frame_px[1]} px frames (camera.width_px, camera.height_px): "
                "a homography maps pixels of the size it was fitted at only; take the "
                "picture at the camera's size, or set camera.width_px and height_px to the "
                "picture's first; nothing written"
            ],
        )
    rms, worst = calibration.reprojection_error_cm, calibration.max_error_cm
    if n_pairs == 4:  # an exact fit: its 0 measures nothing, so none is recorded
        calibration = replace(calibration, reprojection_error_cm=None)

    note = f"fitted {date.today().isoformat()} by mearm calibrate-camera from {how}"
    new_text = update_config_text(
        text, calibration, note, str(args.config), args.output, size_px=frame_px
    )  # or exit 2
    print(f"fitted from {how}")
    print(f"reprojection error: rms {rms:.4f} cm, max {worst:.4f} cm")
    for row in calibration.H:
        print("  [" + ", ".join(f"{v: .9g}" for v in row) + "]")
    print(f"image size: {frame_px[0]}x{frame_px[1]} px (calibration.image_size_px)")
    if args.dry_run:
        target = args.output or args.config
        kept = "is as it was" if target.exists() else "was not made"
        print(f"--dry-run: nothing written ({target} {kept})")
        _exact_fit_note(parser, n_pairs)
        return 0
    target = args.output or args.config
    elsewhere = args.output is not None and file_identity(args.output) != file_identity(args.config)
    _write_config(target, new_text, calibration, force=args.force, keep=elsewhere)
    print(f"wrote the calibration into {target}")
    _exact_fit_note(parser, n_pairs)
    _perspective_note(parser, target)
    _sort_would_refuse(parser, target)
    return 0


def _camera_size(data: dict[str, object]) -> tuple[int, int]:
    """The frame size (width, height) [px] of the composed config ``data``'s camera.

    The size the calibration's pixels are measured in: an --image's must match it, and
    --point pixels are read off the camera's frames. A key the config leaves out is the
    built-in camera's; a value that is no whole number is the loading config's to refuse
    (the written config is validated), so the built-in one stands in for it here.
    """
    camera = data.get("camera")
    given = camera if isinstance(camera, dict) else {}
    size = []
    for key in ("width_px", "height_px"):
        value = given.get(key)
        default = CameraConfig.model_fields[key].default
        size.append(value if isinstance(value, int) and not isinstance(value, bool) else default)
    return size[0], size[1]


def _perspective_note(parser: ArgumentParser, written: Path) -> None:
    """Say, once the homography is written, that a perspective config does not place by it.

    A config with ``calibration.model: perspective`` places what the camera sees with its
    intrinsics and pose files; the homography only outlines the camera's view of the table
    (the random tables' field, the twin's camera where it is not given). A maker who fitted
    a homography into such a config was told ``wrote the calibration`` and nothing else,
    and the next sort placed objects as before.
    """
    try:
        model = load_config(written).calibration.model
    except MearmError:  # the sort's to say (:func:`_sort_would_refuse`)
        return
    if model == "perspective":
        print(
            f"{parser.prog}: note: {written} has calibration.model: perspective, so mearm "
            "sort places objects with its intrinsics and pose files, not this homography; "
            "set calibration.model: homography to place them by it, or fit the camera's "
            "pose with --intrinsics",
            file=sys.stderr,
            flush=True,
        )


def _sort_would_refuse(parser: ArgumentParser, written: Path) -> None:
    """Warn, once the calibration is written, if ``mearm sort`` would refuse it.

    Points typed in the wrong unit (mm for cm) fit a homography of a view the arm
    reaches nowhere: written with exit 0, and refused only by the next sort. The
    calibration is the maker's measurement, so it is kept; the warning says what the sort
    will say. Other problems of the config are the sort's to say.
    """
    from mearm.task.check import check_consistency  # noqa: PLC0415  (the kinematics)

    try:
        check_consistency(load_config(written))
    except MearmError as exc:
        said = [ln for ln in str(exc).splitlines() if "calibration.homography:" in ln]
        if said:
            why = said[0].split("calibration.homography:", 1)[1].strip()
            print(
                f"{parser.prog}: warning: mearm sort --config {written} will refuse this "
                f"calibration: {why}",
                file=sys.stderr,
                flush=True,
            )


def _exact_fit_note(parser: ArgumentParser, n_pairs: int) -> None:
    """Say that an exact fit's error measures nothing, once the fit is written.

    One line on stderr, as notes are (stdout holds the results); a refusal before it is
    then stderr's only line.
    """
    if n_pairs == 4:
        print(
            f"{parser.prog}: note: 4 pairs fit exactly, so the error is 0 by construction and "
            "measures nothing (written as reprojection_error_cm: null); add points (or "
            "--marker-side-cm) for an error that measures something",
            file=sys.stderr,
            flush=True,
        )


def _config_text(config: Path) -> str:
    """The text of the ``--config`` file, which this command writes into.

    Raises:
        ConfigError: it cannot be read; a name of a config mearm ships (which every other
            command reads by its name) is said to be one: a shipped config is not the
            user's to edit, so this command takes a file's path.
    """
    try:
        return read_text_file(config, what="config file")
    except InputFileError as exc:
        reason = exc.reason
        if not config.exists() and packaged_config(str(config)) is not None:
            reason = (
                f"{reason} here; {config} names a config mearm ships, which "
                "calibrate-camera does not edit (it writes the fit into --config): write "
                "your own first (mearm init-config) and give its path"
            )
        raise ConfigError(exc.path, [reason]) from None


def _pose(parser: ArgumentParser, args: argparse.Namespace) -> int:
    """The camera pose mode (``--intrinsics``)."""
    intrinsics = load_calibration(args.intrinsics, "intrinsics")
    assert isinstance(intrinsics, Intrinsics)
    centers = dict(args.marker)
    if len(centers) != len(args.marker):
        parser.error("each --marker id may be given once")
    config_text = None
    if args.config is not None:
        config_text = _config_text(args.config)
        data = load_yaml_text(config_text, source=str(args.config))  # refused before any fitting
        expand_config(data, source=str(args.config), path=args.config)  # its extends, arm.use
    frame = read_image(args.image)
    raised = None
    if args.raised_image is not None:
        raised = RaisedView(
            read_image(args.raised_image),
            dict(args.raised_marker),
            args.raised_height_cm,
            args.raised_image.name,
        )
    pose, rms_cm, max_cm = fit_pose(
        frame, intrinsics, centers, args.marker_side_cm, args.dictionary, raised
    )
    c = pose.position_cm
    tilt = float(np.degrees(np.arccos(np.clip(-pose.rotation[2, 2], -1.0, 1.0))))
    print(f"fitted the camera's pose from {len(centers)} ArUco markers in {args.image.name}")
    if raised is not None:
        print(
            f"  and {len(raised.centers)} in {raised.name}, {raised.height_cm:g} cm above the table"
        )
    print(f"reprojection error of the corners: rms {pose.rms_px:.3f} px")
    print(f"marker centres on the table: rms {rms_cm:.4f} cm, max {max_cm:.4f} cm")
    print(
        f"camera at ({c[0]:.2f}, {c[1]:.2f}, {c[2]:.2f}) cm, its axis {tilt:.2f} deg from vertical"
    )
    if args.dry_run:
        kept = "is as it was" if args.out.exists() else "was not made"
        print(f"--dry-run: nothing written ({args.out} {kept})")
        return 0
    new_config = None
    if args.config is not None and config_text is not None:
        new_config = point_config_at_files(
            config_text, args.intrinsics, args.out, args.output or args.config, str(args.config)
        )
    save_calibration(
        args.out, pose, force=args.force,
        on_backup=lambda backup: print(backup_written(args.out, backup)),
    )  # fmt: skip
    print(f"wrote the camera pose to {args.out}")
    if new_config is not None:
        target = args.output or args.config
        try:
            elsewhere = args.output is not None and (
                file_identity(args.output) != file_identity(args.config)
            )
            backup_existing(target, None if elsewhere else new_config)
            write_atomically(target, new_config)
        except OSError as exc:
            raise MearmError(f"cannot write {target}: {exc.strerror or exc}") from None
        print(f"pointed {target} at {args.intrinsics} and {args.out}")
    return 0


if __name__ == "__main__":
    run(main)
