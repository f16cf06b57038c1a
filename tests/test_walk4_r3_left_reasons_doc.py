"""docs/sorting.md names every reason kind the run log's summary can hold in ``left``.

Found walking the page: its list stopped short of ``cut`` (an object the image border
cuts) and ``missed_belt`` (a belt's sort), both kinds :data:`LEFT_REASONS` holds and the
sorters report.
"""

from __future__ import annotations

import re
from pathlib import Path

from mearm.task.report import LEFT_REASONS

ROOT = Path(__file__).resolve().parents[1]


def test_the_page_lists_every_left_reason() -> None:
    page = (ROOT / "docs" / "sorting.md").read_text(encoding="utf-8")
    start = page.index("per reason (`left`)") + len("per reason (`left`)")
    listed = set(re.findall(r"`([a-z_]+)`", page[start : page.index("Exit 0 only", start)]))
    assert set(LEFT_REASONS) - listed == set()
    assert listed - set(LEFT_REASONS) == set()
