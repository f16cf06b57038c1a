"""The project's benchmarks: timings, measured in one run, printed (never asserted).

``mearm bench`` from the checkout; the code: :mod:`mearm.tools.bench`.
"""

from mearm.cli import run
from mearm.tools.bench import main

if __name__ == "__main__":
    run(main)
