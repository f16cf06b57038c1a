"""The README is the front door: short, the two commands first, the figures elsewhere."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
README = (ROOT / "README.md").read_text(encoding="utf-8")
#: A first screen of a terminal or a browser [lines].
FIRST_SCREEN = 40


def test_readme_is_read_in_five_minutes() -> None:
    """At most 200 lines."""
    assert len(README.splitlines()) <= 200


def test_the_two_commands_are_on_the_first_screen() -> None:
    """``make demo`` and ``make test`` appear in a code block within the first screen."""
    first = "\n".join(README.splitlines()[:FIRST_SCREEN])
    block = re.search(r"```bash\n(.*?)```", first, re.S)
    assert block is not None
    assert re.search(r"^make demo\b", block.group(1), re.M)
    assert re.search(r"^make test\b", block.group(1), re.M)


def test_no_long_measurement_dumps() -> None:
    """No bench output or CPU tables: the figures live on their subjects' pages."""
    assert "[ik] " not in README and "[twin] " not in README
    tables = re.findall(r"^\|.*\|$", README, re.M)
    assert not any(re.search(r"\d+\.\d+ (?:ms|µs|s)\b", row) for row in tables)


def test_where_the_figures_live_links_each_subject_page() -> None:
    """Speed, recording and fidelity each have a page, linked from the README."""
    for page in ("docs/benchmarks.md", "docs/datasets.md", "docs/twin.md"):
        assert f"({page}" in README, page


def test_the_moved_figures_are_on_their_pages() -> None:
    """The figures the README once carried are on the doc page of their subject, dated."""
    pages = {
        # the whole run of 2026-11-30 (IK, twin physics, the sort's CPU)
        "docs/benchmarks.md": ["3.22 µs a solve", "102.425", "0.692 s (`import mearm.sort`"],
        "docs/datasets.md": ["**+7.1 %**", "+387 % wall"],
        "docs/twin.md": ["| 0.740 | 0.726 ± 0.149 |", "0.676 cm"],
        "docs/sorting.md": ["0.414 / 0.436"],
        "docs/calibration.md": ["0.008 / 0.024", "0.010 / 0.032"],
        "docs/development.md": ["3 min 29 s"],
        "docs/maker-path.md": ["0.10 µs"],
    }
    for page, figures in pages.items():
        text = (ROOT / page).read_text(encoding="utf-8")
        for figure in figures:
            assert figure in text, f"{page}: {figure}"
        assert "2026-11-2" in text, f"{page}: no date"
