"""The encoder process: frames drawn from the twin's state or taken as drawn, then encoded.

:class:`~mearm.dataset.video_encoder.EncoderProcess` starts :func:`serve` in another
process and shares a ring of :data:`SLOTS` slots with it, each a frame's pixels and a
frame's state (:data:`STATE_CAPACITY` float64 values). A slot arrives as ``"frame"`` (its
pixels drawn by the recording process: a camera that is not the twin's, a camera fault,
a lens) or ``"draw"`` (its state: this process draws it, from the scene's model sent once
as ``"scene"``, :mod:`mearm.sim.twin.twin_frame_state`). One thread takes the slots in
order, draws or copies each frame out of its slot and gives the slot back; episode k is
converted to yuv420p and encoded by encoding thread k mod :data:`ENCODING_THREADS`, so
that an episode is encoded while the last one's frames still are (MuJoCo's renderer,
swscale and FFmpeg's encoders let go of the GIL): on two cores the sort, the drawing and
the encoding share both. A frame whose state is the last one's (nothing moved: every
body asleep) is the last picture again, not drawn.

Each frame's pixel sample for the image statistics (every :data:`STATS_PIXEL_STRIDE`-th
row and column) goes back with the episode's ``"done"``.
"""

from __future__ import annotations

import contextlib
import os
import queue
import signal
import sys
import threading
from collections.abc import Iterator
from multiprocessing.connection import Connection
from multiprocessing.shared_memory import SharedMemory
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from mearm.dataset import lerobot_format as L
from mearm.dataset.fragments import MOVFLAGS

#: Frames the encoder may be behind: the ring's slots (640×480: 0.9 MB each).
SLOTS = 24
#: A slot's room for a frame's state [float64 values]: 64 kB (the 12-object twin's is 1 245).
STATE_CAPACITY = 8192
#: Encoding threads: episode k is encoded by thread k mod this, so that the next episode
#: is encoded while the last one's frames still are (each thread runs its own encoder).
ENCODING_THREADS = 2
#: Frames drawn and waiting for an encoding thread at most (0.9 MB each at 640×480): about
#: a pick's episode (22 frames at 10 fps), so that the threads overlap by whole episodes.
DRAWN_QUEUE = 24
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


def rgb_frame(av: Any, rgb: np.ndarray) -> Any:
    """``rgb`` (h, w, 3) uint8 copied into a PyAV frame (rgb24): its slot is free again.

    The drawing thread copies; the encoding thread converts (:class:`YuvConverter`) and
    encodes, so the drawing, the thread that waits on the renderer, does no more.
    """
    return av.VideoFrame.from_ndarray(rgb, format="rgb24")


class YuvConverter:
    """RGB frames to the videos' pixel format (yuv420p), as the encoder would convert them.

    The same swscale conversion PyAV's encoder makes of an RGB frame (the files are
    byte-identical), with one scaling context kept and one thread: a context made for each
    frame, with swscale's automatic threads, cost 0.7–1 ms more CPU a 640×480 frame. The
    frame converted last is kept: a frame encoded again (nothing moved) is not converted
    again.
    """

    def __init__(self, av: Any):
        self._reformatter = av.video.reformatter.VideoReformatter()
        self._last: tuple[Any, Any] = (None, None)

    def __call__(self, frame: Any) -> Any:
        """``frame`` in the videos' pixel format (itself if it is in it already)."""
        if frame.format.name == L.VIDEO_PIX_FMT:
            return frame
        if frame is not self._last[0]:
            yuv = self._reformatter.reformat(frame, format=L.VIDEO_PIX_FMT, threads=1)
            self._last = (frame, yuv)
        return self._last[1]


def open_episode_video(
    av: Any, path: Path | BinaryIO, fps: int, size_hw: tuple[int, int], codec: str
) -> Any:
    """An output container and stream for one episode's fragmented MP4 (a path or a file)."""
    os.environ.setdefault("SVT_LOG", "1")  # SVT-AV1: errors only, not its banner
    spec = L.VIDEO_CODECS[codec]
    target = str(path) if isinstance(path, Path) else path
    out = av.open(target, "w", format="mp4", options={"movflags": MOVFLAGS})
    stream = out.add_stream(spec.encoder, rate=fps, options=spec.options())
    stream.height, stream.width = size_hw
    stream.pix_fmt = L.VIDEO_PIX_FMT
    stream.gop_size = L.VIDEO_GOP
    with scheduling_kept():
        stream.codec_context.open()
    return out, stream


