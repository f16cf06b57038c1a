"""What the dataset commands write, and what they must never write over.

``mearm dataset show``'s contact sheet: never inside the dataset (it replaced
``meta/info.json``), an existing one only with ``--force``, and ``show .`` names it after
the folder (it crashed). ``--record`` on a full disk: a named error, exit 1, and a first
recording leaves nothing that refuses the next one (empty ``data/chunk-000`` folders
did). The full disk is a small tmpfs: mounted only as root (CI runs as root); a full
``/dev/shm`` one mounted there in a mount namespace of the sort's own.
"""

from __future__ import annotations

import errno
import hashlib
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from badinput import ROOT, check_bad_input, run_in_process
from conftest import record_by_hand, tmpfs

from mearm.config import load_config
from mearm.dataset.format_check import check_dataset
from mearm.dataset.recorder import DatasetRecorder
from mearm.hardware.command import ArmCommand
from mearm.task import open_rig

SIM = ROOT / "configs" / "sim.yaml"
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two episodes on the kinematic rig, H.264 (as ``sort --config sim --record-codec
    h264`` records them): copy it to change anything beside it."""
    return record_by_hand(tmp_path_factory.mktemp("outputs") / "ds", frames=30, codec="h264")


@pytest.fixture
def dataset(recorded: Path, tmp_path: Path) -> Path:
    """A copy of the dataset in this test's own folder (its sheet goes beside it)."""
    root = tmp_path / "ds"
    shutil.copytree(recorded, root)
    return root


def _digests(root: Path) -> dict[str, str]:
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(root.rglob("*"))
        if p.is_file()
    }


# ----------------------------------------------------------------- dataset show --sheet


@pytest.mark.bad_input
@pytest.mark.parametrize("force", [[], ["--force"]])
@pytest.mark.parametrize("where", ["meta/info.json", "./meta/../meta/stats.json", "new.png"])
def test_show_refuses_a_sheet_inside_the_dataset(
    dataset: Path, where: str, force: list[str]
) -> None:
    """``--sheet DS/meta/info.json`` wrote the PNG over the dataset's metadata, exit 0."""
    sheet = dataset / where
    out = check_bad_input(["dataset", "show", dataset, "--sheet", sheet, *force], keep=[dataset])
    assert f"--sheet {sheet}: is inside the dataset {dataset}" in out.line
    assert out.stdout == ""  # refused before the report
    assert not (dataset / "new.png").exists()
    assert check_dataset(dataset, videos=False) == []


@pytest.mark.bad_input
def test_show_refuses_a_link_into_the_dataset_even_with_force(dataset: Path) -> None:
    link = dataset.parent / "sheet.png"
    link.symlink_to(dataset / "meta" / "info.json")
    out = check_bad_input(
        ["dataset", "show", dataset, "--sheet", link, "--force"], keep=[dataset, link]
    )
    assert "is inside the dataset" in out.line


@pytest.mark.bad_input
@pytest.mark.parametrize("default", [False, True])
def test_show_keeps_an_existing_sheet_without_force(dataset: Path, default: bool) -> None:
    """An existing ``--sheet``, the default ``DS-sheet.png`` too, was replaced silently."""
    sheet = dataset.parent / ("ds-sheet.png" if default else "mine.png")
    sheet.write_text("precious\n")
    argv = ["dataset", "show", dataset] + ([] if default else ["--sheet", sheet])
    out = check_bad_input(argv, keep=[sheet, dataset])
    assert out.line.endswith(f"--sheet {sheet}: exists; pass --force to replace it")
    assert out.stdout == ""


def test_show_replaces_an_existing_sheet_with_force(dataset: Path) -> None:
    sheet = dataset.parent / "ds-sheet.png"
    sheet.write_text("old\n")
    out = run_in_process(["dataset", "show", dataset, "--force"])
    assert out.code == 0, out.stderr
    assert sheet.read_bytes()[:8] == PNG


