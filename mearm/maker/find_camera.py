"""``mearm find-camera``: which cameras are there, and what does each one see?

Tries every camera OpenCV can open — the ``/dev/video*`` devices on Linux and the
indices 0 to ``--indices`` − 1 — reads one frame from each (within
``camera.open_timeout_s`` of the config), prints its resolution and saves the frame as
``camera<N>.png`` in ``--out`` (default ``camera_snapshots``), so you can tell the cameras
apart and put the right one in your config (``camera.kind: device`` with
``camera.device_index`` or ``camera.path``). Each snapshot is named on stdout once in
place (``wrote PATH``). On a second run (the maker's path takes its snapshot of the
markers on the table that way), a snapshot already there is kept as ``PATH.bak`` first
(``wrote PATH.bak (the old PATH)``): the frame a calibration was fitted on is not lost
to the next look. ::

    mearm find-camera
    mearm find-camera --out snapshots --camera /dev/v4l/by-id/usb-046d_C310-video-index0

``--camera SOURCE`` (repeatable) tries only the sources given: an index, a device path or
a stream URL.

Exit status: 0 when at least one camera gave a frame; 1 when none did (the command could
not do its job: there is no snapshot to look at; one line ``mearm find-camera: error: no
cameras found …``, as every command's failure) or a snapshot could not be written after
all (a full disk: the file is not left half-written, nor a folder the run made for
nothing); 2 on bad input (a ``--out`` that cannot be written included, refused before
any camera is opened); 130 on Ctrl-C.
"""

from __future__ import annotations

import glob
import re
import tempfile
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    backup_written,
    check_output_folder,
    config_from_args,
    existing_ancestor,
    plain_int,
    run,
)
from mearm.errors import MearmError

#: Default number of indices tried besides the ``/dev/video*`` devices.
DEFAULT_INDICES = 2
#: Most indices tried (each failed index costs a backend probe).
MAX_INDICES = 16


class SnapshotWriteError(MearmError):
    """A snapshot could not be written once ``--out`` had passed its check (a full disk).

    Not bad input: ``--out`` was checked before any camera was opened
    (:func:`check_snapshot_folder`), so the run itself failed.
    """

    exit_status = EXIT_FAILURE


class NoCameraFound(MearmError):
    """No source gave a frame: the run could not do its job (exit 1), though its input was fine.

    Raised, not printed, so the line is the one every command ends a failure with
    (``mearm find-camera: error: …``, :func:`mearm.cli.run`).
    """

    exit_status = EXIT_FAILURE


@dataclass(frozen=True)
class CameraReport:
    """What one camera source gave.

    Attributes:
        source: The index or path tried.
        ok: Whether a frame was read.
        detail: ``W x H px`` and the snapshot's path, or why no frame came.
        size_px: (width, height) of the frame [px], when one came.
        snapshot: Where the frame was saved, when it was.
        kept_old: Where a snapshot already there was kept before it was replaced
            (``snapshot``'s ``.bak``, or ``.bak.N`` beside an earlier one), or ``None``.
    """

    source: int | str
    ok: bool
    detail: str
    size_px: tuple[int, int] | None = None
    snapshot: Path | None = None
    kept_old: Path | None = None


def video_devices() -> list[str]:
    """The ``/dev/video<N>`` devices (Linux), in number order."""
    paths = [p for p in glob.glob("/dev/video*") if re.fullmatch(r"/dev/video\d+", p)]
    return sorted(paths, key=lambda p: int(p.removeprefix("/dev/video")))


def candidate_sources(indices: int) -> list[int | str]:
    """Indices 0..``indices`` − 1, then each ``/dev/videoN`` whose N is not among them.

    On Linux index N is ``/dev/videoN`` (OpenCV's V4L2 backend), so a device is tried once.
    """
    sources: list[int | str] = list(range(indices))
    for path in video_devices():
        if int(path.removeprefix("/dev/video")) >= indices:
            sources.append(path)
    return sources


def grab_frame(source: int | str, timeout_s: float) -> tuple[Any, str]:
    """One BGR frame from ``source`` (an index, a path or a URL), or (None, the reason).

    Opening and reading run in a thread: a camera that hangs is abandoned after
    ``timeout_s``.
    """
    import cv2

    from mearm.vision.image import quiet_opencv

    box: dict[str, Any] = {}

    def work() -> None:
        with quiet_opencv():
            cap = cv2.VideoCapture(source)
            try:
                box["opened"] = cap.isOpened()
                if box["opened"]:
                    ok, frame = cap.read()
                    box["frame"] = frame if ok and frame is not None else None
            finally:
                cap.release()

    thread = threading.Thread(target=work, name=f"camera {source}", daemon=True)
    thread.start()
    thread.join(timeout_s)
    if thread.is_alive():
        return None, f"no frame within {timeout_s:g} s (camera.open_timeout_s)"
    if not box.get("opened"):
        return None, "cannot open it (absent, not a capture device, or held by another program)"
    if box.get("frame") is None:
        return None, "opened, but gave no frame (a metadata node, or held by another program)"
    return box["frame"], ""


