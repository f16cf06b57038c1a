"""Check the camera's calibration with the arm: set an object down, see where the camera sees it.

``mearm check-camera`` from the checkout; the code: :mod:`mearm.tools.check_camera`.
"""

from mearm.cli import run
from mearm.tools.check_camera import main

if __name__ == "__main__":
    run(main)
