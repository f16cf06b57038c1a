"""``mearm dataset check --no-videos`` finds a video file cut short.

Found walking docs/datasets.md: with its last fragment cut short (a kill mid-append, a
copy cut off), the dataset passed ``check --no-videos`` ("passes ... (8 rules)", exit 0)
while ``--resume`` and ``show`` refuse it as damaged. The file's boxes are walked, as
they do, without decoding a frame.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from badinput import run_in_process  # noqa: E402
from conftest import record_by_hand  # noqa: E402

from mearm.dataset.format_check import check_dataset  # noqa: E402

VIDEO = "videos/observation.images.table/chunk-000/file-000.mp4"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("walk3_q10_check") / "ds"
    record_by_hand(root, episodes=2, frames=8, codec="h264")
    assert check_dataset(root, videos=False) == []
    return root


def test_a_video_cut_short_fails_without_decoding(dataset: Path, tmp_path: Path) -> None:
    copy = tmp_path / "dsx"
    shutil.copytree(dataset, copy)
    path = copy / VIDEO
    with path.open("r+b") as f:
        f.truncate(path.stat().st_size - 100)
    problems = check_dataset(copy, videos=False)
    assert len(problems) == 1, problems
    assert problems[0].startswith(f"episodes: episode 0: its file {VIDEO} is cut short: box")
    out = run_in_process(["dataset", "check", str(copy), "--no-videos"])
    assert out.code == 1, out
    assert "passes" not in out.stdout
    assert out.stdout.splitlines() == problems


def test_a_whole_dataset_passes_without_decoding(dataset: Path) -> None:
    out = run_in_process(["dataset", "check", str(dataset), "--no-videos"])
    assert (out.code, out.stdout) == (
        0,
        f"{dataset}: passes the LeRobotDataset v3.0 checks (8 rules)\n",
    )
