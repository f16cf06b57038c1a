"""Record runs as a LeRobotDataset v3.0: the run's commands, measured joints and frames.

The recorder is the servo bus's sampler (:class:`~mearm.hardware.bus.Sampler`): whenever
the bus's clock (the command periods streamed, the holds and waits; the twin's physics
time) passes the next frame's time, it takes one frame at ``fps``:

- ``observation.state``: each actuated joint as measured (the twin's joints; a bus that
  measures nothing confirms its commands) [deg or cm], each tool actuator's confirmed
  setting [deg] and ``gripper_closed`` (0 or 1);
- ``action``: the same names, as commanded (the command being sent, else the last one);
- ``observation.images.<camera>``: the camera's frame (:meth:`Camera.peek`), encoded as
  AV1 video.

The sorter opens an episode per pick-and-place (or one per scene) with its task as a
sentence, and ends or abandons it. An episode is written whole or not at all: its files
are written beside the ones they replace, listed in a journal (``meta/.commit.json``),
then renamed into place; a recorder that opens a dataset with a journal finishes its
renames first. Ctrl-C waits for an episode being written; an unfinished episode (a fault,
Ctrl-C during it) is dropped.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np

from mearm.config import Config
from mearm.dataset import lerobot_format as L
from mearm.dataset.errors import DatasetError, DatasetExistsError, ExtraMissingError
from mearm.dataset.feature_stats import Stats, aggregate, image_stats, to_json, vector_stats
from mearm.hardware.bus import MeasuresWorld, ServoBus
from mearm.vision import Camera

#: A frame's pixels kept for the image statistics: every this many rows and columns.
STATS_PIXEL_STRIDE = 16
#: The name of the camera's feature (``observation.images.table``): it looks at the table.
CAMERA_NAME = "table"

Per = Literal["pick", "scene"]


def import_extra() -> tuple[Any, Any, Any]:
    """pyarrow, pyarrow.parquet and av, or a one-line error naming the extra."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise ExtraMissingError("pyarrow") from None
    try:
        import av
    except ImportError:
        raise ExtraMissingError("PyAV (av)") from None
    return pa, pq, av


def state_names(config: Config) -> list[str]:
    """The names of ``observation.state`` and ``action``, in order."""
    arm = config.arm
    return [*arm.home(), *(a.name for a in arm.tool.actuators), "gripper_closed"]


def task_sentence(class_name: str) -> str:
    """The task of a pick-and-place as a sentence."""
    return f"put the {class_name} object in the {class_name} bin"


#: The task of an episode that is a whole scene.
SCENE_TASK = "put each object in the bin of its class"


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


@contextlib.contextmanager
def _no_interrupt() -> Iterator[None]:
    """Hold Ctrl-C (SIGINT) back until the block ends; it is delivered then."""
    try:
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    except (ValueError, OSError):  # not possible here (another thread): run as is
        yield
        return
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def finish_journal(root: Path) -> bool:
    """Finish the renames of an episode's journal, if one is there; whether there was one."""
    journal = root / L.JOURNAL_PATH
    if not journal.exists():
        return False
    moves = json.loads(journal.read_text())["replace"]
    for final, tmp in moves.items():
        if (root / tmp).exists():
            os.replace(root / tmp, root / final)
    journal.unlink()
    return True


