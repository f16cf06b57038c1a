"""Camera sources, chosen by ``camera.kind`` in the config (paper §1: one USB camera).

- ``device``: a USB camera through ``cv2.VideoCapture``, by ``camera.device_index`` or,
  when ``camera.path`` is set, by path (e.g. a stable ``/dev/v4l/by-id/...`` name);
  opening (and the first frame) must finish within ``camera.open_timeout_s`` and give
  the configured resolution.
- ``file``: one image (every read returns it) or a video (frames in order).
- ``folder``: the images of a folder in name order.
- ``sim``: the simulated table (:class:`mearm.sim.SimCamera`, the layer above), rendered
  afresh on every read.

Which source a config names is chosen in one place above this package,
:func:`mearm.backends.open_camera`.

Replayed frames must have the configured size, because the calibration is in pixels of
that size. Every failure is a :class:`~mearm.vision.errors.CameraError` naming the source;
nothing blocks longer than the open timeout on opening.
"""

from __future__ import annotations

import stat
import threading
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from mearm.config import CameraConfig
from mearm.vision.errors import CameraError, ImageError
from mearm.vision.image import MAX_IMAGE_PIXELS, probe_image, quiet_opencv, read_image

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".ppm", ".pgm")


class Camera(ABC):
    """A source of BGR frames; use as a context manager or call :meth:`close`.

    Attributes:
        source: What the frames come from, for messages (e.g. ``"device 0"``).
        size_px: Expected frame size (width, height) [px].
        frame_time_s: When the last frame read was taken, on the source's own clock [s],
            for a source that tells (the twin: its simulated time); ``None`` otherwise. A
            source whose clock moved on since a frame and whose next frame is not newer
            has frozen.
    """

    def __init__(self, source: str, size_px: tuple[int, int]):
        self.source = source
        self.size_px = size_px
        self.frame_time_s: float | None = None
        self._closed = False
        self._last: np.ndarray | None = None  # the frame read last (a replay's peek)

    def read(self) -> np.ndarray:
        """The next frame, (H, W, 3) uint8 BGR.

        Raises:
            CameraError: closed, no more frames, or the source failed.
        """
        if self._closed:
            raise CameraError(self.source, "read after close")
        frame = self._read()
        if frame.ndim == 2:
            frame = cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR)
        h, w = frame.shape[:2]
        if (w, h) != self.size_px:
            raise CameraError(
                self.source,
                f"frame is {w}x{h} px but the config says {self.size_px[0]}x{self.size_px[1]}"
                " (camera.width_px, camera.height_px): the calibration is for that size",
            )
        self._last = frame
        return frame

    def peek(self) -> np.ndarray:
        """A frame of the scene now, for a recording.

        Like :meth:`read`, but a source that numbers its frames (a simulated camera's
        noise) does not count it.
        """
        return self.read()

    @abstractmethod
    def _read(self) -> np.ndarray: ...

    @property
    def clock_s(self) -> float | None:
        """The source's own clock now [s] (see :attr:`frame_time_s`); ``None``: unknown."""
        return None

    def close(self) -> None:
        """Release the source; further reads raise."""
        self._closed = True

    def __enter__(self) -> Camera:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class NumberedCamera(Camera):
    """A camera that numbers the frames it reads: :meth:`peek` leaves the count as it was.

    A simulated camera's noise follows from each frame's number (:attr:`frames_read`), so
    a recorded run's frames equal an unrecorded run's.
    """

    frames_read: int

    def peek(self) -> np.ndarray:  # noqa: D102
        frames_read = self.frames_read
        try:
            return self.read()
        finally:
            self.frames_read = frames_read


class DeviceCamera(Camera):
    """A camera device through ``cv2.VideoCapture`` (``camera.kind: device``)."""

    def __init__(self, camera: CameraConfig):
        self.target: int | str = camera.path if camera.path else camera.device_index
        super().__init__(f"device {self.target}", (camera.width_px, camera.height_px))
        self._cap = self._open(camera)

    def _open(self, camera: CameraConfig) -> Any:
        box: dict[str, Any] = {}
        abandoned = threading.Event()

        def work() -> None:
            with quiet_opencv():
                cap = cv2.VideoCapture(self.target)
                ok = cap.isOpened()
                if ok:
                    cap.set(cv2.CAP_PROP_FRAME_WIDTH, camera.width_px)
                    cap.set(cv2.CAP_PROP_FRAME_HEIGHT, camera.height_px)
                    ok, box["frame"] = cap.read()
            box["ok"] = ok
            if abandoned.is_set() or not ok:
                cap.release()
            else:
                box["cap"] = cap

        thread = threading.Thread(target=work, name=self.source, daemon=True)
        thread.start()
        thread.join(camera.open_timeout_s)
        if thread.is_alive():
            abandoned.set()
            raise CameraError(
                self.source,
                f"did not open within {camera.open_timeout_s:g} s (camera.open_timeout_s): "
                "is it plugged in and free?",
            )
        if not box.get("ok"):
            raise CameraError(
                self.source,
                "cannot open or read it: check camera.device_index or camera.path "
                "(ls /dev/video* /dev/v4l/by-id) and that no other program holds the camera",
            )
        h, w = box["frame"].shape[:2]
        if (w, h) != self.size_px:
            box["cap"].release()
            raise CameraError(
                self.source,
                f"gives {w}x{h} px, not the {self.size_px[0]}x{self.size_px[1]} asked for",
            )
        return box["cap"]

    def _read(self) -> np.ndarray:
        ok, frame = self._cap.read()
        if not ok or frame is None:
            raise CameraError(self.source, "read failed: camera unplugged or stopped?")
        return frame

    def close(self) -> None:  # noqa: D102
        if not self._closed:
            self._cap.release()
        super().close()


