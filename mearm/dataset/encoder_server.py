"""The encoder process: frames drawn from the twin's state or taken as drawn, then encoded.

:class:`~mearm.dataset.video_encoder.EncoderProcess` starts :func:`serve` in another
process and shares a ring of :data:`SLOTS` slots with it, each a frame's pixels and a
frame's state (:data:`STATE_CAPACITY` float64 values). A slot arrives as ``"frame"`` (its
pixels drawn by the recording process: a camera that is not the twin's, a camera fault,
a lens) or ``"draw"`` (its state: this process draws it, from the scene's model sent once
as ``"scene"``, :mod:`mearm.sim.twin.twin_frame_state`). Drawing and encoding run in two
threads of this process (MuJoCo's renderer and FFmpeg's encoders let go of the GIL), so
on two cores the sort, the drawing and the encoding share both. A frame whose state is
the last one's (nothing moved: every body asleep) is the last picture again, not drawn.

Each frame's pixel sample for the image statistics (every :data:`STATS_PIXEL_STRIDE`-th
row and column) goes back with the episode's ``"done"``.
"""

from __future__ import annotations

import contextlib
import os
import queue
import signal
import threading
from multiprocessing.connection import Connection
from multiprocessing.shared_memory import SharedMemory
from pathlib import Path
from typing import Any

import numpy as np

from mearm.dataset import lerobot_format as L
from mearm.dataset.fragments import MOVFLAGS

#: Frames the encoder may be behind: the ring's slots (640×480: 0.9 MB each).
SLOTS = 24
#: A slot's room for a frame's state [float64 values]: 64 kB (the 12-object twin's is 1 245).
STATE_CAPACITY = 8192
#: Frames drawn and waiting for the encoding thread at most (0.9 MB each at 640×480).
DRAWN_QUEUE = 4
#: A frame's pixels kept for the image statistics: every this many rows and columns.
STATS_PIXEL_STRIDE = 16


def ring_bytes(shape: tuple[int, int, int]) -> int:
    """The shared memory of a ring of frames of ``shape``: pixels, then states [bytes]."""
    return SLOTS * (int(np.prod(shape)) + 8 * STATE_CAPACITY)


def ring_views(buf: Any, shape: tuple[int, int, int]) -> tuple[np.ndarray, np.ndarray]:
    """The ring's frames (SLOTS, h, w, 3) uint8 and states (SLOTS, STATE_CAPACITY) float64."""
    frames = np.ndarray((SLOTS, *shape), np.uint8, buffer=buf)
    states = np.ndarray((SLOTS, STATE_CAPACITY), np.float64, buffer=buf, offset=frames.nbytes)
    return frames, states


def pixel_sample(rgb: np.ndarray) -> np.ndarray:
    """A frame's pixels kept for the image statistics, (k, 3) uint8."""
    step = STATS_PIXEL_STRIDE
    return rgb[::step, ::step].reshape(-1, 3).copy()


def video_frame(av: Any, rgb: np.ndarray) -> Any:
    """``rgb`` (h, w, 3) uint8 as a PyAV frame already in the videos' pixel format (yuv420p).

    The same conversion the encoder makes of an RGB frame (its files are byte-identical),
    done by whoever calls this: the drawing thread, so the encoding thread only encodes.
    """
    return av.VideoFrame.from_ndarray(rgb, format="rgb24").reformat(format=L.VIDEO_PIX_FMT)


def open_episode_video(av: Any, path: Path, fps: int, size_hw: tuple[int, int], codec: str) -> Any:
    """An output container and stream for one episode's fragmented MP4."""
    os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1: errors only, not its banner
    spec = L.VIDEO_CODECS[codec]
    out = av.open(str(path), "w", format="mp4", options={"movflags": MOVFLAGS})
    stream = out.add_stream(spec.encoder, rate=fps, options=spec.options())
    stream.height, stream.width = size_hw
    stream.pix_fmt = L.VIDEO_PIX_FMT
    stream.gop_size = L.VIDEO_GOP
    return out, stream


class EpisodeWriter:
    """One episode's video being encoded, in whatever process holds it."""

    def __init__(self, av: Any, path: Path, fps: int, size_hw: tuple[int, int], codec: str):
        self.path = path
        self._av = av
        self._out, self._stream = open_episode_video(av, path, fps, size_hw, codec)
        self.frames = 0
        self.samples: list[np.ndarray] = []

    def add(self, frame: Any, repeat: int = 1, sample: np.ndarray | None = None) -> None:
        """Encode ``frame`` (a PyAV ``VideoFrame``) ``repeat`` times, one frame period each.

        ``sample``: its :func:`pixel_sample`, kept once per frame encoded.
        """
        for _ in range(repeat):
            frame.pts = self.frames
            for packet in self._stream.encode(frame):
                self._out.mux(packet)
            self.frames += 1
        if sample is not None:
            self.samples.extend([sample] * repeat)

    def pixels(self) -> np.ndarray | None:
        """The episode's pixel samples, (frames · k, 3) uint8; ``None`` if none were kept."""
        return np.concatenate(self.samples) if self.samples else None

    def close(self) -> None:
        """Flush the encoder and write the file's one fragment."""
        for packet in self._stream.encode():
            self._out.mux(packet)
        self._out.close()

    def discard(self) -> None:
        """Stop and remove the file."""
        with contextlib.suppress(Exception):
            self._out.close()
        self.path.unlink(missing_ok=True)


def _error(exc: Exception) -> str:
    return f"{type(exc).__name__}: {exc}"


