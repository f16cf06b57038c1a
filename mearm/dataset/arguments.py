"""``--record DIR`` and its options, shared by ``mearm sort`` and ``mearm experiment``.

Light on purpose: the recorder (and pyarrow, PyAV) is imported only when ``--record`` is
given.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from mearm.cli import PLAIN_INTEGER, check_plain_number
from mearm.config import Config, SceneObject
from mearm.config.loader import apply_overrides, file_keys_set, parse_override
from mearm.data import doc_page
from mearm.dataset.lerobot_format import DEFAULT_CODEC, VIDEO_CODECS

if TYPE_CHECKING:
    from mearm.dataset.errors import DatasetWriteError
    from mearm.dataset.recorder import DatasetRecorder

#: Frames per second of a recording unless ``--record-fps`` says otherwise [Hz].
DEFAULT_FPS = 10
#: ``--record-codec``'s choices, the default first.
CODECS = (DEFAULT_CODEC, *(c for c in VIDEO_CODECS if c != DEFAULT_CODEC))
#: The highest ``--record-fps`` [Hz]: the servo streams at most at 1000 Hz.
MAX_FPS = 1000


def fps_value(text: str) -> int:
    """An argparse type: a whole number of frames per second in 1..MAX_FPS."""
    check_plain_number(text, f"must be a whole number of frames per second ({PLAIN_INTEGER})")
    try:
        fps = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be a whole number of frames per second, got {text!r}"
        ) from None
    if not 1 <= fps <= MAX_FPS:
        raise argparse.ArgumentTypeError(f"must be in 1..{MAX_FPS} frames per second, got {fps}")
    return fps


def add_record_arguments(parser: argparse.ArgumentParser) -> None:
    """``--record DIR``, ``--resume``, ``--record-fps N``, ``--record-codec``, ``--record-per``."""
    parser.add_argument(
        "--record",
        type=Path,
        metavar="DIR",
        help="record the run as a LeRobotDataset v3.0 in DIR (a new or empty directory; "
        f"needs the 'record' extra; {doc_page('datasets.md')})",
    )
    parser.add_argument(
        "--resume", action="store_true", help="with --record: append to the dataset in DIR"
    )
    parser.add_argument(
        "--record-fps",
        type=fps_value,
        default=DEFAULT_FPS,
        metavar="N",
        help=f"with --record: frames per second of the run's time (default {DEFAULT_FPS})",
    )
    parser.add_argument(
        "--record-codec",
        choices=CODECS,
        default=CODECS[0],
        help="with --record: the video's codec, both read by LeRobot: av1 (SVT-AV1, "
        "LeRobot's default) or h264 (libx264, about a fifth of AV1's CPU a frame)",
    )
    parser.add_argument(
        "--record-per",
        choices=("pick", "scene"),
        default="pick",
        help="with --record: one episode per pick-and-place (default) or per scene",
    )


def check_record_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Refuse the recording options without ``--record``, and too high a frame rate.

    A frame rate the codec's encoder does not open at was found after the arm moved.
    Each is exit 2, one line.
    """
    most = VIDEO_CODECS[args.record_codec].max_fps
    if args.record is not None and most is not None and args.record_fps > most:
        others = [c for c, v in VIDEO_CODECS.items() if v.max_fps is None]
        parser.error(
            f"--record-fps {args.record_fps}: --record-codec {args.record_codec} records at "
            f"most {most} frames per second: give {most} or fewer, or --record-codec "
            f"{' or '.join(others)}"
        )
    if args.record is None:
        given = [
            flag
            for flag, on in (
                ("--resume", args.resume),
                ("--record-fps", args.record_fps != DEFAULT_FPS),
                ("--record-per", args.record_per != "pick"),
                ("--record-codec", args.record_codec != CODECS[0]),
            )
            if on
        ]
        if given:
            parser.error(f"{given[0]} is an option of --record DIR: give --record too")


def _config_kept(given: str | Path) -> str:
    """``--config`` as a replay finds it from any folder.

    A shipped config's name stays a name; a file is kept by its absolute path.
    """
    from mearm.config.files import resolve_config_path  # noqa: PLC0415
    from mearm.data import packaged_config  # noqa: PLC0415

    path = resolve_config_path(given)
    if path == packaged_config(str(given)):
        return str(given)
    return str(path.resolve())


