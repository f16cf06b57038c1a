"""Write a printable A4 sheet of ArUco markers for ``mearm calibrate-camera``.

    mearm aruco-sheet --output markers.png [--ids 0,1,2,3] [--side-cm 4] [--dpi 300]

The PNG records its resolution, so printing it at 100 % ("actual size") gives markers of
exactly ``--side-cm``; check with the 5 cm scale bar. Cut the markers out with their
white margin, lay them flat on the table with the label (top edge) towards +y (away
from the robot), and measure each centre's (x, y) in the base frame [cm].
"""

from __future__ import annotations

import argparse
import math
import struct
import zlib
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from mearm.cli import ArgumentParser, plain_float, plain_int, run
from mearm.errors import MearmError
from mearm.fileio import write_atomic
from mearm.vision.aruco import DEFAULT_DICTIONARY, get_dictionary, marker_image

A4_CM = (21.0, 29.7)
CM_PER_INCH = 2.54
#: The smallest marker side printed [cm]: smaller is not detectable. The largest is what
#: fits the page (:func:`largest_side_cm`).
MIN_SIDE_CM = 1.0
#: The page's layout [cm]: what a marker's cell adds to its side across (margins) and
#: down (its label), and the page's margins above and below the grid (the scale bar).
CELL_EXTRA_CM = (3.0, 3.5)
PAGE_MARGIN_CM = 3.0
#: Most ids ``--ids`` reads; how many fit the page is :func:`most_that_fit` (fewer).
MAX_IDS = 64


def _page_px(dpi: int) -> tuple[int, int, float]:
    """The A4 page's (width, height) [px] at ``dpi``, and its pixels per cm."""
    px_per_cm = dpi / CM_PER_INCH
    w, h = (round(v * px_per_cm) for v in A4_CM)
    return w, h, px_per_cm


