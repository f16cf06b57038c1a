"""Show the bare arm of any config in the meshcat view (issue 6, item 3).

``mearm preview`` from the checkout; the code: :mod:`mearm.tools.preview`.
"""

from mearm.cli import run
from mearm.tools.preview import main

if __name__ == "__main__":
    run(main)
