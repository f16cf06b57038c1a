"""Write the ChArUco calibration board as a printable A4 page (``mearm charuco-board``).

``mearm charuco-board`` from the checkout; the code: :mod:`mearm.tools.charuco_board`.
"""

from mearm.cli import run
from mearm.tools.charuco_board import main

if __name__ == "__main__":
    run(main)
