"""Run the paper's 24 demo routes with PD-PIJ and compare with its reported figures.

``mearm reproduce-paper`` from the checkout; the code: :mod:`mearm.tools.reproduce_paper`.
"""

from mearm.cli import run
from mearm.tools.reproduce_paper import main

if __name__ == "__main__":
    run(main)
