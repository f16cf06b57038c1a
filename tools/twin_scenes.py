"""Sort seeded random scenes in the physical twin and count what lands in its bin.

``mearm twin-scenes`` from the checkout; the code: :mod:`mearm.tools.twin_scenes`.
"""

from mearm.cli import run
from mearm.tools.twin_scenes import main

if __name__ == "__main__":
    run(main)
