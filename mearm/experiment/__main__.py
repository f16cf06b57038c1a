"""``python -m mearm.experiment``: run the trials (:mod:`mearm.experiment.command`)."""

from mearm.cli import run
from mearm.experiment.command import main

if __name__ == "__main__":
    run(main)
