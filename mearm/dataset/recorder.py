"""Record runs as a LeRobotDataset v3.0: the run's commands, measured joints and frames.

The recorder is the servo bus's sampler (:class:`~mearm.hardware.bus.Sampler`): whenever
the bus's clock (the command periods streamed, the holds and waits; the twin's physics
time) passes the next frame's time, it takes one frame at ``fps``:

- ``observation.state``: each actuated joint as measured (the twin's joints; a bus that
  measures nothing confirms its commands) [deg or cm], each tool actuator's confirmed
  setting [deg] and ``gripper_closed`` (0 or 1);
- ``action``: the same names, as commanded (the command being sent, else the last one);
- ``observation.images.<camera>``: the camera's frame, drawn and encoded as AV1 (or
  H.264) by another process (:mod:`mearm.dataset.video_encoder`): the twin's camera sends
  the state it is drawn from (:class:`~mearm.dataset.sampler.DrawsElsewhere`), another
  camera's frame is drawn by this process into shared memory.

The sorter opens an episode per pick-and-place (or one per scene) with its task as a
sentence, and ends or abandons it. An ended episode is written once its video is
encoded, while the sort goes on; whole or not at all: its files are written beside the
ones they replace and its video's fragment beside the video file it joins
(:mod:`mearm.dataset.fragments`), all listed in a journal (``meta/.commit.json``), then
appended and renamed into place; a recorder that opens a dataset with a journal
finishes it first. Ctrl-C waits for an episode being written; an unfinished episode (a
fault, Ctrl-C during it) is dropped, and the finished ones are written before the sorter
logs how its sort ended (:meth:`DatasetRecorder.abandon`).

In an experiment each episode is tagged with its trial's seed and its pick's number
(:meth:`DatasetRecorder.start_trial`): a trial cut off by a kill and run again records
only the picks the dataset does not hold. The first pick it records continues the held
one before it: the run timed that pick again (:class:`~mearm.dataset.sampler.Rerun`),
and its actions are checked against the held episode's (:meth:`DatasetRecorder._after_held`).

What a replay needs besides the scene is kept with each episode (:class:`EpisodeStart`,
``meta/mearm_starts.json``): the episode of the same sort it continues (an episode per
pick after a sort's first starts where the one before left the arm and the table), and
the servo calibration the sort made at its start (``servo.calibrate_at_start``), as a
servo calibration file in the dataset, which each episode carries to it
(:meth:`~mearm.dataset.sampler.EpisodeSampler.servos_calibrated`): one a worker process
recorded (``mearm experiment --jobs N``) too.
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import shutil
import tempfile
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.config import Config, SceneObject
from mearm.config.files import resolve_config_path
from mearm.dataset import lerobot_format as L
from mearm.dataset.errors import (
    DatasetError,
    DatasetExistsError,
    DatasetWriteError,
    ExtraMissingError,
)
from mearm.dataset.feature_stats import Stats, aggregate, image_stats, to_json, vector_stats
from mearm.dataset.fragments import EpisodeVideo, file_header, tear
from mearm.dataset.reading import (  # noqa: F401  (EpisodeStart, read_starts re-exported)
    JOURNAL_SHAPE,
    EpisodeStart,
    RecordedScene,
    Tag,
    damaged,
    read_episodes,
    read_info,
    read_json,
    read_starts,
    read_table,
    read_tags,
    read_tasks,
    starts_json,
    tags_json,
)
from mearm.dataset.sampler import (  # noqa: F401  (re-exported: what an episode is)
    SCENE_TASK,
    STATS_PIXEL_STRIDE,
    EpisodeCapture,
    EpisodeSampler,
    Per,
    Rerun,
    _Episode,
    no_interrupt,
    state_names,
    task_sentence,
)
from mearm.errors import MearmError

if TYPE_CHECKING:
    from mearm.hardware.bus import ServoBus
    from mearm.vision import Camera

#: The name of the camera's feature (``observation.images.table``): it looks at the table.
CAMERA_NAME = "table"


def import_extra(*, av_here: bool = True) -> tuple[Any, Any, Any]:
    """pyarrow, pyarrow.parquet and av, or a one-line error naming the extra.

    ``av_here=False``: av is only looked for, ``None`` in its place: a recorder's videos
    are encoded by another process, which imports it (45 ms of CPU, not paid twice).
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise ExtraMissingError("pyarrow") from None
    if not av_here:
        if importlib.util.find_spec("av") is None:
            raise ExtraMissingError("PyAV (av)")
        return pa, pq, None
    try:
        import av
    except ImportError:
        raise ExtraMissingError("PyAV (av)") from None
    return pa, pq, av


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in its folder (no torn file)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name + ".", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


@dataclass(frozen=True)
class _SortRun:
    """The sort whose episodes are being recorded (:meth:`DatasetRecorder.attach`).

    Attributes:
        number: Its number in this recorder: episodes of one sort continue one another.
    """

    number: int


def finish_journal(root: Path) -> bool:
    """Finish an episode's journal, if one is there; whether there was one.

    Its appends first (a video file cut back to its size before, then the episode's
    fragment added: the same file however often this is repeated), then its renames.
    """
    journal = root / L.JOURNAL_PATH
    if not journal.exists():
        return False
    entries = read_json(root, L.JOURNAL_PATH)
    if not (
        isinstance(entries, dict)
        and isinstance(entries.get("replace"), dict)
        and isinstance(entries.get("append", {}), dict)
    ):
        raise damaged(root, L.JOURNAL_PATH, JOURNAL_SHAPE)
    for rel, append in entries.get("append", {}).items():
        fragment = root / append["from"]
        if fragment.exists():
            with _naming(root / rel), open(root / rel, "r+b") as f:
                f.truncate(append["size"])
                f.seek(0, os.SEEK_END)
                f.write(fragment.read_bytes())
                f.flush()
                os.fsync(f.fileno())
            fragment.unlink()
    for final, tmp in entries["replace"].items():
        if (root / tmp).exists():
            os.replace(root / tmp, root / final)
    journal.unlink()
    return True


