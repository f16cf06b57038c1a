"""Measure where the calibrated camera puts objects in the twin, calibrated by mearm's own tools.

``mearm camera-accuracy`` from the checkout; the code: :mod:`mearm.tools.camera_accuracy`.
"""

from mearm.cli import run
from mearm.tools.camera_accuracy import main

if __name__ == "__main__":
    run(main)