def snapshot_name(source: int | str) -> str:
    """``camera0.png`` for index 0, ``camera-dev-video3.png`` for ``/dev/video3``."""
    if isinstance(source, int):
        return f"camera{source}.png"
    slug = re.sub(r"[^A-Za-z0-9]+", "-", source).strip("-")[:60] or "source"
    return f"camera-{slug}.png"


def probe_camera(source: int | str, timeout_s: float, out_dir: Path) -> CameraReport:
    """Read a frame from ``source`` and save it in ``out_dir`` (made if missing).

    A snapshot of an earlier run at that name is kept as its ``.bak`` first: it may be the
    frame the camera's calibration was fitted on.

    Raises:
        MearmError: the snapshot (or the old one's backup) cannot be written; the old
            snapshot is then as it was.
    """
    import cv2

    from mearm.fileio import keep_backup, write_atomic

    frame, why = grab_frame(source, timeout_s)
    if frame is None:
        return CameraReport(source, ok=False, detail=why)
    h, w = frame.shape[:2]
    ok, png = cv2.imencode(".png", frame)
    if not ok:
        return CameraReport(source, ok=False, detail=f"{w}x{h} px, but the frame cannot be encoded")
    path = out_dir / snapshot_name(source)
    try:
        kept_old = keep_backup(path, png.tobytes())
        out_dir.mkdir(parents=True, exist_ok=True)
        write_atomic(path, png.tobytes())  # whole or not at all: no temporary file is left
    except OSError as exc:
        # strerror: the reason, not the temporary file's name the error carries
        raise SnapshotWriteError(
            f"cannot write the snapshot {path}: {exc.strerror or exc}"
        ) from None
    return CameraReport(
        source,
        ok=True,
        detail=f"{w}x{h} px, snapshot {path}",
        size_px=(w, h),
        snapshot=path,
        kept_old=kept_old,
    )


def check_snapshot_folder(out_dir: Path) -> None:
    """Refuse, before any camera is opened, a ``--out`` the snapshots cannot be written to.

    Permission bits are checked (:func:`mearm.cli.check_output_folder`), then a file is
    made and removed where the snapshots would go: root passes the bits of a read-only
    mount or of ``/sys``, where nothing can be made. Nothing is left, and no folder made.

    Raises:
        MearmError: ``out_dir`` is not a folder, or no file can be written where it is.
    """
    check_output_folder(out_dir, "--out")
    folder = out_dir if out_dir.is_dir() else existing_ancestor(out_dir)
    try:
        tempfile.TemporaryFile(dir=folder).close()
    except OSError as exc:
        raise MearmError(
            f"--out {out_dir}: cannot write: the folder {folder} is not writable "
            f"({exc.strerror or exc})"
        ) from None


def _missing_folders(out_dir: Path) -> list[Path]:
    """The folders of ``out_dir`` a snapshot would make, the deepest first."""
    missing = []
    at = out_dir.absolute()
    while not at.exists():
        missing.append(at)
        at = at.parent
    return missing


def _remove_empty(folders: list[Path]) -> None:
    """Remove the folders this run made (deepest first) that hold nothing.

    A failed run leaves no empty ``--out`` behind; one that holds another camera's
    snapshot stays, with its parents.
    """
    for folder in folders:
        try:
            folder.rmdir()
        except OSError:
            return  # it holds a snapshot (or is gone): its parents stay too