@contextlib.contextmanager
def _naming(path: Path) -> Iterator[None]:
    """An OSError in the block names ``path`` (a write's own error names no file)."""
    try:
        yield
    except OSError as exc:
        if exc.filename is None and exc.errno is not None:
            raise OSError(exc.errno, os.strerror(exc.errno), str(path)) from exc
        raise


def _holds_files(root: Path) -> bool:
    """Whether ``root`` holds a file anywhere but in the scratch folder (not only folders).

    A tree of empty folders holds nothing to lose: a recording that failed before its
    first episode (an older mearm left them) is recorded into again without --resume.
    """
    for folder, dirs, files in os.walk(root):
        if files or any(os.path.islink(os.path.join(folder, d)) for d in dirs):
            return True  # a link to a folder is the user's too
        if folder == str(root):
            dirs[:] = [d for d in dirs if d != L.SCRATCH_DIR]
    return False


def check_root(root: Path, *, resume: bool) -> bool:
    """Check the directory to record into; whether it holds a dataset to append to.

    With ``resume``, an episode's journal left by a kill is finished first.

    Raises:
        DatasetError: it is a file, or cannot be created or written.
        DatasetExistsError: it holds a file (empty folders do not count) and ``resume``
            is off.
    """
    if root.exists() and not root.is_dir():
        raise DatasetError(root, "is a file, not a directory: give a directory to record into")
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise DatasetError(root, f"cannot be created ({exc.strerror})") from None
    try:  # a file made and removed: permission bits do not tell (root, read-only mounts)
        fd, probe = tempfile.mkstemp(dir=root, prefix=".mearm-probe-")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise DatasetError(
            root, f"is not writable ({exc.strerror}): give a directory you can write to"
        ) from None
    held = _holds_files(root)
    if held and not resume:
        raise DatasetExistsError(root)
    if held:  # a first episode killed mid-renames has its info.json in the journal
        finish_journal(root)
    if held and not (root / L.INFO_PATH).exists():
        raise DatasetError(
            root, f"--resume: holds files but no {L.INFO_PATH}: not a dataset to append to"
        )
    return held


