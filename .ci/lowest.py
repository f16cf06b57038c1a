"""Print pip constraints that hold every direct dependency to its lowest allowed release.

pyproject.toml states each dependency as ``name>=X``: X is the oldest version the
project claims to work with (a pin, ``name==X``, is held as it is). The constraint is ``name==X.*``: the release X itself, or
its newest build of that release where the project numbers builds below it (OpenCV's
5.0.0.93 for 5.0.0), which is what pip can be asked for; pip has no "lowest" strategy.
CI installs the project once more under these constraints (``pip install -c``) and runs
the suite there, so a lower bound that no longer holds is caught. Transitive
dependencies still resolve to their newest allowed versions (what uv calls
``lowest-direct``). Usage: ``python .ci/lowest.py EXTRA ... > constraints.txt``.
"""

from __future__ import annotations

import re
import sys
import tomllib
from pathlib import Path

BOUND = re.compile(
    r"^\s*([A-Za-z0-9][A-Za-z0-9._-]*)\s*(\[[^\]]*\])?\s*(>=|==)\s*([^,;\s]+)\s*$"
)


def main(extras: list[str]) -> int:
    project = tomllib.loads(Path("pyproject.toml").read_text(encoding="utf-8"))["project"]
    wanted = list(project["dependencies"])
    for extra in extras:
        wanted += project["optional-dependencies"][extra]
    pins: dict[str, str] = {}
    for requirement in wanted:
        match = BOUND.match(requirement)
        if match is None:
            print(
                f"lowest.py: {requirement!r} is not of the form name>=version or name==version",
                file=sys.stderr,
            )
            return 2
        name, _, op, version = match.groups()
        # an exact pin is held as it is (torch==2.13.0: its CPU build); a bound to its release
        pin = version if op == "==" else f"{version}.*"
        if pins.setdefault(name.lower(), pin) != pin:
            print(f"lowest.py: {name} has two lower bounds", file=sys.stderr)
            return 2
    for name, pin in sorted(pins.items()):
        print(f"{name}=={pin}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