def _source(text: str) -> int | str:
    """``--camera``: an index, or a path or URL as given.

    Checked before any camera is tried: a negative index, a folder, a path that does not
    exist, a name that is not UTF-8 (OpenCV crashes on it), or a file OpenCV cannot read
    as a video or an image is bad input, not "no camera found".

    Raises:
        MearmError: the source cannot be a camera, and why.
    """
    text = text.strip()
    if not text:
        raise MearmError("--camera needs an index, a device path or a URL, got ''")
    from mearm.vision.image import opencv_takes_name  # noqa: PLC0415  (OpenCV's import)

    if not opencv_takes_name(text):  # OpenCV would crash on it (SIGSEGV)
        raise MearmError(f"--camera {text}: the name is not UTF-8 text, which OpenCV cannot "
                         "open; rename the file (or give the camera's index)")  # fmt: skip
    if text.isascii() and text.isdigit():  # not other scripts' digits (١ is not camera 1)
        return int(text)
    if re.fullmatch(r"-[0-9]+", text):
        raise MearmError(f"--camera {text}: a camera index is 0 or more")
    if "://" in text:
        return text
    path = Path(text)
    if path.is_dir():
        raise MearmError(f"--camera {text} is a folder: give a camera device, a video or an image")
    if not path.exists():
        raise MearmError(f"--camera {text} does not exist (ls /dev/video* lists the cameras)")
    if path.is_file() and not _readable_media(path):
        raise MearmError(f"--camera {text}: OpenCV cannot read a frame from it (not a video or "
                         "an image); give a camera device, a video or an image")  # fmt: skip
    return text


def _readable_media(path: Path) -> bool:
    """Whether OpenCV reads a frame from the file (a video or an image)."""
    import cv2

    from mearm.vision.image import quiet_opencv

    with quiet_opencv():
        cap = cv2.VideoCapture(str(path))
        try:
            return bool(cap.isOpened() and cap.read()[0])
        finally:
            cap.release()


def _config_hint(source: int | str) -> str:
    if isinstance(source, int):
        return f"camera.kind: device, camera.device_index: {source}"
    kind = "file" if Path(source).is_file() else "device"  # a recorded video replays
    return f"camera.kind: {kind}, camera.path: {source}"


def main(argv: Sequence[str] | None = None) -> int:
    """List the cameras with a snapshot of each; see the module docstring."""
    parser = ArgumentParser(
        prog="mearm find-camera",
        description="List the cameras OpenCV can open, with the resolution of each and a "
        "snapshot to tell them apart.",
        epilog="Exit status: 0 at least one camera gave a frame, 1 none did or a snapshot could "
        "not be written (a full disk), 2 bad input.",
    )
    add_config_argument(parser)
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("camera_snapshots"),
        metavar="DIR",
        help="folder for the snapshots (default camera_snapshots)",
    )
    parser.add_argument(
        "--indices",
        type=plain_int,
        default=DEFAULT_INDICES,
        metavar="N",
        help=f"also try camera indices 0 to N-1 (default {DEFAULT_INDICES}; at most "
        f"{MAX_INDICES}); the /dev/video* devices are always tried",
    )
    parser.add_argument(
        "--camera",
        action="append",
        default=[],
        metavar="SOURCE",
        help="try only this source: an index, a device path or a stream URL (repeatable)",
    )
    args = parser.parse_args(argv)
    if not 0 <= args.indices <= MAX_INDICES:
        parser.error(f"--indices must be in [0, {MAX_INDICES}], got {args.indices}")
    config = config_from_args(args)
    timeout_s = config.camera.open_timeout_s
    check_snapshot_folder(args.out)  # before any camera is read, not after each one

    given = list(dict.fromkeys(_source(s) for s in args.camera))  # each tried once
    sources = given or candidate_sources(args.indices)
    if not sources:
        raise MearmError(
            "--indices 0 and no /dev/video* device here: nothing to try; give --indices N "
            f"(1 to {MAX_INDICES}) or --camera SOURCE"
        )
    print(f"trying {len(sources)} camera source{'s' if len(sources) != 1 else ''}:")
    made = _missing_folders(args.out)
    reports = []
    for source in sources:
        try:
            report = probe_camera(source, timeout_s, args.out)
        except SnapshotWriteError:
            _remove_empty(made)
            raise
        reports.append(report)
        print(f"  {source!s:<14}  {'camera' if report.ok else 'no camera'}: {report.detail}")
        if report.snapshot is not None:
            if report.kept_old is not None:
                print(backup_written(report.snapshot, report.kept_old))
            print(f"wrote {report.snapshot}")
    found = [r for r in reports if r.ok]
    if not found:
        where = ", ".join(str(s) for s in sources)
        raise NoCameraFound(
            f"no cameras found (tried {where}): is one plugged in, and not held by another "
            "program? (Linux: ls /dev/video*; your user must be in the video group)"
        )
    for r in found:
        w, h = r.size_px or (0, 0)
        print(f"in your config: {_config_hint(r.source)}, camera.width_px: {w}, "
              f"camera.height_px: {h}")  # fmt: skip
    return EXIT_OK


if __name__ == "__main__":
    run(main)
