"""Render calibration pictures from the physical twin's camera: ChArUco views and a marker sheet.

``mearm render-calibration`` from the checkout; the code: :mod:`mearm.tools.render_calibration`.
"""

from mearm.cli import run
from mearm.tools.render_calibration import main

if __name__ == "__main__":
    run(main)
