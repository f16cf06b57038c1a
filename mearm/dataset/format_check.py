"""Check a directory against the LeRobotDataset v3.0 format (``mearm dataset check``).

Every rule in :data:`RULES` is checked and each broken one reported with the file and
the episode at fault. The rules are LeRobot's (``lerobot/datasets/``): the files it reads,
the columns and types it casts them to, and the relations between the metadata, the
frames and the videos that its reader relies on (a frame's video time is its episode's
``from_timestamp`` plus its ``timestamp``, matched within ``1e-4`` s).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path, PurePosixPath
from typing import Any, TypeVar

import numpy as np

from mearm.dataset import lerobot_format as L
from mearm.dataset.errors import DatasetError
from mearm.dataset.fragments import tear
from mearm.dataset.reading import (
    EpisodeStart,
    RecordedScene,
    Tag,
    journal_damage,
    read_starts,
    read_tags,
)
from mearm.dataset.recorder import import_extra

#: What a reader of mearm's own files returns.
T = TypeVar("T")

#: The folder of the servo calibrations sorts made at their start (``meta/mearm_servos``).
SERVOS_DIR = str(PurePosixPath(L.SERVOS_PATH).parent)

#: LeRobot's tolerance between a frame's timestamp and its video frame's time [s].
TOLERANCE_S = 1e-4

#: Each rule ``check`` applies, by name (docs/datasets.md lists them).
RULES: dict[str, str] = {
    "journal": f"no episode is half written ({L.JOURNAL_PATH} is absent)",
    "info": f'{L.INFO_PATH} is JSON with codebase_version "{L.CODEBASE_VERSION}", fps ≥ 1, '
    "the totals, chunks_size, the size limits, data_path and video_path as LeRobot's, "
    'splits {"train": "0:<total_episodes>"}',
    "features": "every feature has a dtype, a shape and names; the frame columns "
    "timestamp, frame_index, episode_index, index and task_index are LeRobot's; a video "
    "feature has its video.* info",
    "tasks": f"{L.TASKS_PATH} has task_index 0..total_tasks-1 and distinct tasks",
    "episodes": "meta/episodes/chunk-*/file-*.parquet has episode_index 0..total_episodes-1 "
    "in order, each with a length ≥ 1, frame ranges that follow each other from 0, tasks "
    "that tasks.parquet holds, and its data and video files (a video file's boxes fill "
    "it: not cut short); the lengths add up to total_frames",
    "data": "each data file has a column per non-video feature of its dtype and shape, "
    "and exactly the rows of its episodes, in order: episode_index, frame_index "
    "0..length-1, index from dataset_from_index, timestamp = frame_index / fps, a "
    "task_index of the episode's tasks, each float feature (the state, the action) finite: "
    "no NaN nor inf but NaN in a frame 0 whose action is all NaN (taken before the bus's "
    "first command) (a torn last episode breaks this)",
    "videos": "each video file is of the feature's codec (AV1 or H.264), yuv420p, of its "
    "size, and each episode's "
    "span [from_timestamp, to_timestamp) holds exactly its frames, at its timestamps",
    "stats": f"{L.STATS_PATH} has min, max, mean, std, count and the quantiles for every "
    "feature, shaped as the feature ((3, 1, 1) for a camera), count = total_frames",
    "mearm": f"{L.TAGS_PATH} (mearm's own), if there (and it must be, beside "
    f'{L.STARTS_PATH}: mearm keeps both), is JSON {{"episodes": [...]}} '
    "with one entry per episode: [trial seed, pick], each null or a whole number, and "
    f"optionally the scene a replay rebuilds; {L.STARTS_PATH}, if there, too: each "
    "episode's start (not known, optionally with why in a sentence, the reset's, or after "
    "an earlier episode of its sort: the pick before it in its trial, of the same scene "
    "and servos) and optionally the "
    "servo calibration its sort ran, a file of the dataset's arm that is there; every "
    f"file in {SERVOS_DIR}/ is one an episode names",
}


def check_dataset(root: Path, *, videos: bool = True) -> list[str]:
    """The broken rules of the dataset in ``root``: one line each, ``rule: what``.

    Args:
        root: The dataset's directory.
        videos: Decode the videos (rule ``videos``); off, the rule is skipped.

    Raises:
        DatasetError: ``root`` is not a directory, or holds no ``meta/info.json``.
    """
    root = Path(root)
    if not root.is_dir():
        what = "is a file" if root.exists() else "does not exist"
        raise DatasetError(root, f"{what}: give a dataset directory")
    if not (root / L.INFO_PATH).is_file():
        raise DatasetError(root, f"holds no {L.INFO_PATH}: not a LeRobot dataset")
    return _Checker(root, videos=videos).run()


def refuse_damaged(root: Path, problems: list[str] | None = None) -> None:
    """Refuse a dataset that breaks a rule of the format (its videos not decoded).

    ``mearm dataset show`` and the replay read a dataset as the recorder wrote it: a torn
    episode, an action that is not finite or totals that disagree would be drawn,
    replayed or counted wrong, or crash them halfway.

    Args:
        root: The dataset's directory.
        problems: :func:`check_dataset`'s broken rules, if found already.

    Raises:
        DatasetError: a rule is broken (the first named, and how many more), or ``root``
            is not a dataset.
    """
    if problems is None:
        problems = check_dataset(root, videos=False)
    if problems:
        first = " ".join(problems[0].split())  # one line, whatever a library's words were
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise DatasetError(
            root,
            f"{first}{more}: the dataset is damaged; `mearm dataset check {root}` lists "
            "what is wrong",
        )


class _Checker:
    def __init__(self, root: Path, *, videos: bool):
        self.root = root
        self.videos = videos
        self.problems: list[str] = []
        self.seen: set[str] = set()  # files the episodes name, looked at (each said once)
        self.pa, self.pq, self.av = import_extra(av_here=videos)  # (a replay decodes none)

    def fail(self, rule: str, message: str) -> None:
        self.problems.append(f"{rule}: {message}")

    def run(self) -> list[str]:
        if (self.root / L.JOURNAL_PATH).exists():
            wrong = journal_damage(self.root)
            self.fail(
                "journal",
                f"{L.JOURNAL_PATH} is there: an episode was being written when the "
                "recorder stopped (record with --resume to finish writing it)"
                if wrong is None
                else f"{L.JOURNAL_PATH} is there and damaged ({wrong}): an episode was being "
                "written when the recorder stopped, and --resume cannot finish it; the "
                "dataset's files may disagree",
            )
        info = self._info()
        if info is None:
            return self.problems
        tasks = self._tasks(info)
        episodes = self._episodes(info, tasks)
        if episodes is not None:
            self._data(info, episodes, tasks)
            if self.videos:
                self._videos(info, episodes)
        self._stats(info)
        self._mearm(info)
        return self.problems

    # ----------------------------------------------------------------- meta

    def _info(self) -> dict[str, Any] | None:  # noqa: C901, PLR0912 (one check per field of info.json, in its order)
        try:
            info = json.loads((self.root / L.INFO_PATH).read_text())
        except (OSError, ValueError) as exc:
            self.fail("info", f"{L.INFO_PATH} cannot be read as JSON ({exc})")
            return None
        if not isinstance(info, dict):
            self.fail("info", f"{L.INFO_PATH} is not a JSON object")
            return None
        expected = {
            "codebase_version": L.CODEBASE_VERSION,
            "data_path": L.DATA_PATH,
            "video_path": L.VIDEO_PATH,
        }
        for key, value in expected.items():
            if info.get(key) != value:
                self.fail("info", f"{key} is {info.get(key)!r}, LeRobot v3.0 has {value!r}")
        least = {"fps": 1}  # (the rest may be 0: a dataset of no episode yet)
        for key in ("fps", "total_episodes", "total_frames", "total_tasks", "chunks_size"):
            number, low = info.get(key), least.get(key, 0)
            if not isinstance(number, int) or isinstance(number, bool) or number < low:
                self.fail("info", f"{key} is {number!r}: a whole number ≥ {low} is needed")
                return None
        for key in ("data_files_size_in_mb", "video_files_size_in_mb"):
            if not isinstance(info.get(key), int | float) or info[key] <= 0:
                self.fail("info", f"{key} is {info.get(key)!r}: a size > 0 [MB] is needed")
        split = f"0:{info['total_episodes']}"
        if info.get("splits") != {"train": split}:
            self.fail("info", f'splits is {info.get("splits")!r}, not {{"train": "{split}"}}')
        features = info.get("features")
        if not isinstance(features, dict):
            self.fail("features", "info.json has no features object")
            return None
        for key, ft in features.items():
            if not isinstance(ft, dict) or not {"dtype", "shape", "names"} <= set(ft):
                self.fail("features", f"{key} lacks a dtype, shape or names")
                return None
            shape = ft["shape"]
            if not isinstance(shape, list) or not all(isinstance(s, int) for s in shape):
                self.fail("features", f"{key}: shape {shape!r} is not a list of whole numbers")
                return None
            if ft["dtype"] == "video":
                vinfo = ft.get("info") or {}
                missing = [
                    k for k in ("video.codec", "video.pix_fmt", "video.fps") if k not in vinfo
                ]
                if missing:
                    self.fail("features", f"{key}: its info lacks {', '.join(missing)}")
        for key, ft in L.DEFAULT_FEATURES.items():
            got = features.get(key)
            if got is None or got.get("dtype") != ft["dtype"] or got.get("shape") != ft["shape"]:
                self.fail("features", f"{key} is {got!r}, LeRobot has {ft!r}")
        return info

    def _tasks(self, info: dict[str, Any]) -> list[str]:
        path = self.root / L.TASKS_PATH
        try:
            table = self.pq.read_table(path)
            tasks = [str(t) for t in table["task"].to_pylist()]
            indices = table["task_index"].to_pylist()
        except Exception as exc:  # noqa: BLE001  (any unreadable file is one finding)
            self.fail("tasks", f"{L.TASKS_PATH} cannot be read with task and task_index ({exc})")
            return []
        if indices != list(range(len(tasks))):
            self.fail("tasks", f"task_index is {indices[:5]}..., not 0..{len(tasks) - 1}")
        if len(set(tasks)) != len(tasks):
            self.fail("tasks", "a task is listed twice")
        if len(tasks) != info["total_tasks"]:
            self.fail("tasks", f"{len(tasks)} tasks, info.json says {info['total_tasks']}")
        return tasks

    def _episodes(self, info: dict[str, Any], tasks: list[str]) -> list[dict[str, Any]] | None:
        paths = sorted((self.root / "meta" / "episodes").glob("chunk-*/file-*.parquet"))
        if not paths and info["total_episodes"]:
            self.fail("episodes", "meta/episodes holds no chunk-*/file-*.parquet")
            return None
        rows: list[dict[str, Any]] = []
        for path in paths:
            try:
                rows.extend(self.pq.read_table(path).to_pylist())
            except Exception as exc:  # noqa: BLE001
                self.fail("episodes", f"{path.relative_to(self.root)} cannot be read ({exc})")
                return None
        if len(rows) != info["total_episodes"]:
            self.fail("episodes", f"{len(rows)} episodes, info.json says {info['total_episodes']}")
        video_keys = [k for k, f in info["features"].items() if f["dtype"] == "video"]
        needed = ["episode_index", "tasks", "length", "data/chunk_index", "data/file_index"]
        needed += ["dataset_from_index", "dataset_to_index"]
        for key in video_keys:
            needed += [f"videos/{key}/{c}" for c in ("chunk_index", "file_index")]
            needed += [f"videos/{key}/{c}" for c in ("from_timestamp", "to_timestamp")]
        frames = 0
        for k, row in enumerate(rows):
            missing = [c for c in needed if row.get(c) is None]
            if missing:
                self.fail("episodes", f"episode {k} lacks {', '.join(missing)}")
                return None
            if row["episode_index"] != k:
                self.fail("episodes", f"row {k} has episode_index {row['episode_index']}")
            if row["length"] < 1:
                self.fail("episodes", f"episode {k} has length {row['length']}")
            if row["dataset_from_index"] != frames:
                self.fail(
                    "episodes",
                    f"episode {k} starts at index {row['dataset_from_index']}, not {frames} "
                    "(where the episode before it ends)",
                )
            if row["dataset_to_index"] - row["dataset_from_index"] != row["length"]:
                self.fail("episodes", f"episode {k}: its index range is not its length")
            frames = row["dataset_to_index"]
            for task in row["tasks"]:
                if task not in tasks:
                    self.fail("episodes", f"episode {k}: task {task!r} is not in tasks.parquet")
            self._files_present(k, row, video_keys)
        if frames != info["total_frames"]:
            self.fail("episodes", f"the episodes hold {frames} frames, info.json says "
                      f"{info['total_frames']}")  # fmt: skip
        return rows

    def _files_present(self, k: int, row: dict[str, Any], video_keys: list[str]) -> None:
        """Episode ``k``'s data and video files are there (with or without --no-videos).

        Each video file's boxes are walked to its end too (no frame decoded): with
        --no-videos a file cut short (a kill mid-append) passed, which ``--resume`` and
        ``show`` refuse as damaged.
        """
        files = [L.chunk_file(L.DATA_PATH, row["data/chunk_index"], row["data/file_index"])]
        files += [
            L.chunk_file(
                L.VIDEO_PATH,
                row[f"videos/{key}/chunk_index"],
                row[f"videos/{key}/file_index"],
                video_key=key,
            )
            for key in video_keys
        ]
        for rel in files:
            if rel in self.seen:
                continue
            self.seen.add(rel)
            if not (self.root / rel).is_file():
                self.fail("episodes", f"episode {k}: its file {rel} is missing")
            elif rel.endswith(".mp4") and (problem := tear(self.root / rel)) is not None:
                self.fail("episodes", f"episode {k}: its file {rel} is {problem}")

    # ----------------------------------------------------------------- frames

    def _data(self, info: dict[str, Any], episodes: list[dict[str, Any]], tasks: list[str]) -> None:
        features = {k: f for k, f in info["features"].items() if f["dtype"] != "video"}
        files: dict[tuple[int, int], list[dict[str, Any]]] = {}
        for row in episodes:
            files.setdefault((row["data/chunk_index"], row["data/file_index"]), []).append(row)
        on_disk = set(sorted((self.root / "data").glob("chunk-*/file-*.parquet")))
        fps = info["fps"]
        for (chunk, file), rows in files.items():
            rel = L.chunk_file(L.DATA_PATH, chunk, file)
            path = self.root / rel
            on_disk.discard(path)
            if not path.is_file():  # the episodes rule has said so
                continue
            try:
                table = self.pq.read_table(path)
            except Exception as exc:  # noqa: BLE001
                self.fail("data", f"{rel} cannot be read ({exc})")
                continue
            if not self._columns(rel, table, features):
                continue
            cols = {c: np.asarray(table[c].to_numpy()) for c in L.DEFAULT_FEATURES}
            vectors = self._float_vectors(rel, table, features)
            at = 0
            for row in rows:
                k, n = row["episode_index"], row["length"]
                part = {c: v[at : at + n] for c, v in cols.items()}
                if len(part["index"]) < n:
                    self.fail(
                        "data",
                        f"episode {k} is torn: {rel} holds {len(part['index'])} of its {n} frames",
                    )
                    break
                start = row["dataset_from_index"]
                allowed = [tasks.index(t) for t in row["tasks"] if t in tasks]
                checks = {
                    "episode_index": np.all(part["episode_index"] == k),
                    "frame_index": np.array_equal(part["frame_index"], np.arange(n)),
                    "index": np.array_equal(part["index"], np.arange(start, start + n)),
                    "timestamp": np.allclose(
                        part["timestamp"], np.arange(n) / fps, rtol=0, atol=TOLERANCE_S
                    ),
                    "task_index": np.all(np.isin(part["task_index"], allowed)),
                }
                bad = [c for c, ok in checks.items() if not ok]
                if bad:
                    self.fail("data", f"episode {k} in {rel}: wrong {', '.join(bad)}")
                # frame 0 taken before the bus's first command: its action is all NaN
                action = vectors.get("action")
                unsent = n > 0 and action is not None and bool(np.isnan(action[at]).all())
                for key, values in vectors.items():
                    finite = np.isfinite(values[at : at + n]).all(axis=1)
                    if unsent:  # what the command sets is not known yet (NaN), none is inf
                        finite[0] = not np.isinf(values[at]).any()
                    frames = np.flatnonzero(~finite)
                    if len(frames):
                        more = f" (and {len(frames) - 1} more)" if len(frames) > 1 else ""
                        self.fail(
                            "data",
                            f"episode {k} in {rel}: {key} is not finite (NaN or inf) at frame "
                            f"{frames[0]}{more}",
                        )
                at += n
            else:
                if at != table.num_rows:
                    self.fail(
                        "data",
                        f"{rel} holds {table.num_rows - at} rows after its last episode "
                        f"({rows[-1]['episode_index']}): an episode torn off while written",
                    )
        for path in sorted(on_disk):
            self.fail("data", f"{path.relative_to(self.root)} belongs to no episode")

    def _float_vectors(
        self, rel: str, table: Any, features: dict[str, dict[str, Any]]
    ) -> dict[str, np.ndarray]:
        """Each float feature's column but LeRobot's own (the state, the action), (rows, n).

        A value that is not finite is no state nor action: a replay cannot step it, and
        training on it spoils a policy (each is checked per episode). The recorder writes
        NaN in one frame only: an episode's frame 0 taken as it opened before the bus's
        first command, its action all NaN and the state's values a command sets too
        (no replay steps a frame 0). A column with a null row is said here, and not
        checked further.
        """
        out = {}
        for key, ft in features.items():
            if key in L.DEFAULT_FEATURES or not str(ft["dtype"]).startswith("float"):
                continue
            column = table[key]
            if column.null_count:
                self.fail("data", f"{rel}: column {key} has {column.null_count} null rows")
                continue
            if ft["shape"] != [1]:
                column = column.combine_chunks().flatten()
            values = np.asarray(column.to_numpy(zero_copy_only=False), np.float64)
            out[key] = values.reshape(table.num_rows, -1)
        return out

    def _columns(self, rel: str, table: Any, features: dict[str, dict[str, Any]]) -> bool:
        pa = self.pa
        ok = True
        for key, ft in features.items():
            if key not in table.column_names:
                self.fail("data", f"{rel} has no column {key}")
                ok = False
                continue
            typ = table.schema.field(key).type
            shape = ft["shape"]
            if shape == [1]:
                want = pa.type_for_alias(ft["dtype"])
            else:
                want = pa.list_(pa.type_for_alias(ft["dtype"]), shape[0])
            if typ != want:
                self.fail("data", f"{rel}: column {key} is {typ}, the feature says {want}")
                ok = False
        return ok

    def _videos(self, info: dict[str, Any], episodes: list[dict[str, Any]]) -> None:
        fps = info["fps"]
        for key, ft in info["features"].items():
            if ft["dtype"] != "video":
                continue
            files: dict[tuple[int, int], list[dict[str, Any]]] = {}
            for row in episodes:
                where = (row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"])
                files.setdefault(where, []).append(row)
            for (chunk, file), rows in files.items():
                rel = L.chunk_file(L.VIDEO_PATH, chunk, file, video_key=key)
                times = self._frame_times(rel, ft)
                if times is None:
                    continue
                for row in rows:
                    k = row["episode_index"]
                    t0 = row[f"videos/{key}/from_timestamp"]
                    t1 = row[f"videos/{key}/to_timestamp"]
                    span = times[(times >= t0 - TOLERANCE_S) & (times < t1 - TOLERANCE_S)]
                    want = t0 + np.arange(row["length"]) / fps
                    if len(span) != row["length"]:
                        self.fail(
                            "videos",
                            f"episode {k}: {rel} holds {len(span)} frames in "
                            f"[{t0:.3f}, {t1:.3f}) s, the episode has {row['length']}",
                        )
                    elif not np.allclose(span, want, rtol=0, atol=TOLERANCE_S):
                        self.fail(
                            "videos", f"episode {k}: {rel}: frame times are not its timestamps"
                        )

    def _frame_times(self, rel: str, ft: dict[str, Any]) -> np.ndarray | None:
        path = self.root / rel
        if not path.is_file():  # the episodes rule has said so
            return None
        try:
            with self.av.open(str(path)) as container:
                stream = container.streams.video[0]
                h, w = ft["shape"][0], ft["shape"][1]
                spec = L.codec_of(ft.get("info", {}))
                name = stream.codec_context.name
                if spec is None or name not in spec.decoders:
                    want = ft.get("info", {}).get("video.codec")
                    self.fail("videos", f"{rel} is {name}, the feature says {want}")
                if stream.pix_fmt != L.VIDEO_PIX_FMT or (stream.height, stream.width) != (h, w):
                    self.fail(
                        "videos",
                        f"{rel} is {stream.width}x{stream.height} {stream.pix_fmt}, the "
                        f"feature says {w}x{h} {L.VIDEO_PIX_FMT}",
                    )
                times = [float(f.pts * f.time_base) for f in container.decode(stream)]
        except Exception as exc:  # noqa: BLE001  (a video PyAV cannot decode is one finding)
            self.fail("videos", f"{rel} cannot be decoded ({exc})")
            return None
        return np.array(sorted(times))

    # ----------------------------------------------------------------- stats

    def _stats(self, info: dict[str, Any]) -> None:
        try:
            stats = json.loads((self.root / L.STATS_PATH).read_text())
        except (OSError, ValueError) as exc:
            self.fail("stats", f"{L.STATS_PATH} cannot be read as JSON ({exc})")
            return
        for key, ft in info["features"].items():
            s = stats.get(key)
            if s is None:
                self.fail("stats", f"no statistics of {key}")
                continue
            missing = [n for n in L.STAT_NAMES if n not in s]
            if missing:
                self.fail("stats", f"{key} lacks {', '.join(missing)}")
                continue
            want = (3, 1, 1) if ft["dtype"] == "video" else tuple(ft["shape"])
            for name in L.STAT_NAMES:
                shape = np.shape(s[name])
                if name == "count":
                    if shape != (1,) or s[name][0] != info["total_frames"]:
                        total = info["total_frames"]
                        self.fail(
                            "stats", f"{key} count is {s[name]}, not [{total}] (total_frames)"
                        )
                elif shape != want:
                    self.fail("stats", f"{key} {name} is shaped {shape}, not {want}")

    # ----------------------------------------------------------------- mearm's own

    def _mearm(self, info: dict[str, Any]) -> None:
        """The files of mearm's own: the tags, the starts and the servo calibrations named.

        What a replay and ``--resume`` read: a fault here is one they refuse (a damaged
        file) or one that replays an episode from the wrong start or with the wrong
        servos (files that disagree with each other).
        """
        total = info["total_episodes"]
        tags = self._read_mearm(lambda: read_tags(self.root, total))
        starts = self._read_mearm(lambda: read_starts(self.root, total))
        if starts is None:  # which servo files it names is not known
            return
        named = self._servo_files(info, starts)
        folder = self.root / SERVOS_DIR
        kept = sorted(folder.iterdir()) if folder.is_dir() else []
        for path in kept:
            rel = str(path.relative_to(self.root))
            if path.is_file() and not path.name.endswith(".tmp") and rel not in named:
                self.fail("mearm", f"{rel} belongs to no episode (no entry of "
                          f"{L.STARTS_PATH} names it)")  # fmt: skip
        if tags is not None:
            self._continued(starts, *tags)

    def _read_mearm(self, read: Callable[[], T]) -> T | None:
        """What ``read`` reads of mearm's files; ``None``, the fault said, if it cannot."""
        try:
            return read()
        except DatasetError as exc:
            what = str(exc).split(": the dataset is damaged")[0]
            self.fail("mearm", what.removeprefix(f"{self.root}/"))
            return None

    def _servo_files(self, info: dict[str, Any], starts: list[EpisodeStart]) -> set[str]:
        """Check each servo calibration file an episode names; the files named."""
        from mearm.config.errors import ServoCalibrationError  # noqa: PLC0415
        from mearm.config.servo_file import load_servo_calibration  # noqa: PLC0415

        named: dict[str, int] = {}  # each file, by the first episode that names it
        for k, start in enumerate(starts):
            if start.servos is not None:
                named.setdefault(start.servos, k)
        robot = info.get("robot_type")
        for rel, k in named.items():
            path = self.root / rel
            if not path.is_file():
                self.fail("mearm", f"episode {k}: its servo calibration {rel} is missing")
                continue
            try:
                cal = load_servo_calibration(path)
            except ServoCalibrationError as exc:
                self.fail("mearm", f"episode {k}: {str(exc).replace(f'{self.root}/', '')}")
                continue
            if isinstance(robot, str) and cal.arm != robot:
                self.fail(
                    "mearm",
                    f"episode {k}: {rel} is a servo calibration of the arm {cal.arm!r}, the "
                    f"dataset's robot_type is {robot!r}",
                )
        return set(named)

    def _continued(
        self, starts: list[EpisodeStart], tags: list[Tag], scenes: list[RecordedScene | None]
    ) -> None:
        """Each episode continues one of its own sort: the pick before it, its scene, servos.

        A sort's picks are recorded in a row, each tagged with its trial's seed and its
        number in the trial (``[null, null]`` outside an experiment), each with the sort's
        scene and servo calibration; a trial's pick after its first never starts at the
        reset.
        """
        for k, start in enumerate(starts):
            seed, pick = tags[k]
            before = start.after
            if before is None:
                if start.known and pick not in (None, 0):
                    self.fail(
                        "mearm",
                        f"{L.STARTS_PATH}: episode {k}, pick {pick} of its trial, starts where "
                        "the reset leaves the arm, not after the pick before it",
                    )
                continue
            was = (seed, None if pick is None else pick - 1)
            if tags[before] != was:
                self.fail(
                    "mearm",
                    f"{L.STARTS_PATH}: episode {k} continues episode {before}, but "
                    f"{L.TAGS_PATH} tags them {list(tags[k])} and {list(tags[before])}: not "
                    "one sort's picks in a row",
                )
            if scenes[before] != scenes[k]:
                self.fail(
                    "mearm",
                    f"{L.STARTS_PATH}: episode {k} continues episode {before}, which sorts "
                    f"another scene ({L.TAGS_PATH})",
                )
            if starts[before].servos != start.servos:
                self.fail(
                    "mearm",
                    f"{L.STARTS_PATH}: episode {k} continues episode {before}, which ran "
                    f"other servos ({_servos(starts[before])}, not {_servos(start)})",
                )


def _servos(start: EpisodeStart) -> str:
    """The servo calibration an episode ran, for a message."""
    return start.servos or "the config's own"
