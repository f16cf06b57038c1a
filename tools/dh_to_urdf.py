"""Write the URDF of an arm description: ``mearm urdf`` (:mod:`mearm.tools.dh_to_urdf`)."""

import sys

try:
    from mearm.cli import run
    from mearm.tools.dh_to_urdf import main
except ModuleNotFoundError as exc:  # a Python without mearm: one line, not a traceback
    sys.stderr.write(f"{sys.argv[0]}: error: {exc.name} is not installed: use .venv/bin/python\n")
    sys.exit(2)

if __name__ == "__main__":
    run(main)