def largest_side_cm(count: int, dpi: int) -> float:
    """The largest marker side [cm] at which ``count`` markers fit on the page at ``dpi``.

    From :func:`marker_sheet`'s layout (2 columns, ``(count + 1) // 2`` rows, each cell
    :data:`CELL_EXTRA_CM` larger than its marker, :data:`PAGE_MARGIN_CM` for the scale
    bar), in whole pixels as the page is drawn. Below :data:`MIN_SIDE_CM` when ``count``
    markers do not fit at any printable side.
    """
    w, h, px_per_cm = _page_px(dpi)
    extra_w, extra_h = (round(v * px_per_cm) for v in CELL_EXTRA_CM)
    rows = (count + 1) // 2
    side_px = min(w // 2 - extra_w, (h - round(PAGE_MARGIN_CM * px_per_cm)) // rows - extra_h)
    return side_px / px_per_cm


def most_that_fit(dpi: int) -> int:
    """The most markers one page holds at ``dpi`` (at :data:`MIN_SIDE_CM`): 10 on A4."""
    return max(
        (n for n in range(1, MAX_IDS + 1) if largest_side_cm(n, dpi) >= MIN_SIDE_CM), default=0
    )


def check_side(count: int, side_cm: float, dpi: int) -> None:
    """Refuse a marker side that is not printable or whose ``count`` markers do not fit.

    The bound is the page's (:func:`largest_side_cm`), so the message names the largest
    side that fits rather than a number the page cannot hold.

    Raises:
        MearmError: ``count`` markers fit at no printable side, or ``side_cm`` is below
            :data:`MIN_SIDE_CM`, above what fits, or not a number.
    """
    largest = largest_side_cm(count, dpi)
    if largest < MIN_SIDE_CM:
        most = most_that_fit(dpi)
        raise MearmError(
            f"--ids: {count} markers do not fit on one A4 page at any --side-cm (the least "
            f"is {MIN_SIDE_CM:g} cm); at most {most} fit: split them over sheets"
        )
    shown = math.floor(largest * 100) / 100  # a side typed as shown fits too
    markers = f"{count} marker{'s' if count != 1 else ''}"
    if side_cm > largest:
        fewer = (
            " (fewer ids per sheet fit larger ones)" if largest_side_cm(2, dpi) > largest else ""
        )
        raise MearmError(
            f"--side-cm {side_cm:g}: {markers} of {side_cm:g} cm "
            f"{'does' if count == 1 else 'do'} not fit on one A4 page; the largest side "
            f"that fits is {shown:g} cm{fewer}"
        )
    if not MIN_SIDE_CM <= side_cm:  # also nan
        raise MearmError(
            f"--side-cm must be in [{MIN_SIDE_CM:g}, {shown:g}] cm for {markers} on an A4 "
            f"page, got {side_cm:g}"
        )


def marker_sheet(
    ids: Sequence[int], side_cm: float, dpi: int, dictionary: str = DEFAULT_DICTIONARY
) -> np.ndarray:
    """An A4 portrait page (uint8 grey) with the markers in a 2-column grid, labelled.

    Raises:
        MearmError: the markers do not fit (:func:`check_side`).
    """
    check_side(len(ids), side_cm, dpi)
    w, h, px_per_cm = _page_px(dpi)
    page = np.full((h, w), 255, np.uint8)
    side = round(side_cm * px_per_cm)
    extra_w, extra_h = (round(v * px_per_cm) for v in CELL_EXTRA_CM)
    cell_w, cell_h = side + extra_w, side + extra_h
    x0 = (w - 2 * cell_w) // 2
    font, scale = cv2.FONT_HERSHEY_SIMPLEX, dpi / 200
    # white quiet zone between a marker and its label: a module (0.3 … 0.8 cm), so the
    # label's descenders stay clear of the edge the detector fits
    modules = get_dictionary(dictionary).markerSize + 2
    quiet = round(min(max(side_cm / modules, 0.3), 0.8) * px_per_cm)
    for k, marker_id in enumerate(ids):
        cx = x0 + (k % 2) * cell_w + (cell_w - side) // 2
        cy = round(1.5 * px_per_cm) + (k // 2) * cell_h + round(1.0 * px_per_cm)
        page[cy : cy + side, cx : cx + side] = marker_image(marker_id, side, dictionary)
        label = f"id {marker_id}  ({dictionary}, {side_cm:g} cm)  ^ +y"
        (_, _), descent = cv2.getTextSize(label, font, scale, 2)
        cv2.putText(page, label, (cx, cy - quiet - descent), font, scale, 0, 2)
    # 5 cm scale bar at the bottom, under the first column's markers: the grid's own edge
    # is the page's at the largest side, where a printer prints nothing
    y = h - round(2 * px_per_cm)
    bar, bx = round(5 * px_per_cm), x0 + (cell_w - side) // 2
    page[y : y + round(0.2 * px_per_cm), bx : bx + bar] = 0
    cv2.putText(page, "5 cm", (bx + bar + 20, y + 10), font, scale, 0, 2)
    return page


def png_with_dpi(image: np.ndarray, dpi: int) -> bytes:
    """PNG bytes of ``image`` with a pHYs chunk, so printers keep the physical size."""
    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise MearmError("PNG encoding failed")
    data = buf.tobytes()
    ppm = round(dpi / 0.0254)  # pixels per metre
    body = b"pHYs" + struct.pack(">IIB", ppm, ppm, 1)
    chunk = struct.pack(">I", 9) + body + struct.pack(">I", zlib.crc32(body))
    end_ihdr = 8 + 8 + 13 + 4  # signature, IHDR length+type, IHDR data, CRC
    return data[:end_ihdr] + chunk + data[end_ihdr:]


def _ids(text: str) -> list[int]:
    """The ids of ``--ids``; how many fit one page is :func:`check_side`'s to say.

    More than :data:`MAX_IDS` never fit; they are refused in the page's words too.
    """
    items = [v.strip() for v in text.split(",")]
    if not all(v.isascii() and v.isdigit() and len(v) <= 6 for v in items):
        raise argparse.ArgumentTypeError(
            f"--ids must be comma-separated integers (at most {_MOST} fit one A4 page), "
            f"each a marker id of --dictionary (0 … 49 in the default {DEFAULT_DICTIONARY}), "
            f"got {text[:40]!r}"
        )
    if len(items) > MAX_IDS:
        raise argparse.ArgumentTypeError(
            f"{len(items)} markers do not fit on one A4 page at any --side-cm (the least is "
            f"{MIN_SIDE_CM:g} cm); at most {_MOST} fit: split them over sheets"
        )
    return [int(v) for v in items]


#: How many markers fit one A4 page, said by ``--help`` and ``--ids``'s refusals: the
#: same at every ``--dpi`` (a test checks it).
_MOST = most_that_fit(300)


def main(argv: Sequence[str] | None = None) -> int:
    """Write the marker sheet; 0 on success, 2 on bad input."""
    parser = ArgumentParser(description="Printable ArUco marker sheet.")
    parser.add_argument("--output", type=Path, required=True, help="PNG file to write")
    parser.add_argument("--force", action="store_true", help="replace an existing --output")
    parser.add_argument(
        "--ids",
        type=_ids,
        default=[0, 1, 2, 3],
        help=(
            f"marker ids (0,1,2,3): at most {_MOST} fit one A4 page (at --side-cm "
            f"{MIN_SIDE_CM:g}; fewer at larger sides), more go on further sheets"
        ),
    )
    parser.add_argument(
        "--side-cm",
        type=plain_float,
        default=4.0,
        help="marker side [cm] (4): at least 1, at most what fits the page for the ids given",
    )
    parser.add_argument("--dpi", type=plain_int, default=300, help="print resolution (300)")
    parser.add_argument("--dictionary", default=DEFAULT_DICTIONARY, help="ArUco dictionary")
    args = parser.parse_args(argv)
    if not 72 <= args.dpi <= 2400:
        parser.error(f"--dpi must be in [72, 2400], got {args.dpi}")
    if len(set(args.ids)) != len(args.ids):
        parser.error(f"--ids repeat: {args.ids}")
    check_side(len(args.ids), args.side_cm, args.dpi)  # the page's bound, before any file
    if args.output.suffix.lower() != ".png":
        parser.error(f"--output must be a .png file, got {args.output}")
    if args.output.exists() and not args.output.is_file():
        parser.error(f"--output {args.output}: exists and is not a regular file")
    if args.output.exists() and not args.force:  # a camera's snapshot is a .png, too
        parser.error(f"--output {args.output}: exists; pass --force to replace it")
    page = marker_sheet(args.ids, args.side_cm, args.dpi, args.dictionary)
    try:
        write_atomic(args.output, png_with_dpi(page, args.dpi))
    except OSError as exc:
        raise MearmError(f"cannot write {args.output}: {exc.strerror or exc}") from None
    print(f"wrote {args.output}: print at 100 % and check the 5 cm bar")
    return 0


if __name__ == "__main__":
    run(main)