class DatasetRecorder(EpisodeSampler):
    """Records episodes into a LeRobotDataset v3.0 directory (module docstring).

    Args:
        root: The dataset's directory: new, empty, or (with ``resume``) a dataset this
            recorder appends to.
        config: The rig's config (the arm's joint and tool names, the camera's size).
        fps: Frames per second of stream time [Hz], ≥ 1.
        per: One episode per ``"pick"`` (pick-and-place) or per ``"scene"`` (a whole sort).
        resume: Append to the dataset in ``root``.
        codec: The video encoding, a key of
            :data:`~mearm.dataset.lerobot_format.VIDEO_CODECS` (``"av1"``, ``"h264"``).
        scene: The scene every episode of this run sorts, as a replay rebuilds it (a
            sort's ``--random N --seed S``), kept with each episode; ``None``: not one,
            or on a simulated table without a belt, the config's own (``task.scene``),
            kept as it is laid once :attr:`kept_config` says which config that is.

    Raises:
        DatasetError: ``root`` is a file or not writable; with ``resume``, its dataset
            has another fps, robot, features or encoding, or a file of it is damaged.
        DatasetExistsError: ``root`` is not empty and ``resume`` is off.
        ExtraMissingError: pyarrow or PyAV is not installed.
        EncoderError: the encoder process could not be started.
        ValueError: ``fps`` below 1, ``per`` or ``codec`` unknown (the CLI checks them first).
    """

    def __init__(
        self,
        root: Path,
        config: Config,
        *,
        fps: int,
        per: Per = "pick",
        resume: bool = False,
        codec: str = L.DEFAULT_CODEC,
        scene: RecordedScene | None = None,
    ):
        root = Path(root)
        super().__init__(config, fps=fps, per=per, codec=codec, scratch=root / L.SCRATCH_DIR)
        self._pa, self._pq, _ = import_extra(av_here=False)
        self.root = root
        self.video_key = L.IMAGES + CAMERA_NAME
        self.robot_type = config.arm.name
        # the folders this recorder makes, parents first: those left empty go at close()
        self._made = [p for p in (root, *root.parents) if not p.exists()][::-1]
        existing = check_root(self.root, resume=resume)
        if not finish_journal(self.root):  # files of an episode whose journal was not written
            for stale in self.root.glob("**/*.tmp"):
                stale.unlink()
        shutil.rmtree(self._scratch, ignore_errors=True)
        self._episodes: list[dict[str, Any]] = []
        self._tags: list[Tag] = []
        self._scenes: list[RecordedScene | None] = []  # each episode's, as self._tags
        self._starts: list[EpisodeStart] = []  # each episode's, as self._tags
        self.scene = scene
        #: The table a sort lays when no scene is given (:meth:`attach`), if simulated.
        self._own_table: tuple[SceneObject, ...] = ()
        if scene is None and config.simulated_table and config.belt is None:
            self._own_table = tuple(config.task.scene)
        self._run = _SortRun(0)  # the sort being recorded
        # written by the writer thread: the last episode written (its sort's number, its
        # start on the bus's clock, its length and tag) and each sort's servo file
        self._last: tuple[int, float, int, Tag] | None = None
        self._servo_files: dict[int, str | None] = {}
        self._tasks: list[str] = []
        self._stats: dict[str, Stats] = {}  # the dataset's, aggregated
        self._episodes_table: Any = None  # meta/episodes' table, as last written
        self._data_table: tuple[str, Any] | None = None  # the last data file and its table
        if existing:
            self._load()
        # one thread writes the episodes, in order, while the sort goes on (its files'
        # fsyncs and pyarrow's writing let go of the GIL)
        self._writer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mearm-dataset")
        self._writes: deque[Future[None]] = deque()
        self._failed = False
        #: Why the recording stopped, if a write failed (a full disk): raised once, kept.
        self.failure: DatasetWriteError | None = None
        # the episode being written (:meth:`_commit`): its files staged (each new one by
        # the one it replaces), all it wrote, the file being written now, and its sort
        self._moves: dict[str, Path] = {}
        self._temps: list[Path] = []
        self._appends: dict[str, dict[str, Any]] = {}  # the journal's: video file → fragment
        self._later: dict[str, Callable[[Path], object]] = {}  # a file: what writes it
        self._target = self.root
        self._writing = self._run

    def features(self) -> dict[str, dict[str, Any]]:
        """The ``features`` of ``meta/info.json``."""
        n = len(self.names)
        h, w = self._size
        spec = L.VIDEO_CODECS[self.codec]
        return {
            "observation.state": {"dtype": "float32", "shape": [n], "names": list(self.names)},
            "action": {"dtype": "float32", "shape": [n], "names": list(self.names)},
            self.video_key: {
                "dtype": "video",
                "shape": [h, w, 3],
                "names": ["height", "width", "channels"],
                "info": {
                    "video.height": h,
                    "video.width": w,
                    "video.codec": spec.codec,
                    "video.pix_fmt": L.VIDEO_PIX_FMT,
                    "video.fps": self.fps,
                    "video.channels": 3,
                    "has_audio": False,
                    "video.g": L.VIDEO_GOP,
                    "video.crf": L.VIDEO_CRF,
                    "video.preset": spec.preset,
                    "video.fast_decode": 0,
                    "video.video_backend": "pyav",
                    "video.extra_options": {},
                    "is_depth_map": False,
                },
            },
            **L.DEFAULT_FEATURES,
        }

    def _load(self) -> None:
        """Read the dataset to append to; refuse one recorded differently or damaged.

        Every file the next episode reads or joins is read here, before any motion: the
        last data file is kept for it, its rows checked against its episodes' (a torn
        episode is refused: the next one appended after it would carry the damage on),
        the last video file's boxes walked to its end.
        """
        info = read_info(self.root)
        mine = {"fps": self.fps, "robot_type": self.robot_type, "features": self.features()}
        for key, value in mine.items():
            if info.get(key) != value:
                where, there, here = _first_difference(info.get(key), value, key)
                codec = where.endswith(("video.codec", "video.preset"))
                raise DatasetError(
                    self.root,
                    f"--resume: the dataset's {where} is not this run's ({_short(there)} "
                    f"there, {_short(here)} here): record into a new directory"
                    + (" (or give the dataset's --record-codec)" if codec else ""),
                )
        pq, root = self._pq, self.root
        self._tasks = read_tasks(pq, root)
        self._episodes = read_episodes(pq, root, info)
        self._tags, self._scenes = read_tags(root, len(self._episodes))
        self._starts = read_starts(root, len(self._episodes))
        if not self._episodes:
            return
        try:
            per_episode = [_stats_of_row(ep) for ep in self._episodes]
            self._stats = {f: aggregate([s[f] for s in per_episode]) for f in per_episode[0]}
            last = self._episodes[-1]
            data_rel = L.chunk_file(L.DATA_PATH, last["data/chunk_index"], last["data/file_index"])
            key = self.video_key
            video_rel = L.chunk_file(
                L.VIDEO_PATH,
                last[f"videos/{key}/chunk_index"],
                last[f"videos/{key}/file_index"],
                video_key=key,
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise damaged(
                root, L.chunk_file(L.EPISODES_PATH, 0, 0), f"an episode's row lacks {exc}"
            ) from None
        table = read_table(pq, root, data_rel, ["episode_index", "index"])
        joined = (last["data/chunk_index"], last["data/file_index"])
        rows = [
            ep for ep in self._episodes if (ep["data/chunk_index"], ep["data/file_index"]) == joined
        ]
        problem = _rows_damage(table, rows)
        if problem is not None:
            raise damaged(root, data_rel, problem)
        self._data_table = (data_rel, table)
        problem = tear(root / video_rel)
        if problem is not None:
            raise damaged(root, video_rel, problem)

    # ----------------------------------------------------------------- the run

    def attach(self, bus: ServoBus, camera: Camera) -> None:
        """As :meth:`EpisodeSampler.attach`: a sort begins, its episodes continue one another.

        A sort of the config's own table (no scene given, not an experiment's trial) keeps
        that table as its scene, with :attr:`kept_config`: a replay lays it as it was,
        whatever the config's table is by then.
        """
        super().attach(bus, camera)
        self._run = _SortRun(self._run.number + 1)
        own = self._own_table
        if own and self.scene is None and self._trial is None and self.kept_config is not None:
            self.scene = RecordedScene.laid(own, *self.kept_config)

    def _accept(self, ep: _Episode) -> None:
        self._writes.append(self._writer.submit(self._write, ep, self._run))

    def _write_failed(self, path: Path, exc: OSError, why: str = "") -> DatasetWriteError:
        self._failed = True  # no later episode is written: the disk is full
        if self.failure is None:  # the first says why the recording stopped
            self.failure = DatasetWriteError.of(path, exc, kept=len(self._episodes), why=why)
        return self.failure

    def _settle(self, *, wait: bool) -> None:
        while self._writes and (wait or self._writes[0].done()):
            self._writes.popleft().result()  # a failed write is raised here

    def _held_tags(self) -> list[Tag]:
        return self._tags

    def check_trials_per(self, trials: Mapping[int, int]) -> None:
        """Refuse to record an experiment's trials otherwise than the dataset holds them.

        A trial run again records only the picks the dataset lacks, each known by its
        trial's seed and its number; per scene, the trial's one episode is tagged pick 0
        and holds every pick. A trial cut per pick by one run and per scene by the next
        would be recorded twice, or lost in part (a worker's scene dropped as held).

        Args:
            trials: The experiment's trial numbers, by their seeds.

        Raises:
            DatasetError: An episode of one of them was recorded per the other.
        """
        for index, ((seed, _), row) in enumerate(zip(self._tags, self._episodes, strict=True)):
            if seed is None or seed not in trials:
                continue
            held = "scene" if row["tasks"] == [SCENE_TASK] else "pick"
            if held != self.per:
                raise DatasetError(
                    self.root,
                    f"holds trial {trials[seed]} of this experiment recorded --record-per "
                    f"{held} (episode {index}), not --record-per {self.per}: resume with "
                    f"--record-per {held}, or record into a new directory",
                )

    def check_trials_scenes(
        self, trials: Mapping[int, int], scene_of: Callable[[int], RecordedScene | None]
    ) -> None:
        """Refuse a dataset whose episodes of these trials' seeds sorted other trials.

        A trial run again records only the picks the dataset lacks, known by the trial's
        seed and the pick's number; another experiment's trials of the same seeds (the
        default ``--seed`` 0, another ``--scene``, ``--set`` or config) would be taken for
        them and dropped, the run exiting 0 with none of its episodes recorded.

        Args:
            trials: The experiment's trial numbers, by their seeds.
            scene_of: The scene a trial of that seed records (``None``: not known, a real
                rig's); asked only for the seeds the dataset holds.

        Raises:
            DatasetError: An episode of one of those seeds records another scene.
        """
        mine: dict[int, RecordedScene | None] = {}
        for index, ((seed, _), held) in enumerate(zip(self._tags, self._scenes, strict=True)):
            if seed is None or seed not in trials or held is None:
                continue
            if seed not in mine:
                mine[seed] = scene_of(seed)
            ours = mine[seed]
            differs = None if ours is None else _how_trials_differ(held, ours)
            if differs is not None:
                raise DatasetError(
                    self.root,
                    f"holds episode {index} of another experiment's trial of seed {seed} "
                    f"(trial {trials[seed]} here): {differs}; record into a new directory, "
                    "or give this experiment another --seed",
                )

    def write_episodes(self, episodes: list[_Episode]) -> None:
        """Write episodes recorded elsewhere (:class:`EpisodeCapture`, a worker's trial).

        In order, each whole, before this returns; one whose (trial, pick) the dataset
        holds already is not written again: the episode after it continues the held one
        (:class:`~mearm.dataset.sampler.Rerun`, as a held pick run in this process).
        """
        held = set(self._tags)
        self._run = _SortRun(self._run.number + 1)  # a trial's: they continue one another
        reran = None
        batch = []
        with no_interrupt():
            for ep in episodes:
                if ep.tag[0] is not None and ep.tag in held:
                    self.episodes_skipped += 1
                    reran = Rerun(ep.tag, ep.start_s, ep.actions)
                    continue
                ep.before, reran = reran, None
                batch.append(ep)
            if batch:  # one commit for the trial's episodes (:meth:`_commit`)
                self._writes.append(self._writer.submit(self._write_all, batch, self._run))
            self._settle(wait=True)

    def abandon(self) -> None:
        """As :meth:`EpisodeSampler.abandon`; a write that fails here is kept, not raised.

        The sorter abandons on its way out of a fault or Ctrl-C, before it parks the arm:
        a full disk must not cut that short. :attr:`failure` keeps it, and the command
        says it once the run is over (:func:`~mearm.dataset.arguments.close_recorder`).
        """
        with contextlib.suppress(DatasetWriteError):
            super().abandon()

    def held_note(self) -> str:
        """``; it holds M episodes, G frames`` after a ``--resume`` appended, else nothing.

        A ``wrote DIR/ (N episodes, F frames)`` line names what this run added; after a
        resume it read as the dataset's size, while the dataset held more.
        """
        episodes = len(self._episodes)
        if episodes <= self.episodes_written:
            return ""
        frames = sum(int(ep["length"]) for ep in self._episodes)
        return f"; it holds {episodes} episodes, {frames} frames"

    def close(self) -> None:
        """Write the finished episodes, drop an unfinished one, stop the encoder.

        The scratch folder goes, and so does each folder this recorder made that holds
        nothing (DIR too, if it was made for nothing): a first recording that failed on
        a full disk leaves nothing that would refuse the next one. A finished episode
        that cannot be written here is :attr:`failure`.
        """
        try:
            super().close()
        finally:
            self._failed = True  # a write still queued after an error is not made
            self._writer.shutdown(wait=True, cancel_futures=True)
            shutil.rmtree(self._scratch, ignore_errors=True)
            for folder in reversed(self._made):  # the deepest first
                with contextlib.suppress(OSError):  # only if empty: never a file
                    folder.rmdir()

    def _make_dirs(self, folder: Path) -> None:
        """``mkdir -p folder``, each folder made remembered (:meth:`close`)."""
        made = []
        at = folder
        while not at.exists():
            made.append(at)
            at = at.parent
        folder.mkdir(parents=True, exist_ok=True)
        self._made += made[::-1]

    # ----------------------------------------------------------------- writing

    def _write(self, ep: _Episode, run: _SortRun) -> None:
        """Write one episode of the sort ``run`` (in the writer thread); see :meth:`_write_all`."""
        self._write_all([ep], run)

    def _write_all(self, eps: list[_Episode], run: _SortRun) -> None:
        """Write episodes of the sort ``run``, in order, in one commit (in the writer thread).

        Raises:
            DatasetWriteError: a file could not be written (a full disk): the episodes are
                dropped, their files removed, and no later one is written.
        """
        if self._failed:
            return
        try:
            self._writing = run
            self._commit(eps)
        except OSError as exc:
            raise self._write_failed(self._target, exc) from exc
        except BaseException:
            self._failed = True
            raise
        finally:
            for ep in eps:
                ep.path.unlink(missing_ok=True)
        self.episodes_written += len(eps)
        self.frames_written += sum(ep.length for ep in eps)

    def _commit(self, eps: list[_Episode]) -> None:
        """Write episodes whole, or leave none of their files (their journal not written).

        One commit (one journal, each file staged, synced and renamed once) for all of
        ``eps``: a worker's trial brings a dozen episodes at once, and a commit's
        syncs and renames, ten of each, and its tables rewritten, took a tenth of a
        second an episode, so that the command's one writer held back two workers (a
        12-trial twin experiment, ``--jobs 2``, recorded: 26 s, 18 of them writing).
        Each episode's rows, stats and starts are what the episode alone commits, in
        the same files: the dataset is the same, byte for byte.
        """
        self._moves, self._temps, self._appends, self._later = {}, [], {}, {}
        before = self._state()
        try:
            for ep in eps:
                self._stage_episode(ep)
            self._commit_staged()
        except Exception:  # a full disk, mostly (a kill leaves them to the next open)
            self._set_state(before)
            if self._roll_back():  # else the journal finishes it at the next open
                for tmp in self._temps:
                    with contextlib.suppress(OSError):
                        tmp.unlink(missing_ok=True)
            raise

    def _state(self) -> tuple[Any, ...]:
        """What a commit changes in this recorder, as it is (:meth:`_set_state` puts it back)."""
        return (
            list(self._episodes), dict(self._stats), list(self._tags), list(self._scenes),
            list(self._starts), self._last, dict(self._servo_files), self._episodes_table,
            self._data_table, list(self._tasks),
        )  # fmt: skip

    def _set_state(self, state: tuple[Any, ...]) -> None:
        (
            self._episodes, self._stats, self._tags, self._scenes, self._starts, self._last,
            self._servo_files, self._episodes_table, self._data_table, self._tasks,
        ) = state  # fmt: skip

    def _staged(self, rel: str) -> Path:
        """Where the episode's new file ``rel`` is written, beside the one it replaces."""
        final = self.root / rel
        self._make_dirs(final.parent)
        tmp = final.with_name(final.name + ".tmp")
        self._moves[rel] = tmp
        self._temps.append(tmp)
        self._target = final
        return tmp

    def _appended(self, rel: str) -> Path:
        """Where the fragment to append to the video file ``rel`` is written."""
        tmp = self.root / (rel + ".append.tmp")
        self._temps.append(tmp)
        self._target = self.root / rel
        return tmp

    def _as_it_stands(self, rel: str) -> Path:
        """The file ``rel`` as this commit leaves it so far: staged, else the dataset's."""
        return self._moves.get(rel, self.root / rel)

    def _roll_back(self) -> bool:
        """Undo an episode that failed before its renames; whether it is undone.

        Its journal written, its fragment's append can fail (a full disk): the video
        file is cut back to its size before (the journal could still redo the append,
        were this process killed now), then the journal goes. Once a rename is made,
        the episode is the journal's to finish.
        """
        root = self.root
        journal = root / L.JOURNAL_PATH
        if not journal.exists():
            return True
        try:
            entries = read_json(root, L.JOURNAL_PATH)
            if not all((root / tmp).exists() for tmp in entries["replace"].values()):
                return False
            for rel, append in entries.get("append", {}).items():
                with open(root / rel, "r+b") as f:
                    f.truncate(append["size"])
                    f.flush()
                    os.fsync(f.fileno())
            journal.unlink()
        except (OSError, DatasetError, KeyError, TypeError, AttributeError):
            return False
        return True

    def _stage_episode(self, ep: _Episode) -> None:
        """Stage one episode of :meth:`_commit`: each file it stages is in ``_temps`` as it begins.

        Files an episode before it in the commit staged are read and staged again as
        they stand (:meth:`_as_it_stands`); this recorder's state is the dataset's with
        the episode. The file being written is ``_target`` (a write's error does not name it).
        """
        pa, pq = self._pa, self._pq
        index = len(self._episodes)
        last = self._episodes[-1] if self._episodes else None
        first_index = int(last["dataset_to_index"]) if last else 0
        if ep.task not in self._tasks:
            self._tasks.append(ep.task)
        task_index = self._tasks.index(ep.task)
        n = ep.length
        states = np.stack(ep.states)
        actions = np.stack(ep.actions)
        staged = self._staged

        # data: appended to the last episode's file unless that has reached its limit
        chunk, file = (0, 0)
        if last:
            chunk, file = int(last["data/chunk_index"]), int(last["data/file_index"])
        data_rel = L.chunk_file(L.DATA_PATH, chunk, file)
        table = self._frames_table(states, actions, index, first_index, task_index)
        old = self._as_it_stands(data_rel)
        if last and old.exists() and _mb(old) + table.nbytes / 2**20 >= L.DATA_FILES_SIZE_IN_MB:
            chunk, file = L.next_file(chunk, file)
            data_rel = L.chunk_file(L.DATA_PATH, chunk, file)
        elif last and old.exists():
            cached = self._data_table
            earlier = cached[1] if cached and cached[0] == data_rel else pq.read_table(old)
            table = pa.concat_tables([earlier, table])
        pq.write_table(table, staged(data_rel), compression="snappy")
        data_meta = {"data/chunk_index": chunk, "data/file_index": file}

        video_meta = self._stage_video(ep, last)

        key = self.video_key
        ep_stats = {
            "observation.state": vector_stats(states),
            "action": vector_stats(actions),
            key: image_stats(np.concatenate(ep.pixels), n),
            "timestamp": vector_stats(np.arange(n, dtype=np.float32) / self.fps),
            "frame_index": vector_stats(np.arange(n)),
            "episode_index": vector_stats(np.full(n, index)),
            "index": vector_stats(np.arange(first_index, first_index + n)),
            "task_index": vector_stats(np.full(n, task_index)),
        }
        row: dict[str, Any] = {
            "episode_index": index,
            "tasks": [ep.task],
            "length": n,
            **data_meta,
            "dataset_from_index": first_index,
            "dataset_to_index": first_index + n,
            **video_meta,
            "meta/episodes/chunk_index": 0,
            "meta/episodes/file_index": 0,
        }
        for feature, stats in ep_stats.items():
            for name, value in stats.items():
                row[f"stats/{feature}/{name}"] = np.asarray(value).tolist()
        episodes = [*self._episodes, row]
        episodes_table = self._with_row(row, episodes)
        # the files each episode rewrites whole, written once a commit, as its last episode
        # leaves them (:meth:`_commit_staged`)
        later = self._later
        later[L.chunk_file(L.EPISODES_PATH, 0, 0)] = partial(pq.write_table, episodes_table)
        later[L.TASKS_PATH] = partial(pq.write_table, tasks_table(pa, self._tasks))
        # the aggregate is associative: the dataset's so far with this episode's
        dataset_stats = {
            f: aggregate([self._stats[f], s]) if self._stats else s for f, s in ep_stats.items()
        }
        later[L.STATS_PATH] = partial(_write_json, to_json(dataset_stats))
        later[L.INFO_PATH] = partial(_write_json, self._info(len(episodes), first_index + n))
        tags = [*self._tags, ep.tag]
        scenes = [*self._scenes, ep.scene]
        later[L.TAGS_PATH] = partial(_write_text, partial(tags_json, tags, scenes))
        starts, servo_file = self._stage_start(ep, index)
        self._episodes = episodes
        self._stats = dataset_stats
        self._tags = tags
        self._scenes = scenes
        self._starts = starts
        self._last = (self._writing.number, ep.start_s, ep.length, ep.tag)
        self._servo_files[self._writing.number] = servo_file
        self._episodes_table = episodes_table
        self._data_table = (data_rel, table)

    def _commit_staged(self) -> None:
        """Sync what :meth:`_stage_episode` staged, write the journal, and finish it."""
        root = self.root
        for rel, write in self._later.items():
            write(self._staged(rel))
        for tmp in dict.fromkeys(self._temps):
            with _naming(tmp), open(tmp, "rb") as f:
                os.fsync(f.fileno())
        journal = {
            "replace": {rel: str(tmp.relative_to(root)) for rel, tmp in self._moves.items()},
            "append": self._appends,
        }
        self._target = root / L.JOURNAL_PATH
        write_atomic(self._target, json.dumps(journal).encode())
        finish_journal(root)

    def _stage_start(self, ep: _Episode, index: int) -> tuple[list[EpisodeStart], str | None]:
        """Stage the starts with episode ``index``'s, and its sort's servo file if new.

        Returns:
            The episodes' starts, and the servo calibration file its sort made (written
            with the sort's first episode, from the calibration it carries; the held
            episode's it continues, the same calibration), or ``None``.
        """
        run = self._writing
        servo_file = self._servo_files.get(run.number)
        start = self._start_of(ep, run, index)
        if ep.servos is not None and servo_file is None:  # the sort's first episode
            if start.after is not None and ep.before is not None:  # the same, checked
                servo_file = self._starts[start.after].servos
            else:
                servo_file = L.SERVOS_PATH.format(episode_index=index)
                self._staged(servo_file).write_text(ep.servos)
        start = replace(start, servos=servo_file)
        starts = [*self._starts, start]
        self._later[L.STARTS_PATH] = partial(_write_text, partial(starts_json, starts))
        return starts, servo_file

    def _start_of(self, ep: _Episode, run: _SortRun, index: int) -> EpisodeStart:
        """Where episode ``index`` starts: where a reset leaves the arm, or after another.

        The first of its sort starts where the reset does (the arm at home, the table as
        laid), unless it is a trial's pick after the first: then it continues the held
        episode of the pick before it, which this run ran again (:meth:`_after_held`). A
        later one continues the one written before it, the time between them counted in
        frames. Not known, with the reason, when its trial's pick before it is not the
        episode it would continue.
        """
        seed, pick = ep.tag
        if ep.before is not None:
            return self._after_held(ep, ep.before)
        last = self._last
        if last is None or last[0] != run.number:
            return self._no_pick_before(ep) if pick not in (None, 0) else EpisodeStart(known=True)
        _, start_s, length, tag = last
        if pick is not None and (tag[0] != seed or tag[1] is None or pick != tag[1] + 1):
            return self._no_pick_before(ep)
        return EpisodeStart(known=True, after=index - 1, gap_frames=self._gap(ep, start_s, length))

    def _gap(self, ep: _Episode, start_s: float, length: int) -> int:
        """The frames between the last of an episode (its start, length) and ``ep``'s first."""
        return max(0, round((ep.start_s - start_s) * self.fps) - (length - 1))

    def _no_pick_before(self, ep: _Episode) -> EpisodeStart:
        """A trial's pick whose pick before it this run did not record nor time: why."""
        seed, pick = ep.tag
        assert pick is not None
        was = (seed, pick - 1)
        if was not in self._tags:
            why = (
                f"pick {pick - 1} of its trial, before it, is not in the dataset (a pick of "
                "fewer than 2 frames is not recorded)"
            )
        else:
            why = (
                f"pick {pick - 1} of its trial, before it (episode {self._tags.index(was)}), "
                "was recorded by an earlier run, and this run did not run it again"
            )
        return EpisodeStart(why=why)

    def _after_held(self, ep: _Episode, before: Rerun) -> EpisodeStart:
        """A pick after one the dataset holds, which this run ran again: after that episode.

        ``mearm experiment --resume`` runs a trial cut off by a kill again from its start;
        its picks the killed run recorded are timed, not recorded. The held episode is the
        pick before as this run ran it if its actions are the same, frame for frame, and
        its sort's servo calibration at the start too (the twin runs a trial the same way
        each time): the gap is then counted on this run's clock. Else not known, the
        reason said.
        """
        seed, pick = ep.tag
        if pick is None or before.tag != (seed, pick - 1) or before.tag not in self._tags:
            return self._no_pick_before(ep)
        held = self._tags.index(before.tag)
        what = f"pick {pick - 1} of its trial, before it (episode {held}, an earlier run's),"
        recorded = self._held_actions(held)
        ran = np.stack(before.actions) if before.actions else np.zeros((0, len(self.names)))
        if isinstance(recorded, str):
            return EpisodeStart(why=f"{what} cannot be read ({recorded})")
        if len(ran) != len(recorded):
            return EpisodeStart(
                why=f"{what} ran {len(ran)} frames when its trial ran again, not "
                f"{len(recorded)}: the trial did not run as it had"
            )
        same = np.all((ran == recorded) | (np.isnan(ran) & np.isnan(recorded)), axis=1)
        if not same.all():
            return EpisodeStart(
                why=f"{what} sent another action at its frame {int(np.argmin(same))} when its "
                "trial ran again: the trial did not run as it had"
            )
        servos = self._starts[held].servos
        if not self._same_servos(servos, ep.servos):
            kept = servos or "the config's own"
            return EpisodeStart(
                why=f"{what} ran other servos ({kept}) than its trial's calibration at the "
                "start when the trial ran again"
            )
        gap = self._gap(ep, before.start_s, before.length)
        return EpisodeStart(known=True, after=held, gap_frames=gap)

    def _held_actions(self, episode: int) -> np.ndarray | str:
        """The ``action`` column of an episode in the dataset, (k, n); why not, if it cannot."""
        row = self._episodes[episode]
        rel = L.chunk_file(L.DATA_PATH, row["data/chunk_index"], row["data/file_index"])
        cached = self._data_table
        try:
            table = (
                cached[1]
                if cached and cached[0] == rel
                else read_table(self._pq, self.root, rel, ["episode_index", "action"])
            )
        except DatasetError as exc:  # the check's to report: this episode is not lost for it
            return str(exc).removeprefix(f"{self.root}/")
        rows = np.flatnonzero(np.asarray(table["episode_index"].to_numpy()) == episode)
        actions = table["action"].take(rows).combine_chunks().flatten()
        return np.asarray(actions.to_numpy(zero_copy_only=False), np.float32).reshape(
            len(rows), len(self.names)
        )

    def _same_servos(self, rel: str | None, text: str | None) -> bool:
        """Whether the dataset's servo file ``rel`` holds the calibration ``text`` holds.

        The same fits made again differ in their date only (``date:``, when it was made).
        """
        if rel is None or text is None:
            return rel is None and text is None
        try:
            kept = (self.root / rel).read_text()
        except OSError:
            return False

        def undated(yaml_text: str) -> list[str]:
            return [line for line in yaml_text.splitlines() if not line.startswith("date:")]

        return undated(kept) == undated(text)

    def _with_row(self, row: dict[str, Any], episodes: list[dict[str, Any]]) -> Any:
        """``meta/episodes``' table with ``row`` added: to the last one written, if it fits."""
        pa = self._pa
        last = self._episodes_table
        if last is not None:
            with contextlib.suppress(pa.ArrowInvalid, pa.ArrowTypeError):
                return pa.concat_tables([last, pa.Table.from_pylist([row], schema=last.schema)])
        return pa.Table.from_pylist(episodes)

    def _stage_video(self, ep: _Episode, last: dict[str, Any] | None) -> dict[str, Any]:
        """The episode's video: its fragment appended to the last episode's file, or a new file.

        An append is staged as a fragment (the journal's ``append``: the file's size
        before, the fragment), to which the commit's later episodes add theirs; a new
        file staged whole takes theirs itself.

        Returns:
            The episode row's video columns.
        """
        key = self.video_key
        video = EpisodeVideo.parse(ep.video if ep.video is not None else ep.path.read_bytes())
        vchunk, vfile = (
            (int(last[f"videos/{key}/chunk_index"]), int(last[f"videos/{key}/file_index"]))
            if last
            else (0, 0)
        )
        video_rel = L.chunk_file(L.VIDEO_PATH, vchunk, vfile, video_key=key)
        old_video = self._as_it_stands(video_rel)
        pending = self._appends.get(video_rel)
        old_mb = _mb(old_video) + (_mb(self.root / pending["from"]) if pending else 0.0)
        # the frames before this episode in the file, counted (no sum of rounded seconds)
        before = round(float(last[f"videos/{key}/to_timestamp"]) * self.fps) if last else 0
        appendable = last is not None and file_header(old_video) == video.header
        too_big = old_mb + len(video.fragments) / 2**20 >= L.VIDEO_FILES_SIZE_IN_MB
        if last and (too_big or not appendable):
            vchunk, vfile = L.next_file(vchunk, vfile)
            video_rel = L.chunk_file(L.VIDEO_PATH, vchunk, vfile, video_key=key)
            before = 0
        if before > 0 and video_rel in self._moves:  # a new file this commit staged
            with _naming(self._moves[video_rel]), self._moves[video_rel].open("ab") as f:
                f.write(video.shifted(before, self.fps))
        elif before > 0 and video_rel in self._appends:  # appended to already
            tmp = self.root / self._appends[video_rel]["from"]
            with _naming(tmp), tmp.open("ab") as f:
                f.write(video.shifted(before, self.fps))
        elif before > 0:
            tmp = self._appended(video_rel)
            tmp.write_bytes(video.shifted(before, self.fps))
            size = (self.root / video_rel).stat().st_size
            self._appends[video_rel] = {"size": size, "from": str(tmp.relative_to(self.root))}
        else:
            self._staged(video_rel).write_bytes(video.header + video.shifted(0, self.fps))
        return {
            f"videos/{key}/chunk_index": vchunk,
            f"videos/{key}/file_index": vfile,
            f"videos/{key}/from_timestamp": before / self.fps,
            f"videos/{key}/to_timestamp": (before + ep.length) / self.fps,
        }

    def _frames_table(
        self, states: np.ndarray, actions: np.ndarray, episode: int, first: int, task: int
    ) -> Any:
        pa = self._pa
        n, width = states.shape
        vec = pa.list_(pa.float32(), width)
        return pa.table(
            {
                "observation.state": pa.FixedSizeListArray.from_arrays(
                    pa.array(states.reshape(-1), pa.float32()), type=vec
                ),
                "action": pa.FixedSizeListArray.from_arrays(
                    pa.array(actions.reshape(-1), pa.float32()), type=vec
                ),
                "timestamp": pa.array(np.arange(n, dtype=np.float32) / np.float32(self.fps)),
                "frame_index": pa.array(np.arange(n, dtype=np.int64)),
                "episode_index": pa.array(np.full(n, episode, dtype=np.int64)),
                "index": pa.array(np.arange(first, first + n, dtype=np.int64)),
                "task_index": pa.array(np.full(n, task, dtype=np.int64)),
            }
        )

    def _info(self, episodes: int, frames: int) -> dict[str, Any]:
        return {
            "codebase_version": L.CODEBASE_VERSION,
            "fps": self.fps,
            "features": self.features(),
            "total_episodes": episodes,
            "total_frames": frames,
            "total_tasks": len(self._tasks),
            "chunks_size": L.CHUNKS_SIZE,
            "data_files_size_in_mb": L.DATA_FILES_SIZE_IN_MB,
            "video_files_size_in_mb": L.VIDEO_FILES_SIZE_IN_MB,
            "data_path": L.DATA_PATH,
            "video_path": L.VIDEO_PATH,
            "robot_type": self.robot_type,
            "splits": {"train": f"0:{episodes}"},
        }


def tasks_table(pa: Any, tasks: list[str]) -> Any:
    """``meta/tasks.parquet``: ``task_index`` by ``task``.

    As pandas writes a DataFrame indexed by task (LeRobot reads it with
    ``pandas.read_parquet``).
    """
    pandas_meta = {
        "index_columns": ["task"],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {
                "name": "task",
                "field_name": "task",
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": None,
            },
        ],
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": "2.2.3",
    }
    table = pa.table(
        {
            "task_index": pa.array(range(len(tasks)), pa.int64()),
            "task": pa.array(tasks, pa.string()),
        }
    )
    return table.replace_schema_metadata({b"pandas": json.dumps(pandas_meta).encode()})