#: The realtime scheduling policies (Linux); none where ``os`` has no scheduler calls.
_REALTIME = {getattr(os, name) for name in ("SCHED_FIFO", "SCHED_RR") if hasattr(os, name)}


def _threads_policies() -> dict[int, int]:
    """Each thread of this process (its id) and its scheduling policy."""
    out: dict[int, int] = {}
    with contextlib.suppress(OSError):
        for tid in os.listdir("/proc/self/task"):
            with contextlib.suppress(OSError):  # a thread that ended meanwhile
                out[int(tid)] = os.sched_getscheduler(int(tid))
    return out


@contextlib.contextmanager
def scheduling_kept() -> Iterator[None]:
    """Every thread of this process at the scheduling it had before the block.

    A thread the block started at a realtime policy runs at the calling thread's.
    SVT-AV1, opened as root, puts the thread that opens it and its own 38 encoding threads
    at ``SCHED_FIFO`` 99, and leaves the first there: every process that thread started
    afterwards inherited it (a pytest worker after an AV1 episode started the virtual Uno's
    busy simulator realtime, and it held a core), and on two cores the encoding threads
    took the CPU before anything else, the sort's own process included. A program run
    realtime on purpose (``chrt``) keeps it: only what the block changed is undone.
    """
    if not hasattr(os, "sched_getscheduler"):  # pragma: no cover - not Linux
        yield
        return
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    before = _threads_policies()
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            if (os.sched_getscheduler(0), os.sched_getparam(0)) != (policy, param):
                os.sched_setscheduler(0, policy, param)
        for tid, now in _threads_policies().items():
            if now in _REALTIME and before.get(tid, policy) not in _REALTIME:
                with contextlib.suppress(OSError):  # ended meanwhile, or not ours to change
                    os.sched_setscheduler(tid, policy, param)


class EpisodeWriter:
    """One episode's video being encoded, in whatever process holds it."""

    def __init__(
        self,
        av: Any,
        path: Path,
        fps: int,
        size_hw: tuple[int, int],
        codec: str,
        convert: YuvConverter | None = None,
    ):
        self.path = path
        self._av = av
        self._convert = convert if convert is not None else YuvConverter(av)
        # written through a Python file: FFmpeg's own writes drop a full disk's error
        # (the file is cut short, the close succeeds); these raise it, errno and all
        self._file = open(path, "wb")  # noqa: SIM115  (closed by close() or discard())
        try:
            self._out, self._stream = open_episode_video(av, self._file, fps, size_hw, codec)
        except BaseException:
            self._file.close()
            raise
        self.frames = 0
        self.samples: list[np.ndarray] = []

    def add(self, frame: Any, repeat: int = 1, sample: np.ndarray | None = None) -> None:
        """Encode ``frame`` (a PyAV ``VideoFrame``) ``repeat`` times, one frame period each.

        Converted to the videos' pixel format once (:class:`YuvConverter`). ``sample``:
        its :func:`pixel_sample`, kept once per frame encoded.
        """
        frame = self._convert(frame)
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
        self._file.close()  # what is still buffered: its write error is raised here

    def discard(self) -> None:
        """Stop and remove the file.

        The encoder is sent its end of stream first, its last packets dropped: SVT-AV1
        freed without it says ``Svt[error]: deinit called without sending EOS!`` on
        stderr, above an interrupted sort's own line.
        """
        with contextlib.suppress(Exception):
            for _ in self._stream.encode():
                pass
        with contextlib.suppress(Exception):
            self._out.close()
        with contextlib.suppress(OSError):
            self._file.close()
        self.path.unlink(missing_ok=True)


def _error(exc: Exception) -> str:
    return f"{type(exc).__name__}: {exc}"


