"""Write the URDF of an arm description (by default: every reference arm).

``mearm urdf`` from the checkout; the code: :mod:`mearm.tools.dh_to_urdf`.
"""

from mearm.cli import run
from mearm.tools.dh_to_urdf import main

if __name__ == "__main__":
    run(main)
