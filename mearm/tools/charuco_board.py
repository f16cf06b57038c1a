"""Write the ChArUco calibration board as a printable A4 page (``mearm charuco-board``).

    mearm charuco-board --output board.png [--dpi 300]

The page is A4 landscape with the project's board (:data:`mearm.vision.charuco.DEFAULT_BOARD`,
7 × 5 squares of 3 cm) centred, a line naming it and a 5 cm scale bar. The PNG records
its resolution, so printing it at 100 % ("actual size") gives 3 cm squares: measure the
bar and a square after printing, and glue the sheet flat onto card or board. Calibrate
with ``mearm calibrate-intrinsics``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from mearm.cli import ArgumentParser, plain_int, run
from mearm.errors import MearmError
from mearm.fileio import write_atomic
from mearm.tools.aruco_sheet import A4_CM, CM_PER_INCH, png_with_dpi
from mearm.vision.charuco import DEFAULT_BOARD, BoardSpec

#: Print resolutions accepted [dots per inch]: below 72 a square's edge is blurred by a
#: whole dot of 0.35 mm, above 2400 the page is over 500 Mpx.
DPI_RANGE = (72, 2400)


def board_page(spec: BoardSpec = DEFAULT_BOARD, dpi: int = 300) -> np.ndarray:
    """An A4 landscape page (uint8 grey) with the board centred, its name and a 5 cm bar.

    Args:
        spec: The board.
        dpi: Print resolution [dots per inch].

    Raises:
        MearmError: the board does not fit on the page with room for its label.
    """
    px_per_cm = dpi / CM_PER_INCH
    page_w, page_h = (round(v * px_per_cm) for v in (A4_CM[1], A4_CM[0]))
    page = np.full((page_h, page_w), 255, np.uint8)
    board_w_cm, board_h_cm = spec.size_cm
    if board_w_cm > A4_CM[1] - 2.0 or board_h_cm > A4_CM[0] - 6.0:
        raise MearmError(
            f"a {board_w_cm:g} x {board_h_cm:g} cm board does not fit on an A4 page with "
            f"its label: at most {A4_CM[1] - 2:g} x {A4_CM[0] - 6:g} cm"
        )
    bw, bh = round(board_w_cm * px_per_cm), round(board_h_cm * px_per_cm)
    x0, y0 = (page_w - bw) // 2, (page_h - bh) // 2
    page[y0 : y0 + bh, x0 : x0 + bw] = spec.board().generateImage((bw, bh), marginSize=0)
    font, scale, thick = cv2.FONT_HERSHEY_SIMPLEX, dpi / 250, max(1, round(dpi / 150))
    label = (
        f"ChArUco {spec.squares[0]}x{spec.squares[1]} squares of {spec.square_cm:g} cm, "
        f"markers {spec.marker_cm:g} cm, {spec.dictionary}  -  print at 100 %"
    )
    (tw, _), _ = cv2.getTextSize(label, font, scale, thick)
    cv2.putText(page, label, (max(0, (page_w - tw) // 2), y0 - round(0.8 * px_per_cm)),
                font, scale, 0, thick, cv2.LINE_AA)  # fmt: skip
    bar = round(5 * px_per_cm)
    y = y0 + bh + round(1.0 * px_per_cm)
    page[y : y + round(0.2 * px_per_cm), x0 : x0 + bar] = 0
    cv2.putText(page, "5 cm", (x0 + bar + round(0.3 * px_per_cm), y + round(0.2 * px_per_cm)),
                font, scale, 0, thick, cv2.LINE_AA)  # fmt: skip
    return page


def main(argv: Sequence[str] | None = None) -> int:
    """Write the board page; 0 on success, 2 on bad input."""
    parser = ArgumentParser(description="Printable ChArUco board for calibrate-intrinsics.")
    parser.add_argument("--output", type=Path, required=True, help="PNG file to write")
    parser.add_argument("--force", action="store_true", help="replace an existing --output")
    parser.add_argument("--dpi", type=plain_int, default=300, help="print resolution (300)")
    args = parser.parse_args(argv)
    if not DPI_RANGE[0] <= args.dpi <= DPI_RANGE[1]:
        parser.error(f"--dpi must be in [{DPI_RANGE[0]}, {DPI_RANGE[1]}], got {args.dpi}")
    if args.output.suffix.lower() != ".png":
        parser.error(f"--output must be a .png file, got {args.output}")
    if args.output.exists() and not args.output.is_file():
        parser.error(f"--output {args.output}: exists and is not a regular file")
    if args.output.exists() and not args.force:  # a camera's snapshot is a .png, too
        parser.error(f"--output {args.output}: exists; pass --force to replace it")
    page = board_page(DEFAULT_BOARD, args.dpi)
    try:
        write_atomic(args.output, png_with_dpi(page, args.dpi))
    except OSError as exc:
        raise MearmError(f"cannot write {args.output}: {exc.strerror or exc}") from None
    print(
        f"wrote {args.output}: print at 100 % and check the 5 cm bar and the "
        f"{DEFAULT_BOARD.square_cm:g} cm squares"
    )
    return 0


if __name__ == "__main__":
    run(main)
