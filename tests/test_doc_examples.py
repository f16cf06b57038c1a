"""Every Python example in the docs runs as printed.

Each ```python block of docs/*.md runs in a fresh interpreter, in a scratch folder that
holds the repository's ``configs/`` (the examples name ``configs/sim.yaml``) and nothing
else, so an example that writes a file (``view.screenshot("view.png")``) writes it there.
A block that imports LeRobot is left out: LeRobot cannot be installed beside mearm
(docs/datasets.md says so); tests/test_dataset.py reads the datasets as it does.
Four of docs/view.md's examples had drifted from the API (``cfg.robot``, a colour name,
``mearm.backends.collision_model``, ``show_paths(False)``) with nothing to catch it.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT, browser_or_skip

DOCS = sorted((ROOT / "docs").glob("*.md"))
BLOCK = re.compile(r"^```python\n(.*?)^```", re.M | re.S)


def _examples() -> list[tuple[str, int, str]]:
    found = []
    for doc in DOCS:
        for k, match in enumerate(BLOCK.finditer(doc.read_text(encoding="utf-8"))):
            code = match.group(1)
            if re.search(r"^\s*(from|import) lerobot\b", code, re.M):
                continue
            found.append((str(doc.relative_to(ROOT)), k, code))
    return found


EXAMPLES = _examples()


def test_the_docs_have_python_examples_to_run() -> None:
    """The collection itself: a change to the fence or the folder must not empty it."""
    pages = {doc for doc, _, _ in EXAMPLES}
    assert {"docs/view.md", "docs/inverse-kinematics.md", "docs/servos.md"} <= pages


@pytest.mark.heavy
@pytest.mark.parametrize(
    ("doc", "index", "code"), EXAMPLES, ids=[f"{d}#{k}" for d, k, _ in EXAMPLES]
)
def test_a_python_example_runs_as_printed(doc: str, index: int, code: str, tmp_path: Path):
    if ".screenshot(" in code:
        browser_or_skip()
    (tmp_path / "configs").symlink_to(ROOT / "configs")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    # a hang is the failure: the bound is generous for a loaded 2-core machine
    r = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
        timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, f"{doc}, example {index + 1}:\n{r.stderr[-3000:]}"
