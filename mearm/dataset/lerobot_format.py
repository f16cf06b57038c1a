"""Where the files of a LeRobotDataset v3.0 go, and the features every dataset has.

The paths, the default features and the size limits are LeRobot's own
(``lerobot/datasets/utils.py``, ``lerobot/utils/constants.py``, codebase version "v3.0"):
episodes share a data file and a video file per camera until it reaches its size limit,
and a chunk folder holds up to ``chunks_size`` files.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

CODEBASE_VERSION = "v3.0"

INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
TASKS_PATH = "meta/tasks.parquet"
CHUNK_FILE = "chunk-{chunk_index:03d}/file-{file_index:03d}"
EPISODES_PATH = "meta/episodes/" + CHUNK_FILE + ".parquet"
DATA_PATH = "data/" + CHUNK_FILE + ".parquet"
VIDEO_PATH = "videos/{video_key}/" + CHUNK_FILE + ".mp4"

#: Files per chunk folder; the data file's and each video file's size limit [MB].
CHUNKS_SIZE = 1000
DATA_FILES_SIZE_IN_MB = 100
VIDEO_FILES_SIZE_IN_MB = 200

#: The columns every frame has (LeRobot's ``DEFAULT_FEATURES``).
DEFAULT_FEATURES: dict[str, dict[str, Any]] = {
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}

#: The statistics of each feature (LeRobot's ``compute_stats``): the quantiles are
#: ``q01``, ``q10``, ``q50``, ``q90`` and ``q99``.
QUANTILES = (0.01, 0.10, 0.50, 0.90, 0.99)
STAT_NAMES = ("min", "max", "mean", "std", "count") + tuple(
    f"q{round(q * 100):02d}" for q in QUANTILES
)

#: The video encoding (LeRobot's ``VideoEncoderConfig`` defaults): AV1 by SVT-AV1, 4:2:0,
#: a key frame every 2 frames (any frame decodes fast), constant quality 30.
VIDEO_CODEC = "libsvtav1"
VIDEO_PIX_FMT = "yuv420p"
VIDEO_GOP = 2
VIDEO_CRF = 30
#: SVT-AV1's speed preset, LeRobot's default (SVT-AV1 runs 12 as its fastest, 11).
VIDEO_PRESET = 12


@dataclass(frozen=True)
class VideoCodec:
    """A video encoding LeRobot reads, as ``--record-codec`` names it.

    Attributes:
        encoder: FFmpeg's encoder (PyAV's ``add_stream`` name).
        codec: The stream's codec as ``meta/info.json`` records it (``video.codec``) and
            PyAV reports it when decoding.
        preset: The encoder's speed preset (``video.preset``).
        decoders: The names PyAV may give the stream's decoder.
        max_fps: The most frames per second the encoder opens at (``None``: no limit
            below the recording's own).
    """

    encoder: str
    codec: str
    preset: int | str
    decoders: tuple[str, ...]
    max_fps: int | None = None

    def options(self) -> dict[str, str]:
        """The encoder's options, as LeRobot's ``get_codec_options`` gives them."""
        out = {"crf": str(VIDEO_CRF), "preset": str(self.preset)}
        # One thread (LeRobot's ``encoder_threads=1``): the sort has the other core, and
        # SVT-AV1 spends about a quarter more CPU a 640×480 frame on two threads than on one.
        # Screen-content tools off (``scm=0``): a camera's frames are not a screen's, and
        # SVT-AV1's default, deciding frame by frame whether they are, cost 17 % of a
        # frame's encoding for files of the same size (docs/datasets.md).
        if self.encoder == "libsvtav1":
            out["svtav1-params"] = "lp=1:scm=0"
        else:
            out["threads"] = "1"
        return out


#: The encodings ``--record-codec`` offers: AV1 (LeRobot's default, the default here) and
#: H.264 (LeRobot's ``vcodec="h264"``; libx264's fastest preset, about a fifth of
#: SVT-AV1's CPU a frame, files about a fifth larger).
VIDEO_CODECS: dict[str, VideoCodec] = {
    # SVT-AV1 refuses a frame rate above 240 ("The maximum allowed frame rate is 240 fps")
    "av1": VideoCodec(VIDEO_CODEC, "av1", VIDEO_PRESET, ("av1", "libdav1d", "libaom-av1"), 240),
    "h264": VideoCodec("libx264", "h264", "ultrafast", ("h264",)),
}
DEFAULT_CODEC = "av1"


def codec_of(video_info: dict[str, Any]) -> VideoCodec | None:
    """The encoding a video feature's ``info`` names (``video.codec``), if one of ours."""
    name = video_info.get("video.codec")
    return next((c for c in VIDEO_CODECS.values() if c.codec == name), None)


#: The prefix of a camera's feature (``observation.images.table``).
IMAGES = "observation.images."

#: A journal of an episode being written: the files it replaces (see ``writer``).
JOURNAL_PATH = "meta/.commit.json"
#: mearm's own record of each episode's trial (its seed) and pick in the trial, in
#: episode order: what a resumed experiment reads to record no pick twice. LeRobot
#: reads only the files above.
TAGS_PATH = "meta/mearm_episodes.json"
#: mearm's own record of where each episode starts (the episode of the same sort it
#: continues) and the servo calibration it ran, in episode order: what a replay needs
#: besides the scene (:mod:`mearm.envs.replay`).
STARTS_PATH = "meta/mearm_starts.json"
#: A servo calibration a sort made at its start (``servo.calibrate_at_start``), as a servo
#: calibration file, named by the first episode that ran it.
SERVOS_PATH = "meta/mearm_servos/episode-{episode_index:06d}.servos.yaml"
#: The writer's scratch folder inside the dataset (the episode's video being encoded).
SCRATCH_DIR = ".recording"


def chunk_file(path_template: str, chunk_index: int, file_index: int, **keys: str) -> str:
    """A file's path in the dataset, e.g. ``data/chunk-000/file-003.parquet``."""
    return path_template.format(chunk_index=chunk_index, file_index=file_index, **keys)


def next_file(chunk_index: int, file_index: int) -> tuple[int, int]:
    """The (chunk, file) after this one (LeRobot's ``update_chunk_file_indices``)."""
    if file_index == CHUNKS_SIZE - 1:
        return chunk_index + 1, 0
    return chunk_index, file_index + 1
