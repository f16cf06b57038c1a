"""Write a printable A4 sheet of ArUco markers for ``mearm calibrate-camera``.

    mearm aruco-sheet --output markers.png [--ids 0,1,2,3] [--side-cm 4] [--dpi 300]

The PNG records its resolution, so printing it at 100 % ("actual size") gives markers of
exactly ``--side-cm``; check with the 5 cm scale bar. Cut the markers out with their
white margin, lay them flat on the table with the label (top edge) towards +y (away
from the robot), and measure each centre's (x, y) in the base frame [cm].
"""

from __future__ import annotations

import argparse
import struct
import sys
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
#: Printable marker sides [cm]: smaller is not detectable, larger does not fit on A4.
SIDE_CM = (1.0, 20.0)


def marker_sheet(
    ids: Sequence[int], side_cm: float, dpi: int, dictionary: str = DEFAULT_DICTIONARY
) -> np.ndarray:
    """An A4 portrait page (uint8 grey) with the markers in a 2-column grid, labelled."""
    px_per_cm = dpi / CM_PER_INCH
    w, h = (round(v * px_per_cm) for v in A4_CM)
    page = np.full((h, w), 255, np.uint8)
    side = round(side_cm * px_per_cm)
    cell_w, cell_h = side + round(3 * px_per_cm), side + round(3.5 * px_per_cm)
    rows = (len(ids) + 1) // 2
    if 2 * cell_w > w or rows * cell_h + round(3 * px_per_cm) > h:
        raise MearmError(
            f"{len(ids)} markers of {side_cm:g} cm do not fit on one A4 page: "
            "use fewer ids or a smaller --side-cm"
        )
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
    # 5 cm scale bar at the bottom
    y = h - round(2 * px_per_cm)
    bar = round(5 * px_per_cm)
    page[y : y + round(0.2 * px_per_cm), x0 : x0 + bar] = 0
    cv2.putText(page, "5 cm", (x0 + bar + 20, y + 10), font, scale, 0, 2)
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
    items = [v.strip() for v in text.split(",")]
    if not all(v.isascii() and v.isdigit() and len(v) <= 6 for v in items) or len(items) > 64:
        raise argparse.ArgumentTypeError(
            f"--ids must be up to 64 comma-separated integers 0 … 999999, got {text[:40]!r}"
        )
    return [int(v) for v in items]


def main(argv: Sequence[str] | None = None) -> int:
    """Write the marker sheet; 0 on success, 2 on bad input."""
    parser = ArgumentParser(description="Printable ArUco marker sheet.")
    parser.add_argument("--output", type=Path, required=True, help="PNG file to write")
    parser.add_argument("--force", action="store_true", help="replace an existing --output")
    parser.add_argument("--ids", type=_ids, default=[0, 1, 2, 3], help="marker ids (0,1,2,3)")
    parser.add_argument("--side-cm", type=plain_float, default=4.0, help="marker side [cm] (4)")
    parser.add_argument("--dpi", type=plain_int, default=300, help="print resolution (300)")
    parser.add_argument("--dictionary", default=DEFAULT_DICTIONARY, help="ArUco dictionary")
    args = parser.parse_args(argv)
    if not SIDE_CM[0] <= args.side_cm <= SIDE_CM[1]:
        parser.error(
            f"--side-cm must be in [{SIDE_CM[0]:g}, {SIDE_CM[1]:g}] cm, got {args.side_cm:g}"
        )
    if not 72 <= args.dpi <= 2400:
        parser.error(f"--dpi must be in [72, 2400], got {args.dpi}")
    if len(set(args.ids)) != len(args.ids):
        parser.error(f"--ids repeat: {args.ids}")
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
    print(f"wrote {args.output}: print at 100 % and check the 5 cm bar", file=sys.stderr)
    return 0


if __name__ == "__main__":
    run(main)
