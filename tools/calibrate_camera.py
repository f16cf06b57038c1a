"""Fit the camera → table calibration and write it into a config file (paper §4).

``mearm calibrate-camera`` from the checkout; the code: :mod:`mearm.tools.calibrate_camera`.
"""

from mearm.cli import run
from mearm.tools.calibrate_camera import main

if __name__ == "__main__":
    run(main)
