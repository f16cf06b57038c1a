"""Fit the camera's intrinsics (camera matrix, lens distortion) from ChArUco board views.

``mearm calibrate-intrinsics`` from the checkout; the code: :mod:`mearm.tools.calibrate_intrinsics`.
"""

from mearm.cli import run
from mearm.tools.calibrate_intrinsics import main

if __name__ == "__main__":
    run(main)
