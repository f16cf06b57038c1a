"""The twin's servo step responses, as a table and a plot.

``mearm servo-steps`` from the checkout; the code: :mod:`mearm.tools.servo_steps`.
"""

from mearm.cli import run
from mearm.tools.servo_steps import main

if __name__ == "__main__":
    run(main)
