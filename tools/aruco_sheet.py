"""Write a printable A4 sheet of ArUco markers for ``mearm calibrate-camera``.

``mearm aruco-sheet`` from the checkout; the code: :mod:`mearm.tools.aruco_sheet`.
"""

from mearm.cli import run
from mearm.tools.aruco_sheet import main

if __name__ == "__main__":
    run(main)