def _stats_of_row(row: dict[str, Any]) -> dict[str, Stats]:
    """An episode's statistics from its ``meta/episodes`` row."""
    out: dict[str, Stats] = {}
    for column, value in row.items():
        if column.startswith("stats/"):
            feature, name = column[len("stats/") :].rsplit("/", 1)
            out.setdefault(feature, {})[name] = np.asarray(value)
    return out


def _rows_damage(table: Any, episodes: list[dict[str, Any]]) -> str | None:
    """What is wrong with a data file's rows, which are exactly its ``episodes``', in order.

    ``None``: nothing. A file whose last episode is torn (rows cut off, the Parquet file
    still whole), or that holds rows no episode claims, is one ``--resume`` must not
    append to: the next episode's rows would follow the wrong ones, and its indices and
    every later episode's with them would be wrong (``mearm dataset check``'s rule
    ``data``, which fails it too).
    """
    held = np.asarray(table["episode_index"].to_numpy())
    index = np.asarray(table["index"].to_numpy())
    at, k = 0, None
    for ep in episodes:
        k, n, first = int(ep["episode_index"]), int(ep["length"]), int(ep["dataset_from_index"])
        got = len(held[at : at + n])
        if got < n:
            return f"episode {k} is torn: the file holds {got} of its {n} frames"
        if not (
            np.all(held[at : at + n] == k)
            and np.array_equal(index[at : at + n], np.arange(first, first + n))
        ):
            return f"the rows of episode {k} are not its frames (episode_index or index differ)"
        at += n
    if at != len(held):
        return (
            f"holds {len(held) - at} rows after its last episode ({k}): an episode torn off "
            "while written"
        )
    return None


