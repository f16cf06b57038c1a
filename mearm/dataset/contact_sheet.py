"""What a dataset holds (``mearm dataset show``): episodes, tasks, statistics, a picture.

The contact sheet shows frames of each episode (its first, middle and last) decoded from
its video, each captioned with the episode, the frame and its ``observation.state``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np

from mearm.cli import counted
from mearm.dataset import lerobot_format as L
from mearm.dataset.errors import DatasetError
from mearm.dataset.fragments import tear
from mearm.dataset.reading import (
    damaged,
    journal_damage,
    read_episodes,
    read_info,
    read_json,
    read_starts,
    read_table,
    read_tags,
    read_tasks,
)
from mearm.dataset.recorder import import_extra
from mearm.fileio import write_atomic

#: The width of one frame on the contact sheet [px].
THUMB_WIDTH_PX = 320


def describe(root: Path) -> list[str]:
    """The lines ``show`` prints: totals, episodes, tasks, statistics of the state.

    Raises:
        DatasetError: not a dataset (:func:`check_dataset`'s first checks), an episode
            half written (its journal there: the files disagree until a recorder
            finishes it), or a file of it is damaged (:mod:`mearm.dataset.reading`), its
            episodes' data and video files and ``meta/mearm_starts.json`` included
            (missing, cut short), as ``--resume`` refuses them.
    """
    if (root / L.JOURNAL_PATH).exists():
        wrong = journal_damage(root)
        raise DatasetError(
            root / L.JOURNAL_PATH,
            "an episode was being written when the recorder stopped: record into "
            f"{root} with --resume to finish writing it, then show it"
            if wrong is None
            else f"{wrong}: an episode was being written when the recorder stopped, and "
            f"--resume cannot finish it: the dataset is damaged; `mearm dataset check "
            f"{root}` lists what is wrong",
        )
    info, episodes, tasks = _read(root)
    _check_files(root, info, episodes)
    tags, scenes = read_tags(root, len(episodes))
    read_starts(root, len(episodes))  # not shown; a replay and --resume read it
    lines = [
        f"{root}: LeRobot {info['codebase_version']}, robot {info.get('robot_type')}, "
        f"{info['fps']} fps, {counted(info['total_episodes'], 'episode')}, "
        f"{counted(info['total_frames'], 'frame')}, {counted(info['total_tasks'], 'task')}",
        "",
        "episode  frames  seconds  task",
    ]
    for row in episodes:
        seconds = row["length"] / info["fps"]
        tasks_text = "; ".join(row["tasks"])
        k = row["episode_index"]
        line = f"{k:7d}  {row['length']:6d}  {seconds:7.1f}  {tasks_text}"
        trial, pick = tags[k] if 0 <= k < len(tags) else (None, None)
        scene = scenes[k] if 0 <= k < len(scenes) else None
        if trial is not None:  # an experiment's trial: its table is laid, not drawn
            line += f" (trial seed {trial}, pick {pick})"
        elif scene is not None and scene.table is not None:  # --scene, or the config's
            line += f" (a table of {scene.objects} objects, as laid)"
        elif scene is not None:
            line += f" (--random {scene.objects} --seed {scene.seed})"
        lines.append(line)
    lines += ["", "task_index  task"]
    lines += [f"{k:10d}  {t}" for k, t in enumerate(tasks)]
    stats = read_json(root, L.STATS_PATH)
    for key in ("observation.state", "action"):
        names = info["features"].get(key, {}).get("names") or []
        s = stats.get(key, {}) if isinstance(stats, dict) else {}
        lines += ["", f"{key}: {'name':>14}  {'min':>8}  {'mean':>8}  {'std':>8}  {'max':>8}"]
        for i, name in enumerate(names):
            try:
                values = [float(s[k][i]) for k in ("min", "mean", "std", "max")]
            except (KeyError, IndexError, TypeError, ValueError):
                raise damaged(root, L.STATS_PATH, f"lacks the statistics of {key}") from None
            lines.append(
                " " * (len(key) + 2) + f"{name:>14}  " + "  ".join(f"{v:8.2f}" for v in values)
            )
    return lines


def contact_sheet(root: Path, path: Path, *, per_episode: int = 3, max_episodes: int = 12) -> int:
    """Save frames of the first episodes with their states as one picture; how many frames.

    Raises:
        DatasetError: not a dataset, or the picture cannot be written.
    """
    _, pq, av = import_extra()
    info, episodes, _ = _read(root)
    key = next((k for k, f in info["features"].items() if f["dtype"] == "video"), None)
    if key is None:
        raise DatasetError(root, "has no camera: no frames to show")
    names = info["features"]["observation.state"]["names"]
    fps = info["fps"]
    rows = []
    shown = 0
    for row in episodes[:max_episodes]:
        n = row["length"]
        picks = sorted({0, n // 2, n - 1})[:per_episode]
        rel = L.chunk_file(
            L.VIDEO_PATH, row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"],
            video_key=key,
        )  # fmt: skip
        t0 = row[f"videos/{key}/from_timestamp"]
        frames = _frames_at(av, root, rel, [t0 + i / fps for i in picks])
        shown += len(frames)
        data = read_table(
            pq, root, L.chunk_file(L.DATA_PATH, row["data/chunk_index"], row["data/file_index"])
        )
        states = data["observation.state"].to_pylist()
        first = row["dataset_from_index"] - int(data["index"][0].as_py())
        tiles = []
        for i, frame in zip(picks, frames, strict=True):
            state = states[first + i]
            caption = [f"episode {row['episode_index']} frame {i} t={i / fps:.1f}s"]
            pairs = [f"{nm}={v:.1f}" for nm, v in zip(names, state, strict=True)]
            caption += [" ".join(pairs[j : j + 3]) for j in range(0, len(pairs), 3)]
            tiles.append(_captioned(frame, caption))
        while len(tiles) < per_episode:
            tiles.append(np.zeros_like(tiles[0]))
        rows.append(np.hstack(tiles))
    sheet = np.vstack(rows)
    ok, png = cv2.imencode(".png", sheet)
    try:
        if not ok:
            raise OSError("PNG encoding failed")
        write_atomic(path, png.tobytes())  # a full disk leaves the file there as it was
    except OSError as exc:
        raise DatasetError(path, f"cannot write the contact sheet ({exc})") from None
    return shown


def _read(root: Path) -> tuple[dict[str, Any], list[dict[str, Any]], list[str]]:
    _, pq, _ = import_extra(av_here=False)
    info = read_info(root)
    return info, read_episodes(pq, root, info), read_tasks(pq, root)


def _check_files(root: Path, info: dict[str, Any], episodes: list[dict[str, Any]]) -> None:
    """Refuse a dataset whose episodes' data or video files are missing or cut short.

    Before the report is printed: ``show`` printed the whole report of such a dataset
    and then refused it (a data file cut short), or drew the sheet and exited 0 (the
    last video's fragment cut short, which ``--resume`` refuses). Each data file's
    footer and each video file's boxes are read, not their frames.

    Raises:
        DatasetError: a file is missing or cut short.
    """
    _, pq, _ = import_extra(av_here=False)
    keys = [k for k, f in info["features"].items() if f.get("dtype") == "video"]
    data: set[str] = set()
    videos: set[str] = set()
    try:
        for row in episodes:
            data.add(L.chunk_file(L.DATA_PATH, row["data/chunk_index"], row["data/file_index"]))
            for key in keys:
                chunk, file = row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"]
                videos.add(L.chunk_file(L.VIDEO_PATH, chunk, file, video_key=key))
    except (KeyError, TypeError, ValueError) as exc:
        raise damaged(
            root, L.chunk_file(L.EPISODES_PATH, 0, 0), f"an episode's row lacks {exc}"
        ) from None
    for rel in sorted(data):
        read_table(pq, root, rel, ["index"], only=True)
    for rel in sorted(videos):
        problem = tear(root / rel)
        if problem is not None:
            raise damaged(root, rel, problem)


def _frames_at(av: Any, root: Path, rel: str, times_s: list[float]) -> list[np.ndarray]:
    """The frames of the video ``root / rel`` at these times [s] (BGR), decoded in one pass."""
    out: dict[int, np.ndarray] = {}
    try:
        with av.open(str(root / rel)) as container:
            stream = container.streams.video[0]
            for frame in container.decode(stream):
                t = float(frame.pts * frame.time_base)
                for j, want in enumerate(times_s):
                    if j not in out and abs(t - want) < 1e-3:
                        out[j] = frame.to_ndarray(format="bgr24")
                if len(out) == len(times_s):
                    break
    except (OSError, ValueError, IndexError) as exc:  # PyAV's errors are one or the other
        raise damaged(root, rel, f"cannot be decoded ({type(exc).__name__})") from None
    if len(out) != len(times_s):
        raise damaged(root, rel, "lacks frames its episodes point to")
    return [out[j] for j in range(len(times_s))]


def _captioned(frame: np.ndarray, lines: list[str]) -> np.ndarray:
    h, w = frame.shape[:2]
    thumb = cv2.resize(frame, (THUMB_WIDTH_PX, round(h * THUMB_WIDTH_PX / w)))
    band = np.full((16 * len(lines) + 6, THUMB_WIDTH_PX, 3), 255, np.uint8)
    for i, text in enumerate(lines):
        cv2.putText(band, text, (4, 16 * (i + 1)), cv2.FONT_HERSHEY_PLAIN, 0.8, (0, 0, 0), 1)
    return np.vstack([thumb, band])