def _overrides_kept(overrides: Sequence[str]) -> tuple[str, ...]:
    """``--set`` values as a replay finds what they name from any folder.

    A file path one sets (``servo.calibration_file``, the camera's calibration files) is
    relative to the current folder: it is kept as the absolute path the config loader
    made of it (:func:`~mearm.config.loader.apply_overrides`); every other value as typed.
    """
    kept = []
    for text in overrides:
        if not file_keys_set([text]):
            kept.append(text)
            continue
        path, value = parse_override(text)
        resolved: object = apply_overrides({}, [text])
        for part in path:
            assert isinstance(resolved, dict)  # a file key's path walks sections only
            resolved = resolved[part]
        same = resolved == value
        kept.append(
            text if same else f"{'.'.join(path)}={json.dumps(resolved, ensure_ascii=False)}"
        )
    return tuple(kept)


def kept_config(args: argparse.Namespace) -> tuple[str | None, tuple[str, ...]]:
    """``--config`` and ``--set`` as a replay finds them from any folder (a recorded scene's)."""
    given = getattr(args, "config", None)
    config = None if given is None else _config_kept(given)
    return config, _overrides_kept(getattr(args, "set", None) or ())


def recorder_from_args(
    args: argparse.Namespace, config: Config, table: Sequence[SceneObject] | None = None
) -> DatasetRecorder | None:
    """The recorder ``--record`` asks for, its directory checked; ``None`` without it.

    A sort's ``--random N --seed S``, or its ``--scene`` table (``table``), is kept with
    each episode, with ``--config`` and ``--set``: what a replay rebuilds the scene from
    (:mod:`mearm.envs.replay`), from any folder (a file either names, by its absolute
    path). An experiment's trials keep their own tables
    (:meth:`~mearm.dataset.sampler.EpisodeSampler.start_trial`, with
    :attr:`~mearm.dataset.sampler.EpisodeSampler.kept_config`).

    Raises:
        DatasetError: the directory is a file, not writable, or not empty without
            ``--resume``, or holds another recording.
        ExtraMissingError: pyarrow or PyAV is not installed.
    """
    if args.record is None:
        return None
    from mearm.dataset.reading import RecordedScene
    from mearm.dataset.recorder import DatasetRecorder

    kept = kept_config(args)
    scene = None
    if getattr(args, "random", None) is not None:  # a sort's --random N --seed S
        scene = RecordedScene(
            seed=args.seed, objects=args.random, config=kept[0], overrides=kept[1]
        )
    elif table is not None:  # a sort's --scene FILE
        scene = RecordedScene.laid(table, *kept)
    recorder = DatasetRecorder(
        args.record,
        config,
        fps=args.record_fps,
        per=args.record_per,
        resume=args.resume,
        codec=args.record_codec,
        scene=scene,
    )
    recorder.kept_config = kept
    return recorder


def close_recorder(recorder: DatasetRecorder | None, where: object, said: str = "") -> None:
    """Close ``recorder``: its last episode is written whole or not at all.

    The command names the dataset on stdout once this returns (``wrote DIR/ (N episodes,
    F frames)``, before its summary); picks of a trial run again that the dataset held
    already are said here, on stderr.

    A recording that stopped because a file could not be written (a full disk) ends the
    command with that error (exit 1, its ``exit_status``), unless the command already
    said it (``said``: the sort it stopped, which exits 1) or another exception is on its
    way out (Ctrl-C, which still gets the failure's line).

    Raises:
        DatasetWriteError: the recording failed and nothing else is being raised.
    """
    if recorder is None:
        return
    recorder.close()
    if recorder.episodes_skipped:
        print(
            f"{recorder.episodes_skipped} "
            f"{'pick' if recorder.episodes_skipped == 1 else 'picks'} of the trial run again "
            f"{'was' if recorder.episodes_skipped == 1 else 'were'} in {where} already: not "
            "recorded twice",
            file=sys.stderr,
        )
    failure = recorder.failure  # the first write that failed, raised in the run or not
    if failure is not None and str(failure) not in said:
        _recording_failed(failure)


def _recording_failed(failure: DatasetWriteError) -> None:
    """Raise the failure, or say it on stderr when another exception is on its way out."""
    from mearm.cli import _program_name  # noqa: PLC0415  (a failed recording only)

    on_its_way = sys.exc_info()[1]  # close_recorder runs in the commands' finally blocks
    if on_its_way is None:
        raise failure
    if on_its_way is not failure:
        print(f"{_program_name()}: error: {failure}", file=sys.stderr)