@pytest.mark.parametrize("inside", [".", "meta"])
def test_show_dot_names_the_sheet_after_the_folder(
    dataset: Path, inside: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``dataset show .`` crashed: ``PosixPath('.') has an empty name``."""
    monkeypatch.chdir(dataset / inside)
    out = run_in_process(["dataset", "show", "." if inside == "." else ".."])
    assert out.code == 0, out.stderr
    sheet = dataset.resolve().parent / "ds-sheet.png"
    assert sheet.read_bytes()[:8] == PNG
    assert f"wrote {sheet} (the contact sheet, " in out.stdout
    assert check_dataset(dataset, videos=False) == []


# ----------------------------------------------------------------- --record's leftovers


def test_record_into_the_empty_folders_a_failed_recording_left(tmp_path: Path) -> None:
    """Empty ``data/chunk-000`` folders (what a first recording that failed on a full
    disk left) refused the retry: "is not empty: pass --resume"; and --resume then said
    "holds files but no meta/info.json". Folders alone hold nothing to lose."""
    root = tmp_path / "ds"
    (root / "data" / "chunk-000").mkdir(parents=True)
    argv = ["sort", "--config", SIM, "--random", "1", "--quiet", "--record", root]
    out = run_in_process([*argv, "--record-codec", "h264"], within_s=30)
    assert out.code == 0, out.stderr
    assert check_dataset(root) == []


# ----------------------------------------------------------------- a full disk (root)


def _record(
    root: Path,
    *more: str,
    random: int = 2,
    shm: str | None = None,
    capfd: pytest.CaptureFixture[str] | None = None,
) -> subprocess.CompletedProcess[str]:
    """``mearm sort --config sim --random N --record ROOT``: with ``capfd`` in this process
    (the full disk is a tmpfs under ROOT, which this process sees as the command's would;
    an interpreter each cost 0.4 s of CPU, 2 s over the runs), its stderr what the process
    would have said there: what C code and the encoder's process wrote to the file
    descriptor, then the command's lines; or with ``shm`` in a process of its own.

    ``shm``: the options of a tmpfs mounted on ``/dev/shm`` for that process only (a
    mount namespace of its own: the machine's stays as it is).
    """
    argv = ["sort", "--config", str(SIM), "--random", str(random), "--quiet",
            "--record", str(root), "--record-codec", "h264", *more]  # fmt: skip
    if shm is None:
        assert capfd is not None, "in this process, stderr's file descriptor is read too"
        capfd.readouterr()
        out = run_in_process(argv, within_s=30, cwd=ROOT)
        said = capfd.readouterr()
        return subprocess.CompletedProcess(
            ["mearm", *argv], out.code, said.out + out.stdout, said.err + out.stderr
        )
    mount = f'mount -t tmpfs -o {shm} tmpfs /dev/shm && exec "$@"'
    on_shm = ["unshare", "--mount", "--propagation", "private", "sh", "-c", mount, "sh"]
    return subprocess.run(
        [*on_shm, sys.executable, "-m", "mearm", *argv],
        capture_output=True, text=True, timeout=300, cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
    )  # fmt: skip


def _assert_disk_full(run: subprocess.CompletedProcess[str], root: Path) -> str:
    """Exit 1, the sort stopped on the named error (the file under ``root``, "disk full"),
    the arm parked, and the failure said once on stderr."""
    assert run.returncode == 1, run.stderr
    assert "Traceback" not in run.stderr and "unexpected error" not in run.stderr, run.stderr
    line = run.stderr.strip().splitlines()[-1]
    assert line.startswith(f"mearm sort: stopped: {root}/"), line
    assert ": cannot be written: disk full (No space left on device); recording stopped" in line
    assert line.endswith("; arm parked at home"), line
    assert run.stderr.count("cannot be written") == 1, run.stderr
    return line.removesuffix("; arm parked at home")


@pytest.mark.heavy
def test_a_first_recording_on_a_full_disk_leaves_nothing_and_says_so(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    """It said "unexpected error: OSError", exit 1, and left empty ``data/chunk-000``
    folders: the same command then refused DIR as not empty."""
    with tmpfs(tmp_path / "small", "64k") as small:
        root = small / "ds"
        for attempt in range(2):  # the retry fails the same way: nothing refuses it
            line = _assert_disk_full(_record(root, capfd=capfd), root)
            assert line.endswith("nothing was recorded"), (attempt, line)
            assert list(small.iterdir()) == [], attempt


def _own_shm_possible() -> None:
    """Skip unless this process can mount a tmpfs on ``/dev/shm`` in a namespace of its own."""
    if os.geteuid() != 0 or shutil.which("unshare") is None:
        pytest.skip("a full /dev/shm is a small tmpfs: mounting one needs root and unshare")
    probe = subprocess.run(
        ["unshare", "--mount", "--propagation", "private", "sh", "-c",
         "mount -t tmpfs -o size=4k tmpfs /dev/shm"],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    if probe.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs on /dev/shm here: {probe.stderr.strip()}")


@pytest.mark.parametrize(
    "shm",
    [
        "size=64k",  # room for the segment, not its pages: the first frame died of SIGBUS
        "size=1m,nr_inodes=1",  # no room for a segment: an "unexpected error: OSError"
    ],
)
def test_a_full_dev_shm_at_the_encoders_start_fails_as_a_full_disk(
    tmp_path: Path, shm: str
) -> None:
    """The encoder's ring of frames cannot be had in ``/dev/shm``: exit 1, one line naming
    the segment and what it needs, before any motion; nothing left behind (no dataset
    folder, no segment)."""
    _own_shm_possible()
    root = tmp_path / "ds"
    run = _record(root, shm=shm)
    assert run.returncode == 1, run.stderr
    assert "Traceback" not in run.stderr and "unexpected error" not in run.stderr, run.stderr
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert lines[0].startswith("mearm sort: error: /dev/shm/mearm-ring-"), lines
    assert lines[0].endswith(
        ": cannot be written: disk full (No space left on device; the video encoder's 24 "
        "frames need 23.7 MB of shared memory); recording stopped, nothing was recorded"
    ), lines
    assert not root.exists()


@pytest.mark.parametrize("room", ["32k", "160k", "320k"])
def test_a_resumed_recording_on_a_full_disk_keeps_the_dataset(
    recorded: Path, tmp_path: Path, room: str, capfd: pytest.CaptureFixture[str]
) -> None:
    """Appending on a disk with little room: the named error, and the dataset byte for
    byte as it was (no journal, no staged file, no fragment half appended)."""
    used = sum(p.stat().st_size for p in recorded.rglob("*") if p.is_file())
    size = (used // 4096 + 16) * 4096 + int(room[:-1]) * 1024  # the files' pages, and room
    with tmpfs(tmp_path / "small", str(size)) as small:
        root = small / "ds"
        shutil.copytree(recorded, root)
        before = _digests(root)
        line = _assert_disk_full(_record(root, "--resume", random=6, capfd=capfd), root)
        assert "the dataset keeps the 2 episodes written before" in line
        assert _digests(root) == before
        assert check_dataset(root) == []


def test_an_episode_video_on_a_full_disk_raises_its_error(tmp_path: Path) -> None:
    """FFmpeg's own writes dropped the error: the video was cut short and closed as if
    whole. Written through a Python file, the full disk is raised, errno and all."""
    import av

    from mearm.dataset.encoder_server import EpisodeWriter, rgb_frame

    rng = np.random.default_rng(0)
    with tmpfs(tmp_path / "small", "8k") as small:
        writer = EpisodeWriter(av, small / "e.mp4", 10, (120, 160), "h264")
        with pytest.raises(OSError) as raised:  # noqa: PT012  (the write or the close)
            for _ in range(20):
                writer.add(rgb_frame(av, rng.integers(0, 255, (120, 160, 3), dtype=np.uint8)))
            writer.close()
        writer.discard()
        assert raised.value.errno == errno.ENOSPC


def _one_more_episode(root: Path) -> DatasetRecorder:
    """Append one episode to the dataset at ``root`` in this process (no other episode
    encodes meanwhile: what the disk holds at each step is the same every run)."""
    config = load_config(SIM)
    recorder = DatasetRecorder(root, config, fps=10, codec="h264", resume=True)
    home = ArmCommand.home(config.arm)
    with open_rig(config, []) as rig, rig.bus:
        recorder.attach(rig.bus, rig.camera)
        recorder.begin("green")
        for k in range(30):
            joints = {n: v - np.sin(k / 10) for n, v in home.joints.items()}
            rig.bus.move(ArmCommand(joints, home.tool, k > 15))
        recorder.end()
        recorder.close()
    return recorder


def _pages(size: int) -> int:
    return -(-size // 4096)


def test_an_append_cut_off_by_a_full_disk_is_cut_back(recorded: Path, tmp_path: Path) -> None:
    """The episode's files staged and its journal written, the append of its fragment to
    the video runs out of room: the video is cut back and the journal goes, so the
    dataset is the one before, byte for byte (the journal and a half-appended video
    were left: ``dataset check`` failed until a --resume had room to finish it)."""
    ref = tmp_path / "ref"
    shutil.copytree(recorded, ref)
    before = {p: p.stat().st_size for p in ref.rglob("*") if p.is_file()}
    assert _one_more_episode(ref).failure is None
    after = {p: p.stat().st_size for p in ref.rglob("*") if p.is_file()}
    video = ref / "videos/observation.images.table/chunk-000/file-000.mp4"
    fragment = after[video] - before[video]
    staged = sum(_pages(n) for p, n in after.items() if p != video)  # each new file's
    # the old files, the staged ones, the episode's encoded video (its header and the
    # fragment), the fragment staged to append, the journal: then half the fragment fits
    pages = sum(map(_pages, before.values())) + staged + 2 * _pages(fragment) + 1 + 1
    with tmpfs(tmp_path / "small", str((pages + 1) * 4096 + fragment // 2)) as small:
        root = small / "ds"
        shutil.copytree(recorded, root)
        digests = _digests(root)
        failure = _one_more_episode(root).failure
        assert failure is not None and failure.errno == errno.ENOSPC
        assert failure.path == root / video.relative_to(ref), failure
        assert _digests(root) == digests
        assert check_dataset(root) == []
