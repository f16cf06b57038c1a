"""The recorder's promises on the kinematic rig, in this process: whole episodes only.

An episode cut off by a kill between its journal and its renames is finished by the next
recorder that opens the dataset; one cut off before its journal leaves nothing behind;
an abandoned episode (a fault, Ctrl-C) is not written; an attempt that moved nothing is
no episode.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import Config, load_config
from mearm.dataset import recorder as recorder_module
from mearm.dataset.format_check import check_dataset
from mearm.dataset.lerobot_format import JOURNAL_PATH
from mearm.dataset.recorder import DatasetRecorder
from mearm.hardware.command import ArmCommand
from mearm.task import open_rig


@pytest.fixture(scope="module")
def sim() -> Config:
    return load_config(ROOT / "configs" / "sim.yaml")


def _record(root: Path, config: Config, plan: list[str], *, resume: bool = False) -> None:
    """Episodes on the kinematic rig: "end" writes one, "abandon" drops one, "still" sends
    nothing before its end."""
    rec = DatasetRecorder(root, config, fps=10, resume=resume)
    home = ArmCommand.home(config.arm)
    with open_rig(config, []) as rig, rig.bus:
        rec.attach(rig.bus, rig.camera)
        for k, how in enumerate(plan):
            rec.begin("red")
            for i in range(0 if how == "still" else 30):
                joints = {n: v + 5 * np.sin(i / 8 + k) for n, v in home.joints.items()}
                rig.bus.move(ArmCommand(joints, home.tool, i > 15))
            if how == "abandon":
                rec.abandon()
            else:
                rec.end()
        rec.close()


@pytest.fixture(scope="module")
def one_episode(sim: Config, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset of one whole episode, recorded once for the tests that copy it (read only:
    a test records into its copy, never into this)."""
    root = tmp_path_factory.mktemp("one_episode") / "ds"
    _record(root, sim, ["end"])
    return root


def _copy_of(dataset: Path, tmp_path: Path) -> Path:
    root = tmp_path / "ds"
    shutil.copytree(dataset, root)
    return root


def _total(root: Path) -> int:
    return json.loads((root / "meta/info.json").read_text())["total_episodes"]


def test_abandoned_and_still_attempts_are_not_written(sim: Config, tmp_path: Path) -> None:
    """Of end, abandon, still, end: two episodes, numbered 0 and 1, and nothing else."""
    _record(tmp_path / "ds", sim, ["end", "abandon", "still", "end"])
    assert _total(tmp_path / "ds") == 2
    assert check_dataset(tmp_path / "ds") == []
    assert not (tmp_path / "ds" / ".recording").exists()


@pytest.mark.heavy
def test_a_kill_after_the_journal_is_finished_on_resume(
    sim: Config, one_episode: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Killed between the journal and its renames: check names it; the next recorder
    finishes it, and the episode is there, whole."""
    root = _copy_of(one_episode, tmp_path)
    real = recorder_module.finish_journal

    def killed(path: Path) -> bool:
        if (path / JOURNAL_PATH).exists():  # an episode's renames are due: stop here
            raise KeyboardInterrupt  # stands for the kill: nothing after it runs
        return real(path)

    monkeypatch.setattr(recorder_module, "finish_journal", killed)
    with pytest.raises(KeyboardInterrupt):
        _record(root, sim, ["end"], resume=True)
    monkeypatch.setattr(recorder_module, "finish_journal", real)
    assert _total(root) == 1  # info.json is among the renames not yet done
    assert [p.split(":")[0] for p in check_dataset(root)] == ["journal"]
    DatasetRecorder(root, sim, fps=10, resume=True).close()
    assert _total(root) == 2
    assert check_dataset(root) == []


@pytest.mark.heavy
def test_a_kill_before_the_journal_leaves_the_dataset_as_it_was(
    sim: Config, one_episode: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Killed while writing an episode's files: they are removed on the next open."""
    root = _copy_of(one_episode, tmp_path)

    def killed(path: Path, data: bytes) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(recorder_module, "write_atomic", killed)
    with pytest.raises(KeyboardInterrupt):
        _record(root, sim, ["end"], resume=True)
    monkeypatch.undo()
    assert list(root.glob("**/*.tmp"))  # the episode's files, not yet in place
    DatasetRecorder(root, sim, fps=10, resume=True).close()
    assert not list(root.glob("**/*.tmp"))
    assert _total(root) == 1
    assert check_dataset(root) == []


def test_a_kill_in_the_first_episodes_renames_is_finished_on_resume(
    sim: Config, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The first episode's journal holds info.json itself: --resume still finds the dataset."""
    root = tmp_path / "ds"
    real = recorder_module.finish_journal

    def killed(path: Path) -> bool:
        if (path / JOURNAL_PATH).exists():  # an episode's renames are due: stop here
            raise KeyboardInterrupt  # stands for the kill: nothing after it runs
        return real(path)

    monkeypatch.setattr(recorder_module, "finish_journal", killed)
    with pytest.raises(KeyboardInterrupt):
        _record(root, sim, ["end"])
    monkeypatch.undo()
    assert not (root / "meta/info.json").exists()
    DatasetRecorder(root, sim, fps=10, resume=True).close()
    assert _total(root) == 1
    assert check_dataset(root) == []


def test_a_peek_is_the_next_read_and_does_not_count(sim: Config) -> None:
    """The recorder's frames leave the simulated camera's own sequence (its noise) as it was."""
    with open_rig(sim) as rig:
        camera = rig.camera
        peeked = camera.peek()
        assert camera.frames_read == 0
        np.testing.assert_array_equal(peeked, camera.read())
        assert camera.frames_read == 1


def test_a_replayed_camera_peeks_at_the_frame_read_last(sim: Config, tmp_path: Path) -> None:
    """A folder of frames: a peek repeats the frame the sort read, and skips none of them."""
    import cv2

    from mearm.vision.camera import FolderCamera

    w, h = sim.camera.width_px, sim.camera.height_px
    for k in range(2):
        cv2.imwrite(str(tmp_path / f"{k}.png"), np.full((h, w, 3), 100 * k + 50, np.uint8))
    camera = FolderCamera(sim.camera.model_copy(update={"kind": "folder", "path": str(tmp_path)}))
    first = camera.read()
    np.testing.assert_array_equal(camera.peek(), first)
    assert int(camera.read()[0, 0, 0]) == 150
