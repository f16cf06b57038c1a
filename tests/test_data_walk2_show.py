"""``mearm dataset show`` refuses a damaged dataset before it prints or draws anything.

docs/datasets.md promises that ``show`` refuses a damaged dataset as ``--resume`` does:
exit 2, one line naming the file. Found walking the page: with its last video
fragment cut short (a kill mid-append), ``show`` drew the sheet and exited 0; with a
data file cut short or a video deleted, it printed the whole report, then refused.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from badinput import check_bad_input  # noqa: E402
from conftest import record_by_hand  # noqa: E402

from mearm.dataset.format_check import check_dataset  # noqa: E402

VIDEO = "videos/observation.images.table/chunk-000/file-000.mp4"
DATA = "data/chunk-000/file-000.parquet"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two short H.264 episodes on the kinematic rig."""
    root = tmp_path_factory.mktemp("walk2_show") / "ds"
    record_by_hand(root, episodes=2, frames=8, codec="h264")
    assert check_dataset(root) == []
    return root


def _damaged(dataset: Path, tmp_path: Path, rel: str, cut: int | None) -> Path:
    """A copy of ``dataset`` with ``rel`` cut by ``cut`` bytes from its end, or deleted."""
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    path = copy / rel
    if cut is None:
        path.unlink()
    else:
        with path.open("r+b") as f:
            f.truncate(path.stat().st_size - cut)
    return copy


@pytest.mark.bad_input
@pytest.mark.parametrize(
    ("rel", "cut", "says"),
    [
        (VIDEO, 100, "cut short: box 'mdat'"),  # the last fragment torn: was exit 0
        (VIDEO, None, "is missing"),  # the report was printed first
        (DATA, 100, "not a readable Parquet file"),  # the report was printed first
    ],
)
def test_show_refuses_before_the_report(
    dataset: Path, tmp_path: Path, rel: str, cut: int | None, says: str
) -> None:
    copy = _damaged(dataset, tmp_path, rel, cut)
    sheet = tmp_path / "s.png"
    out = check_bad_input(["dataset", "show", copy, "--sheet", sheet], keep=[copy])
    assert out.line.startswith(f"mearm dataset: error: {copy / rel}: {says}"), out.line
    assert "the dataset is damaged" in out.line, out.line
    assert out.stdout == "", out.stdout
    assert not sheet.exists()