def _write_json(tree: Any, path: Path) -> None:
    path.write_text(json.dumps(tree, indent=4))


def _write_text(text: Callable[[], str], path: Path) -> None:
    path.write_text(text())


def _mb(path: Path) -> float:
    return path.stat().st_size / 2**20 if path.exists() else 0.0


#: A key one JSON tree has and the other lacks (:func:`_first_difference`).
_MISSING = object()


def _first_difference(there: Any, here: Any, path: str) -> tuple[str, Any, Any]:
    """The dotted path of the first value that differs between two JSON trees, and both.

    ``features.observation.images.table.info.video.codec`` rather than the whole of two
    ``features`` mappings, which a one-line message would cut before the difference.
    """
    if isinstance(there, dict) and isinstance(here, dict):
        for key in [*here, *(k for k in there if k not in here)]:
            if there.get(key, _MISSING) != here.get(key, _MISSING):
                return _first_difference(
                    there.get(key, _MISSING), here.get(key, _MISSING), f"{path}.{key}"
                )
    return path, None if there is _MISSING else there, None if here is _MISSING else here


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _how_trials_differ(held: RecordedScene, ours: RecordedScene) -> str | None:
    """How a held episode's trial differs from this run's of the same seed; ``None``: it is it.

    The config as given may be named otherwise (``sim``, ``configs/sim.yaml``): it
    differs only where both name files that can be read and they differ.
    """
    if held.table != ours.table or held.seed != ours.seed or held.objects != ours.objects:
        return "its table differs"
    if held.overrides != ours.overrides:
        return f"it was sorted with --set {list(held.overrides)}, this one {list(ours.overrides)}"
    if held.noise_seed != ours.noise_seed:
        return "its noise seed differs"
    if held.config != ours.config:
        texts = _config_text(held.config), _config_text(ours.config)
        if _UNREAD not in texts and texts[0] != texts[1]:
            return f"it sorted --config {held.config}, this one {ours.config}"
    return None


#: A config file that cannot be read now (moved, another folder): not known to differ.
_UNREAD = b"\0unread"


def _config_text(config: str | None) -> bytes | None:
    """The bytes of the config file named so (``None``: the built-in rig), or :data:`_UNREAD`."""
    if config is None:
        return None
    try:
        return resolve_config_path(config).read_bytes()
    except (OSError, MearmError):
        return _UNREAD