class FileCamera(Camera):
    """One image (returned by every read) or a video file (``camera.kind: file``)."""

    def __init__(self, camera: CameraConfig):
        path = Path(str(camera.path))
        super().__init__(f"file {path}", (camera.width_px, camera.height_px))
        self.loop = camera.loop
        self._still: np.ndarray | None = None
        self._cap: Any = None
        try:
            info = path.stat()
        except (OSError, ValueError):
            raise CameraError(self.source, "no such file (camera.path)") from None
        if not stat.S_ISREG(info.st_mode):
            raise CameraError(
                self.source, "not a regular file (camera.path): give an image or video"
            )
        with quiet_opencv():
            still = path.suffix.lower() in IMAGE_SUFFIXES or cv2.haveImageReader(str(path))
        if still:
            try:
                self._still = read_image(path)
            except ImageError as exc:
                raise CameraError(self.source, exc.reason) from None
            return
        with quiet_opencv():
            self._cap = cv2.VideoCapture(str(path))
            if not self._cap.isOpened():
                raise CameraError(self.source, "neither an image nor a video OpenCV can read")
            w = int(self._cap.get(cv2.CAP_PROP_FRAME_WIDTH))
            h = int(self._cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        if (w, h) != self.size_px or w * h > MAX_IMAGE_PIXELS:
            self._cap.release()
            raise CameraError(
                self.source,
                f"video is {w}x{h} px but the config says {self.size_px[0]}x{self.size_px[1]}"
                " (camera.width_px, camera.height_px): the calibration is for that size",
            )

    def peek(self) -> np.ndarray:  # noqa: D102
        # a replay shows the frame the sort read last: reading would skip one of its frames
        return self._last.copy() if self._last is not None else self.read()

    def _read(self) -> np.ndarray:
        if self._still is not None:
            return self._still.copy()
        ok, frame = self._cap.read()
        if not ok and self.loop:
            self._cap.set(cv2.CAP_PROP_POS_FRAMES, 0)
            ok, frame = self._cap.read()
        if not ok:
            raise CameraError(self.source, "end of video (set camera.loop: true to replay)")
        return frame

    def close(self) -> None:  # noqa: D102
        if self._cap is not None and not self._closed:
            self._cap.release()
        super().close()


class FolderCamera(Camera):
    """The images of a folder, in name order (``camera.kind: folder``)."""

    def __init__(self, camera: CameraConfig):
        folder = Path(str(camera.path))
        super().__init__(f"folder {folder}", (camera.width_px, camera.height_px))
        self.loop = camera.loop
        if not folder.is_dir():
            raise CameraError(self.source, "no such folder (camera.path)")
        self.paths = sorted(p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not self.paths:
            raise CameraError(self.source, f"holds no images ({', '.join(IMAGE_SUFFIXES)})")
        for path in self.paths:  # every header now, so a bad frame stops nothing midway
            try:
                probe_image(path)
            except ImageError as exc:
                raise CameraError(self.source, f"{path.name}: {exc.reason}") from None
        self._next = 0

    def peek(self) -> np.ndarray:  # noqa: D102
        # a replay shows the frame the sort read last: reading would skip one of its frames
        return self._last.copy() if self._last is not None else self.read()

    def _read(self) -> np.ndarray:
        if self._next >= len(self.paths):
            if not self.loop:
                raise CameraError(
                    self.source,
                    f"no more frames after {len(self.paths)} (set camera.loop: true to replay)",
                )
            self._next = 0
        path = self.paths[self._next]
        self._next += 1
        try:
            return read_image(path)
        except ImageError as exc:
            raise CameraError(self.source, f"{path.name}: {exc.reason}") from None