class _Encoding(threading.Thread):
    """The encoding thread: the episodes' writers, fed in order through a bounded queue."""

    def __init__(self, av: Any, send: Any, fps: int, size_hw: tuple[int, int], codec: str):
        super().__init__(name="mearm-encode")
        self.todo: queue.Queue[tuple[Any, ...] | None] = queue.Queue(DRAWN_QUEUE)
        self._av, self._send = av, send
        self._video = (fps, size_hw, codec)
        self._writers: dict[int, EpisodeWriter] = {}
        self._errors: dict[int, str] = {}

    def run(self) -> None:  # noqa: D102
        try:
            while (item := self.todo.get()) is not None:
                self._handle(item)
        finally:
            for writer in self._writers.values():
                writer.discard()

    def _handle(self, item: tuple[Any, ...]) -> None:
        kind, episode = item[0], item[1]
        if kind == "frame":
            _, _, frame, repeat, sample = item
            writer = self._writers.get(episode)
            if writer is not None and episode not in self._errors:
                try:
                    writer.add(frame, repeat, sample)
                except Exception as exc:  # noqa: BLE001  (said when the episode ends)
                    self._errors[episode] = _error(exc)
        elif kind == "error":
            self._errors.setdefault(episode, item[2])
        elif kind == "open":
            try:
                self._writers[episode] = EpisodeWriter(self._av, Path(item[2]), *self._video)
            except Exception as exc:  # noqa: BLE001
                self._errors[episode] = _error(exc)
        elif kind == "finish":
            self._finish(episode)
        elif kind == "cancel":
            writer = self._writers.pop(episode, None)
            self._errors.pop(episode, None)
            if writer is not None:
                writer.discard()

    def _finish(self, episode: int) -> None:
        writer = self._writers.pop(episode, None)
        error = self._errors.pop(episode, None)
        pixels = None
        if writer is not None and error is None:
            try:
                writer.close()
                pixels = writer.pixels()
            except Exception as exc:  # noqa: BLE001
                error = _error(exc)
        self._send(("done", episode, error, pixels))


class _Drawing:
    """The receiving thread's side: slots taken, frames drawn from states, scenes opened."""

    def __init__(self, av: Any, frames: np.ndarray, states: np.ndarray):
        self._av = av
        self._frames, self._states = frames, states
        self._drawer: Any = None
        self._size = 0  # the scene's state values
        self._scene_error: str | None = "no scene was sent to draw from"
        self._last: tuple[np.ndarray, Any, np.ndarray] | None = None  # state, frame, sample

    def scene(self, source: Any) -> None:
        """Draw from ``source``'s model from now on (a :class:`TwinFrameSource`)."""
        self.close()
        self._last = None
        try:
            self._drawer, self._scene_error = source.open(), None
            self._size = int(source.state_size)
        except Exception as exc:  # noqa: BLE001  (each frame drawn says it)
            self._scene_error = f"cannot draw the twin's frames here ({_error(exc)})"

    def take(self, kind: str, slot: int) -> tuple[Any, np.ndarray]:
        """The slot's frame as a PyAV frame and its pixel sample (``kind``: "frame", "draw").

        Raises:
            RuntimeError: a frame to draw, and no scene to draw it from.
        """
        rgb = self._frames[slot]
        if kind != "draw":
            self._last = None
            return video_frame(self._av, rgb), pixel_sample(rgb)
        if self._drawer is None:
            raise RuntimeError(self._scene_error)
        state = self._states[slot, : self._size]
        last = self._last
        if last is not None and np.array_equal(state, last[0]):
            return last[1], last[2]  # nothing moved: the same picture
        self._drawer.draw(state, rgb)
        frame = video_frame(self._av, rgb)
        sample = pixel_sample(rgb)
        self._last = (state.copy(), frame, sample)
        return frame, sample

    def close(self) -> None:
        """Free the scene's renderer."""
        if self._drawer is not None:
            with contextlib.suppress(Exception):
                self._drawer.close()
            self._drawer = None


def serve(
    conn: Connection,
    shm_name: str,
    shape: tuple[int, int, int],
    fps: int,
    codec: str,
    dropped: Any,
) -> None:
    """The encoder process: draw and encode the frames it is sent until told to stop."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import av

    shm = SharedMemory(shm_name)
    frames, states = ring_views(shm.buf, shape)
    lock = threading.Lock()

    def send(msg: tuple[Any, ...]) -> None:
        with lock, contextlib.suppress(OSError):  # the recording process is gone
            conn.send(msg)

    encoding = _Encoding(av, send, fps, shape[:2], codec)
    drawing = _Drawing(av, frames, states)
    encoding.start()
    try:
        _receive(conn, send, encoding, drawing, dropped)
    finally:
        encoding.todo.put(None)
        encoding.join()
        drawing.close()
        del frames, states
        shm.close()


def _receive(
    conn: Connection, send: Any, encoding: _Encoding, drawing: _Drawing, dropped: Any
) -> None:
    """Take the recording process's messages in order until ``stop`` or its end."""
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):  # the recording process is gone
            return
        kind, episode = msg[0], msg[1]
        if kind in ("frame", "draw"):
            _, _, slot, repeat = msg
            item: tuple[Any, ...] | None = None
            if episode != dropped.value:
                try:
                    frame, sample = drawing.take(kind, slot)
                    item = ("frame", episode, frame, repeat, sample)
                except Exception as exc:  # noqa: BLE001  (said when the episode ends)
                    item = ("error", episode, _error(exc))
            send(("free", slot))
            if item is not None:
                encoding.todo.put(item)
        elif kind == "scene":
            drawing.scene(msg[2])
        elif kind == "stop":
            return
        else:  # open, finish, cancel: in order with the frames
            encoding.todo.put(msg)