class _Encoding(threading.Thread):
    """An encoding thread: its episodes' writers, fed in order through a bounded queue.

    A frame of an episode dropped meanwhile (``dropped``, the recording process's last
    cancelled episode) is not encoded: its file goes anyway; nor is anything once the
    process is stopping (``stopping``: its unfinished episodes are dropped).
    """

    def __init__(
        self,
        av: Any,
        send: Any,
        video: tuple[int, tuple[int, int], str],
        dropped: Any,
        stopping: threading.Event,
    ):
        super().__init__(name="mearm-encode")
        self.todo: queue.Queue[tuple[Any, ...] | None] = queue.Queue(DRAWN_QUEUE)
        self._av, self._send, self._dropped = av, send, dropped
        self._stopping = stopping
        self._video = video
        self._convert = YuvConverter(av)  # this thread's: one scaling context
        self._writers: dict[int, EpisodeWriter] = {}
        self._errors: dict[int, str] = {}

    def run(self) -> None:  # noqa: D102
        try:
            while (item := self.todo.get()) is not None:
                if not self._stopping.is_set():
                    self._handle(item)
        finally:
            for writer in self._writers.values():
                writer.discard()

    def _handle(self, item: tuple[Any, ...]) -> None:
        kind, episode = item[0], item[1]
        if kind == "frame":
            _, _, frame, repeat, sample = item
            writer = self._writers.get(episode)
            dropped = episode == self._dropped.value
            if writer is not None and episode not in self._errors and not dropped:
                try:
                    writer.add(frame, repeat, sample)
                except Exception as exc:  # noqa: BLE001  (said when the episode ends)
                    self._errors[episode] = _error(exc)
        elif kind == "error":
            self._errors.setdefault(episode, item[2])
        elif kind == "open":
            try:
                self._writers[episode] = EpisodeWriter(
                    self._av, Path(item[2]), *self._video, convert=self._convert
                )
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
            return rgb_frame(self._av, rgb), pixel_sample(rgb)
        if self._drawer is None:
            raise RuntimeError(self._scene_error)
        state = self._states[slot, : self._size]
        last = self._last
        if last is not None and np.array_equal(state, last[0]):
            return last[1], last[2]  # nothing moved: the same picture
        self._drawer.draw(state, rgb)
        frame = rgb_frame(self._av, rgb)
        sample = pixel_sample(rgb)
        self._last = (state.copy(), frame, sample)
        return frame, sample

    def close(self) -> None:
        """Free the scene's renderer."""
        if self._drawer is not None:
            with contextlib.suppress(Exception):
                self._drawer.close()
            self._drawer = None


#: What a terminal (Ctrl-C, a closed window) or a supervisor (its stop) sends a process
#: group; the encoder ignores them (:func:`serve`).
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name)
)


def serve(
    conn: Connection,
    shm_name: str,
    shape: tuple[int, int, int],
    fps: int,
    codec: str,
    dropped: Any,
) -> None:
    """The encoder process: draw and encode the frames it is sent until told to stop.

    It exits at once when done (:func:`os._exit`), or with the error that stopped it.
    It ignores the stop signals a terminal or a supervisor sends the whole process group
    (Ctrl-C, SIGTERM, SIGHUP): the recording process takes them, waits for the episodes
    it finished to be encoded and written, and then stops this one (killed by a SIGTERM
    to the group, it lost them: the sort then ended as interrupted, naming nothing).
    Its pipe's end tells it when that process is gone, however it ended.
    """
    for stop in STOP_SIGNALS:
        signal.signal(stop, signal.SIG_IGN)
    shm = SharedMemory(shm_name)
    # Mapped here and in the recording process: its name can go, and with it the memory
    # once both processes end, killed or not (a kill of the process group takes the
    # resource tracker too, which would otherwise remove it).
    with contextlib.suppress(FileNotFoundError):  # the recording process removed it
        shm.unlink()
    import av

    frames, states = ring_views(shm.buf, shape)
    lock = threading.Lock()

    def send(msg: tuple[Any, ...]) -> None:
        with lock, contextlib.suppress(OSError):  # the recording process is gone
            conn.send(msg)

    stopping = threading.Event()
    video = (fps, shape[:2], codec)
    encodings = [_Encoding(av, send, video, dropped, stopping) for _ in range(ENCODING_THREADS)]
    drawing = _Drawing(av, frames, states)
    for encoding in encodings:
        encoding.start()
    try:
        _receive(conn, send, encodings, drawing, dropped)
    finally:
        stopping.set()
        for encoding in encodings:
            encoding.todo.put(None)
        for encoding in encodings:
            encoding.join()
        drawing.close()
        del frames, states
        shm.close()
    # Stopped and cleaned up: leave without the interpreter's teardown (MuJoCo's, Mesa's
    # and FFmpeg's modules: 0.15 s the recording process would wait for at its end).
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def _receive(
    conn: Connection, send: Any, encodings: list[_Encoding], drawing: _Drawing, dropped: Any
) -> None:
    """Take the recording process's messages in order until ``stop`` or its end.

    Each episode's messages go, in order, to its encoding thread (its number mod theirs).
    """
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
                encodings[episode % len(encodings)].todo.put(item)
        elif kind == "scene":
            drawing.scene(msg[2])
        elif kind == "stop":
            return
        else:  # open, finish, cancel: in order with the frames
            encodings[episode % len(encodings)].todo.put(msg)
