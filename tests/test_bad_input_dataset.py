"""Bad-input corpus: recording (``--record``) and ``mearm dataset check/show``.

A record directory that is a file, cannot be written or holds a dataset without
``--resume``, a frame rate of 0, options of --record without it; ``check`` of a file, of
a folder with no dataset and of a dataset with a torn last episode (exit 1: a failed
check). Each case: its exit code, one line on stderr, no traceback, the files intact.
"""

from __future__ import annotations

import io
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from badinput import ROOT, check_bad_input
from conftest import record_by_hand

bad_input = pytest.mark.bad_input

SIM = ROOT / "configs" / "sim.yaml"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small dataset of two episodes on the kinematic rig, recorded in this process."""
    return record_by_hand(tmp_path_factory.mktemp("bad-dataset") / "ds", frames=40)


@pytest.fixture(scope="module")
def spots(tmp_path_factory: pytest.TempPathFactory, dataset: Path) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("record-spots")
    (d / "file.txt").write_text("keep me\n")
    (d / "nodata").mkdir()
    (d / "nodata" / "notes.txt").write_text("not a dataset\n")
    torn = d / "torn"
    shutil.copytree(dataset, torn)
    path = torn / "data/chunk-000/file-000.parquet"
    table = pq.read_table(path)
    pq.write_table(table.slice(0, table.num_rows - 3), path)
    return {"dir": d, "file": d / "file.txt", "nodata": d / "nodata", "torn": torn}


@bad_input
def test_record_into_a_file(spots: dict[str, Path]) -> None:
    out = check_bad_input(
        ["sort", "--config", SIM, "--random", "1", "--record", spots["file"]], keep=[spots["file"]]
    )
    assert "is a file, not a directory" in out.line


@bad_input
def test_record_into_an_unwritable_directory(spots: dict[str, Path], tmp_path: Path) -> None:
    if os.geteuid() == 0:  # root writes through permission bits: a read-only kernel folder
        target = Path("/sys/kernel")
        if not target.is_dir():
            pytest.skip("no /sys/kernel to stand for a folder root cannot write")
        keep: list[Path] = []
    else:
        target = tmp_path / "locked"
        target.mkdir(mode=0o500)
        keep = [target]
    out = check_bad_input(["sort", "--config", SIM, "--record", target], keep=keep)
    assert f"{target}: is not writable" in out.line


@bad_input
def test_record_into_a_dataset_without_resume(dataset: Path) -> None:
    log = dataset.parent / "x.jsonl"
    argv = ["experiment", "--config", SIM, "--trials", "1", "--log", log, "--record", dataset]
    out = check_bad_input(argv, keep=[dataset])
    assert "is not empty: pass --resume" in out.line
    assert not log.exists()


@bad_input
def test_resume_a_dataset_at_another_frame_rate(dataset: Path) -> None:
    argv = ["sort", "--config", SIM, "--record", dataset, "--resume", "--record-fps", "5"]
    out = check_bad_input(argv, keep=[dataset])
    assert "--resume: the dataset's fps is not this run's (10 there, 5 here)" in out.line


@bad_input
@pytest.mark.parametrize("command", ["sort", "experiment"])
@pytest.mark.parametrize("fps", ["0", "-5", "2.5", "nan", "1001"])
def test_record_fps_out_of_range(command: str, fps: str, tmp_path: Path) -> None:
    argv = [command, "--config", SIM, "--record", tmp_path / "ds", "--record-fps", fps]
    if command == "experiment":
        argv += ["--log", tmp_path / "x.jsonl"]
    out = check_bad_input(argv)
    assert "--record-fps" in out.line and "frames per second" in out.line
    assert not (tmp_path / "ds").exists()


@bad_input
@pytest.mark.parametrize("command", ["sort", "experiment"])
def test_record_fps_above_what_av1_opens_at(command: str, tmp_path: Path) -> None:
    """SVT-AV1 opens at 240 fps at most: 241 failed after the arm had moved (exit 1, two
    lines); now refused first, naming the codec that records faster."""
    argv = [command, "--config", SIM, "--record", tmp_path / "ds", "--record-fps", "241"]
    if command == "experiment":
        argv += ["--log", tmp_path / "x.jsonl"]
    out = check_bad_input(argv)
    assert out.line.endswith(
        "--record-fps 241: --record-codec av1 records at most 240 frames per second: give "
        "240 or fewer, or --record-codec h264"
    )
    assert not (tmp_path / "ds").exists()


@pytest.mark.parametrize(("fps", "opens"), [(240, True), (241, False)])
def test_av1s_highest_frame_rate_is_the_encoders(fps: int, opens: bool) -> None:
    """The bound the refusal says is the encoder's own: an episode's video opened as the
    recorder opens it (PyAV's SVT-AV1, its log at errors only) at 240 and 241 fps."""
    av = pytest.importorskip("av")
    from mearm.dataset.encoder_server import open_episode_video, rgb_frame, scheduling_kept
    from mearm.dataset.lerobot_format import VIDEO_CODECS

    assert VIDEO_CODECS["av1"].max_fps == 240
    frame = rgb_frame(av, np.zeros((64, 64, 3), np.uint8))
    # (SVT-AV1 opened as root leaves its thread realtime: kept as it was, as the encoder does)
    with scheduling_kept():
        try:  # (it opens the encoder as it writes the file's header)
            out, stream = open_episode_video(av, io.BytesIO(), fps, (64, 64), "av1")
            with out:
                out.mux(stream.encode(frame.reformat(format="yuv420p")))
                out.mux(stream.encode(None))
        except av.error.FFmpegError:
            assert not opens
        else:
            assert opens


@bad_input
@pytest.mark.parametrize(
    "flag",
    [["--resume"], ["--record-fps", "5"], ["--record-per", "scene"], ["--record-codec", "h264"]],
)
def test_record_options_without_record(flag: list[str]) -> None:
    out = check_bad_input(["sort", "--config", SIM, *flag])
    assert f"{flag[0]} is an option of --record DIR" in out.line


@bad_input
def test_record_on_a_cluster(tmp_path: Path) -> None:
    out = check_bad_input(["experiment", "--config", SIM, "--log", tmp_path / "x.jsonl",
                           "--scheduler", "local", "--record", tmp_path / "ds"])  # fmt: skip
    assert "--record writes the dataset here: with --jobs, not with --scheduler" in out.line


@bad_input
@pytest.mark.parametrize("command", ["check", "show"])
def test_dataset_of_a_file_or_a_folder_without_one(command: str, spots: dict[str, Path]) -> None:
    out = check_bad_input(["dataset", command, spots["file"]], keep=[spots["file"]])
    assert "is a file: give a dataset directory" in out.line
    out = check_bad_input(["dataset", command, spots["nodata"]], keep=[spots["nodata"]])
    assert "holds no meta/info.json: not a LeRobot dataset" in out.line
    out = check_bad_input(["dataset", command, spots["dir"] / "missing"])
    assert "does not exist" in out.line


@bad_input
def test_show_refuses_a_folder_as_its_sheet_before_the_report(
    dataset: Path, spots: dict[str, Path]
) -> None:
    """``dataset show DS --sheet .`` printed the whole report, then refused (exit 2)."""
    out = check_bad_input(["dataset", "show", dataset, "--sheet", spots["dir"]], keep=[dataset])
    assert f"--sheet {spots['dir']}: exists and is not a regular file (a folder)" in out.line
    assert out.stdout == ""


@bad_input
def test_check_a_torn_last_episode(spots: dict[str, Path]) -> None:
    out = check_bad_input(["dataset", "check", spots["torn"]], code=1, keep=[spots["torn"]])
    assert "episode 1 is torn: data/chunk-000/file-000.parquet holds" in out.line


def test_the_small_dataset_passes(dataset: Path) -> None:
    """The corpus's dataset is a valid one: each case breaks one thing."""
    from mearm.dataset.format_check import check_dataset

    assert check_dataset(dataset) == []


@bad_input
def test_record_without_the_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "av", None)  # import av fails, as when not installed
    out = check_bad_input(["sort", "--config", SIM, "--record", tmp_path / "ds"])
    assert "needs PyAV (av), which is not installed: pip install 'mearm[record]'" in out.line


@bad_input
def test_record_with_a_camera_that_does_not_open(tmp_path: Path) -> None:
    """Refused before the sort: one line, and no dataset directory left behind."""
    argv = ["sort", "--config", SIM, "--set", "camera.kind=file", "--set",
            f"camera.path={tmp_path / 'none.png'}", "--record", tmp_path / "ds"]  # fmt: skip
    out = check_bad_input(argv)
    assert "no such file (camera.path)" in out.line
    assert not (tmp_path / "ds").exists()


@bad_input
def test_resume_a_dataset_with_another_codec_names_the_codec(dataset: Path) -> None:
    """The features differ only in the video's codec: the line names that key and both
    codecs (it printed the two features mappings, cut before the difference)."""
    argv = ["sort", "--config", SIM, "--record", dataset, "--resume", "--record-codec", "h264"]
    out = check_bad_input(argv, keep=[dataset])
    assert (
        "--resume: the dataset's features.observation.images.table.info.video.codec is not "
        'this run\'s ("av1" there, "h264" here)'
    ) in out.line, out.line
    assert "--record-codec" in out.line.split("here)")[1]
