"""How often the default IK solve stops short of the target, per arm and kind of start.

``mearm ik-stalls`` from the checkout; the code: :mod:`mearm.tools.ik_stalls`.
"""

from mearm.cli import run
from mearm.tools.ik_stalls import main

if __name__ == "__main__":
    run(main)