def check_root(root: Path, *, resume: bool) -> bool:
    """Check the directory to record into; whether it holds a dataset to append to.

    With ``resume``, an episode's journal left by a kill is finished first.

    Raises:
        DatasetError: it is a file, or cannot be created or written.
        DatasetExistsError: it is not empty and ``resume`` is off.
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
    entries = [p for p in root.iterdir() if p.name != L.SCRATCH_DIR]
    if entries and not resume:
        raise DatasetExistsError(root)
    if entries:  # a first episode killed mid-renames has its info.json in the journal
        finish_journal(root)
    if entries and not (root / L.INFO_PATH).exists():
        raise DatasetError(
            root, f"--resume: holds files but no {L.INFO_PATH}: not a dataset to append to"
        )
    return bool(entries)


class _Episode:
    """The frames of the episode being recorded and its video being encoded."""

    def __init__(self, av: Any, path: Path, fps: int, start_s: float, task: str):
        self.path = path
        self.start_s = start_s
        self.task = task
        self.states: list[np.ndarray] = []
        self.actions: list[np.ndarray] = []
        self.pixels: list[np.ndarray] = []
        self.fps = fps
        self._av = av
        self._out = av.open(str(path), "w")
        self._stream: Any = None

    @property
    def length(self) -> int:
        return len(self.states)

    def add(self, state: np.ndarray, action: np.ndarray, frame_bgr: np.ndarray) -> None:
        if self._stream is None:
            stream = self._out.add_stream(
                L.VIDEO_CODEC,
                rate=self.fps,
                options={"crf": str(L.VIDEO_CRF), "preset": str(L.VIDEO_PRESET)},
            )
            stream.width, stream.height = frame_bgr.shape[1], frame_bgr.shape[0]
            stream.pix_fmt = L.VIDEO_PIX_FMT
            stream.gop_size = L.VIDEO_GOP
            self._stream = stream
        frame = self._av.VideoFrame.from_ndarray(frame_bgr, format="bgr24")
        frame.pts = self.length
        for packet in self._stream.encode(frame):
            self._out.mux(packet)
        self.states.append(state)
        self.actions.append(action)
        step = STATS_PIXEL_STRIDE
        self.pixels.append(frame_bgr[::step, ::step, ::-1].reshape(-1, 3))

    def close(self) -> None:
        if self._stream is not None:
            for packet in self._stream.encode():
                self._out.mux(packet)
        self._out.close()


class DatasetRecorder:
    """Records episodes into a LeRobotDataset v3.0 directory (module docstring).

    Args:
        root: The dataset's directory: new, empty, or (with ``resume``) a dataset this
            recorder appends to.
        config: The rig's config (the arm's joint and tool names, the camera's size).
        fps: Frames per second of stream time [Hz], ≥ 1.
        per: One episode per ``"pick"`` (pick-and-place) or per ``"scene"`` (a whole sort).
        resume: Append to the dataset in ``root``.

    Raises:
        DatasetError: ``root`` is a file or not writable; with ``resume``, its dataset
            has another fps, robot or features.
        DatasetExistsError: ``root`` is not empty and ``resume`` is off.
        ExtraMissingError: pyarrow or PyAV is not installed.
        ValueError: ``fps`` below 1 or ``per`` unknown (the CLI checks both first).
    """

    def __init__(
        self, root: Path, config: Config, *, fps: int, per: Per = "pick", resume: bool = False
    ):
        if fps < 1:
            raise ValueError(f"fps must be at least 1, got {fps}")
        if per not in ("pick", "scene"):
            raise ValueError(f"per must be 'pick' or 'scene', got {per!r}")
        self._pa, self._pq, self._av = import_extra()
        os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1: errors only, not its banner
        self.root = Path(root)
        self.fps = int(fps)
        self.per = per
        self.names = state_names(config)
        self.video_key = L.IMAGES + CAMERA_NAME
        self.robot_type = config.arm.name
        self._size = (config.camera.height_px, config.camera.width_px)
        self._created = not self.root.exists()
        existing = check_root(self.root, resume=resume)
        if not finish_journal(self.root):  # files of an episode whose journal was not written
            for stale in self.root.glob("**/*.tmp"):
                stale.unlink()
        self._scratch = self.root / L.SCRATCH_DIR
        shutil.rmtree(self._scratch, ignore_errors=True)
        self._episodes: list[dict[str, Any]] = []
        self._tasks: list[str] = []
        self._ep_stats: list[dict[str, Stats]] = []
        if existing:
            self._load()
        self._bus: ServoBus | None = None
        self._camera: Camera | None = None
        self._episode: _Episode | None = None
        self.episodes_written = 0
        self.frames_written = 0

    # ----------------------------------------------------------------- dataset

    def features(self) -> dict[str, dict[str, Any]]:
        """The ``features`` of ``meta/info.json``."""
        n = len(self.names)
        h, w = self._size
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
                    "video.codec": "av1",
                    "video.pix_fmt": L.VIDEO_PIX_FMT,
                    "video.fps": self.fps,
                    "video.channels": 3,
                    "has_audio": False,
                    "video.g": L.VIDEO_GOP,
                    "video.crf": L.VIDEO_CRF,
                    "video.preset": L.VIDEO_PRESET,
                    "video.fast_decode": 0,
                    "video.video_backend": "pyav",
                    "video.extra_options": {},
                    "is_depth_map": False,
                },
            },
            **L.DEFAULT_FEATURES,
        }

    def _load(self) -> None:
        """Read the dataset to append to; refuse one recorded differently."""
        info = json.loads((self.root / L.INFO_PATH).read_text())
        mine = {"fps": self.fps, "robot_type": self.robot_type, "features": self.features()}
        for key, value in mine.items():
            if info.get(key) != value:
                raise DatasetError(
                    self.root,
                    f"--resume: the dataset's {key} is not this run's "
                    f"({_short(info.get(key))} there, {_short(value)} here): record into a "
                    "new directory",
                )
        pq = self._pq
        self._tasks = [str(t) for t in pq.read_table(self.root / L.TASKS_PATH)["task"].to_pylist()]
        for path in sorted((self.root / "meta" / "episodes").glob("*/*.parquet")):
            self._episodes.extend(pq.read_table(path).to_pylist())
        for ep in self._episodes:
            self._ep_stats.append(_stats_of_row(ep))

    # ----------------------------------------------------------------- the run

    def attach(self, bus: ServoBus, camera: Camera) -> None:
        """Sample this rig from now on: its bus's commands and clock, its camera."""
        self._bus, self._camera = bus, camera
        bus.sampler = self

    def detach(self) -> None:
        """Stop sampling the rig (an open episode is dropped)."""
        self.abandon()
        if self._bus is not None and self._bus.sampler is self:
            self._bus.sampler = None
        self._bus = self._camera = None

    @property
    def due_s(self) -> float:
        """The bus clock's time of the next frame [s] (infinite with no episode open)."""
        ep = self._episode
        return float("inf") if ep is None else ep.start_s + ep.length / self.fps

    def sample(self, bus: ServoBus) -> None:
        """Take every frame due by the bus's clock, as the run is now."""
        ep = self._episode
        if ep is None:
            return
        state = action = frame = None
        while bus.clock_s >= self.due_s - 1e-9:
            if frame is None:
                state, action = self._measure(bus)
                assert self._camera is not None
                frame = self._camera.peek()
            assert state is not None and action is not None
            ep.add(state, action, frame)

    def _measure(self, bus: ServoBus) -> tuple[np.ndarray, np.ndarray]:
        confirmed, sent = bus.state, bus.commanded
        joints = dict(bus.actual_joints) if isinstance(bus, MeasuresWorld) else None

        def vector(cmd: Any, measured: dict[str, float] | None) -> np.ndarray:
            values: dict[str, float] = {}
            if cmd is not None:
                values.update(cmd.joints)
                values.update(cmd.tool)
                values["gripper_closed"] = float(cmd.gripper_closed)
            if measured is not None:
                values.update(measured)
            return np.array([values.get(n, np.nan) for n in self.names], dtype=np.float32)

        return vector(confirmed, joints), vector(sent, None)

    def begin(self, class_name: str) -> None:
        """A pick-and-place of an object of ``class_name`` starts: open its episode.

        Per scene, the first call opens the scene's episode and later ones do nothing.
        """
        if self._episode is not None:
            if self.per == "scene":
                return
            self.abandon()
        if self._bus is None:
            raise RuntimeError("attach() the recorder to a rig before an episode")
        self._scratch.mkdir(parents=True, exist_ok=True)
        path = self._scratch / "episode.mp4"
        task = SCENE_TASK if self.per == "scene" else task_sentence(class_name)
        self._episode = _Episode(self._av, path, self.fps, self._bus.clock_s, task)
        self.sample(self._bus)

    def end(self) -> None:
        """The pick-and-place ended: write its episode (per pick)."""
        if self.per == "pick":
            self._write()

    def end_run(self) -> None:
        """The sort ended normally: write the scene's episode (per scene)."""
        if self.per == "scene":
            self._write()

    def abandon(self) -> None:
        """Drop the episode being recorded (a fault or Ctrl-C cut it short)."""
        ep, self._episode = self._episode, None
        if ep is not None:
            with contextlib.suppress(Exception):
                ep.close()
            ep.path.unlink(missing_ok=True)

    def close(self) -> None:
        """Drop an unfinished episode and the scratch folder (and DIR, if made for nothing)."""
        self.detach()
        shutil.rmtree(self._scratch, ignore_errors=True)
        if self._created and not self._episodes:
            with contextlib.suppress(OSError):  # only if still empty
                self.root.rmdir()

    # ----------------------------------------------------------------- writing

    def _write(self) -> None:
        ep, self._episode = self._episode, None
        if ep is None:
            return
        ep.close()
        if ep.length < 2:  # nothing was sent: no motion to learn from
            ep.path.unlink(missing_ok=True)
            return
        with _no_interrupt():
            self._commit(ep)
        ep.path.unlink(missing_ok=True)
        self.episodes_written += 1
        self.frames_written += ep.length

    def _commit(self, ep: _Episode) -> None:
        pa, pq = self._pa, self._pq
        root = self.root
        index = len(self._episodes)
        last = self._episodes[-1] if self._episodes else None
        first_index = int(last["dataset_to_index"]) if last else 0
        if ep.task not in self._tasks:
            self._tasks.append(ep.task)
        task_index = self._tasks.index(ep.task)
        n = ep.length
        states = np.stack(ep.states)
        actions = np.stack(ep.actions)
        moves: dict[str, Path] = {}

        def staged(rel: str) -> Path:
            final = root / rel
            final.parent.mkdir(parents=True, exist_ok=True)
            tmp = final.with_name(final.name + ".tmp")
            moves[rel] = tmp
            return tmp

        # data: appended to the last episode's file unless that has reached its limit
        chunk, file = (0, 0)
        if last:
            chunk, file = int(last["data/chunk_index"]), int(last["data/file_index"])
        data_rel = L.chunk_file(L.DATA_PATH, chunk, file)
        table = self._frames_table(states, actions, index, first_index, task_index)
        old = root / data_rel
        if last and old.exists() and _mb(old) + table.nbytes / 2**20 >= L.DATA_FILES_SIZE_IN_MB:
            chunk, file = L.next_file(chunk, file)
            data_rel = L.chunk_file(L.DATA_PATH, chunk, file)
        elif last and old.exists():
            table = pa.concat_tables([pq.read_table(old), table])
        pq.write_table(table, staged(data_rel), compression="snappy")
        data_meta = {"data/chunk_index": chunk, "data/file_index": file}

        # video: the episode's file appended to the last one's, or a new file
        key = self.video_key
        vchunk, vfile = (
            (int(last[f"videos/{key}/chunk_index"]), int(last[f"videos/{key}/file_index"]))
            if last
            else (0, 0)
        )
        video_rel = L.chunk_file(L.VIDEO_PATH, vchunk, vfile, video_key=key)
        old_video = root / video_rel
        # the frames before this episode in the file, counted (no sum of rounded seconds)
        before = round(float(last[f"videos/{key}/to_timestamp"]) * self.fps) if last else 0
        if last and _mb(old_video) + _mb(ep.path) >= L.VIDEO_FILES_SIZE_IN_MB:
            vchunk, vfile = L.next_file(vchunk, vfile)
            video_rel = L.chunk_file(L.VIDEO_PATH, vchunk, vfile, video_key=key)
            before = 0
        if before > 0:
            concatenate_videos(self._av, [old_video, ep.path], staged(video_rel))
        else:
            shutil.copyfile(ep.path, staged(video_rel))
        video_meta = {
            f"videos/{key}/chunk_index": vchunk,
            f"videos/{key}/file_index": vfile,
            f"videos/{key}/from_timestamp": before / self.fps,
            f"videos/{key}/to_timestamp": (before + n) / self.fps,
        }

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
        episodes_table = pa.Table.from_pylist(episodes)
        pq.write_table(episodes_table, staged(L.chunk_file(L.EPISODES_PATH, 0, 0)))
        pq.write_table(tasks_table(pa, self._tasks), staged(L.TASKS_PATH))
        all_stats = [*self._ep_stats, ep_stats]
        dataset_stats = {f: aggregate([s[f] for s in all_stats]) for f in ep_stats}
        staged(L.STATS_PATH).write_text(json.dumps(to_json(dataset_stats), indent=4))
        info = self._info(len(episodes), first_index + n)
        staged(L.INFO_PATH).write_text(json.dumps(info, indent=4))

        for tmp in moves.values():
            with open(tmp, "rb") as f:
                os.fsync(f.fileno())
        journal = {"replace": {rel: str(tmp.relative_to(root)) for rel, tmp in moves.items()}}
        write_atomic(root / L.JOURNAL_PATH, json.dumps(journal).encode())
        finish_journal(root)
        self._episodes = episodes
        self._ep_stats = all_stats

    def _frames_table(
        self, states: np.ndarray, actions: np.ndarray, episode: int, first: int, task: int
    ) -> Any:
        pa = self._pa
        n, width = states.shape
        vec = pa.list_(pa.float32(), width)
        return pa.table(
            {
                "observation.state": pa.FixedSizeListArray.from_arrays(
                    pa.array(states.reshape(-1), pa.float32()), width
                ).cast(vec),
                "action": pa.FixedSizeListArray.from_arrays(
                    pa.array(actions.reshape(-1), pa.float32()), width
                ).cast(vec),
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


def concatenate_videos(av: Any, inputs: list[Path], output: Path) -> None:
    """Join videos of the same encoding, packets copied (LeRobot's ``concatenate_video_files``)."""
    with tempfile.NamedTemporaryFile("w", suffix=".ffconcat", delete=False) as listing:
        listing.write("ffconcat version 1.0\n")
        for path in inputs:
            listing.write(f"file '{path.resolve()}'\n")
    try:
        with (
            av.open(listing.name, "r", format="concat", options={"safe": "0"}) as src,
            av.open(str(output), "w", format="mp4") as dst,
        ):
            stream_in = src.streams.video[0]
            stream_out = dst.add_stream_from_template(template=stream_in, opaque=True)
            stream_out.time_base = stream_in.time_base
            for packet in src.demux(stream_in):
                if packet.dts is None:
                    continue
                packet.stream = stream_out
                dst.mux(packet)
    finally:
        os.unlink(listing.name)


def _stats_of_row(row: dict[str, Any]) -> dict[str, Stats]:
    """An episode's statistics from its ``meta/episodes`` row."""
    out: dict[str, Stats] = {}
    for column, value in row.items():
        if column.startswith("stats/"):
            feature, name = column[len("stats/") :].rsplit("/", 1)
            out.setdefault(feature, {})[name] = np.asarray(value)
    return out


def _mb(path: Path) -> float:
    return path.stat().st_size / 2**20 if path.exists() else 0.0


def _short(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."
