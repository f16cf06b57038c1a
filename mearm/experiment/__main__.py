"""``python -m mearm.experiment``: run the trials (:mod:`mearm.experiment.commandline`)."""

from mearm.cli import run
from mearm.experiment.commandline import main

if __name__ == "__main__":
    run(main)
