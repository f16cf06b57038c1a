"""A worker's trial goes into the dataset in one commit, the same dataset as one by one.

``mearm experiment --jobs N --record DIR``: each worker's trial comes back as a dozen
episodes, which the command wrote one commit each, ten syncs and renames apiece and its
tables rewritten whole each time; a 12-trial twin experiment (``--jobs 2``, H.264) took
24-26 s, where one commit a trial takes 17-18 s. The files are the ones the episodes
written one by one leave, byte for byte, and a write that fails part-way through the
trial leaves none of its episodes (the dataset as it was, no file of the commit left).

In-process, on the kinematic rig of configs/sim.yaml (the trial of
tests/test_resume_starts_picks.py).
"""

from __future__ import annotations

import errno
from pathlib import Path

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("av")

from test_resume_starts_picks import _config, _record, _run  # noqa: E402

from mearm.dataset import recorder as recorder_module  # noqa: E402
from mearm.dataset.errors import DatasetWriteError  # noqa: E402
from mearm.dataset.format_check import check_dataset  # noqa: E402
from mearm.dataset.recorder import DatasetRecorder  # noqa: E402
from mearm.dataset.sampler import EpisodeCapture  # noqa: E402

pytestmark = pytest.mark.heavy


def _captured() -> EpisodeCapture:
    """The trial as a worker records it (its episodes come back as data)."""
    capture = EpisodeCapture(_config(), fps=10, per="pick", codec="h264")
    try:
        _run(capture)
    finally:
        capture.close()
    assert len(capture.episodes) == 3
    return capture


def _files(root: Path) -> dict[str, bytes]:
    return {
        str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()
    }


def test_a_trial_in_one_commit_is_the_dataset_its_episodes_one_by_one_make(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    one_by_one = tmp_path / "one_by_one"
    _record(one_by_one)  # the trial recorded here: a commit as each episode ends
    together = tmp_path / "together"
    recorder = DatasetRecorder(together, _config(), fps=10, codec="h264")
    journals = []  # each commit's (an open finishes one a kill left, too: after it)
    finish = recorder_module.finish_journal
    monkeypatch.setattr(
        recorder_module, "finish_journal", lambda r: journals.append(r) or finish(r)
    )
    try:
        recorder.write_episodes(_captured().episodes)
    finally:
        recorder.close()
    assert len(journals) == 1  # the trial's three episodes, one commit
    assert recorder.episodes_written == 3
    assert _files(together) == _files(one_by_one)
    assert check_dataset(together) == []


def test_a_write_that_fails_part_way_leaves_none_of_the_trials_episodes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    root = tmp_path / "ds"
    _record(root, picks=1)  # a dataset that holds one episode already
    before = _files(root)
    episodes = _captured().episodes
    staged = []
    stage = DatasetRecorder._stage_episode

    def full_at_the_second(self: DatasetRecorder, ep: object) -> None:
        staged.append(ep)
        if len(staged) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        stage(self, ep)

    monkeypatch.setattr(DatasetRecorder, "_stage_episode", full_at_the_second)
    recorder = DatasetRecorder(root, _config(), fps=10, codec="h264", resume=True)
    try:
        with pytest.raises(DatasetWriteError):
            recorder.write_episodes(episodes)
        assert recorder.episodes_written == 0
        assert len(recorder._episodes) == 1  # noqa: SLF001 - what it holds, as before
    finally:
        recorder.close()
    assert _files(root) == before
    assert check_dataset(root) == []
