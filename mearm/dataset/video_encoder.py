"""Encoding episodes' frames in another process, the frames passed through shared memory.

The recording process draws each frame straight into a slot of a ring in shared memory
(:meth:`EncoderProcess.slot`) and sends the slot's number; the encoder process turns it
into a video frame, gives the slot back and encodes it into the episode's fragmented MP4
(:mod:`mearm.dataset.fragments`), while the sort goes on. A message says when an
episode's file is complete. The ring bounds how far the encoder may fall behind
(:data:`SLOTS` frames): a recording that draws faster than it encodes waits for a slot,
and an interrupted run waits for at most that many frames to be encoded.

The encoder ignores Ctrl-C (the terminal sends it to both processes; the recording
process decides what is kept) and ends when the recording process goes away, killed or
not. LeRobot encodes in a thread of the recording process (``StreamingVideoEncoder``),
where SVT-AV1's and the frame conversion's CPU share the sort's core.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
from multiprocessing.connection import Connection
from multiprocessing.shared_memory import SharedMemory
from pathlib import Path
from typing import Any

import numpy as np

from mearm.dataset import lerobot_format as L
from mearm.dataset.errors import EncoderError
from mearm.dataset.fragments import MOVFLAGS

#: Frames the encoder may be behind: the ring's slots (640×480: 0.9 MB each).
SLOTS = 24
#: How long to wait for the encoder process at a time before checking it is alive [s].
POLL_S = 0.2


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

    def add(self, frame: Any, repeat: int = 1) -> None:
        """Encode ``frame`` (a PyAV ``VideoFrame``) ``repeat`` times, one frame period each."""
        for _ in range(repeat):
            frame.pts = self.frames
            for packet in self._stream.encode(frame):
                self._out.mux(packet)
            self.frames += 1

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


def _serve(
    conn: Connection,
    shm_name: str,
    shape: tuple[int, int, int],
    fps: int,
    codec: str,
    dropped: Any,
) -> None:
    """The encoder process: encode the frames it is sent until told to stop (or orphaned)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    import av

    shm = SharedMemory(shm_name)
    ring = np.ndarray((SLOTS, *shape), np.uint8, buffer=shm.buf)
    writers: dict[int, EpisodeWriter] = {}
    errors: dict[int, str] = {}
    try:
        while True:
            try:
                msg = conn.recv()
            except (EOFError, OSError):  # the recording process is gone
                break
            kind, episode = msg[0], msg[1]
            if kind == "frame":
                _, _, slot, repeat = msg
                writer = writers.get(episode)
                frame = None
                if writer is not None and episode != dropped.value:
                    frame = av.VideoFrame.from_ndarray(ring[slot], format="rgb24")
                conn.send(("free", slot))
                if frame is not None and episode not in errors:
                    try:
                        writer.add(frame, repeat)  # type: ignore[union-attr]
                    except Exception as exc:  # noqa: BLE001  (said when the episode ends)
                        errors[episode] = f"{type(exc).__name__}: {exc}"
            elif kind == "open":
                try:
                    writers[episode] = EpisodeWriter(av, Path(msg[2]), fps, shape[:2], codec)
                except Exception as exc:  # noqa: BLE001
                    errors[episode] = f"{type(exc).__name__}: {exc}"
            elif kind == "finish":
                writer = writers.pop(episode, None)
                error = errors.pop(episode, None)
                if writer is not None and error is None:
                    try:
                        writer.close()
                    except Exception as exc:  # noqa: BLE001
                        error = f"{type(exc).__name__}: {exc}"
                conn.send(("done", episode, error))
            elif kind == "cancel":
                writer = writers.pop(episode, None)
                errors.pop(episode, None)
                if writer is not None:
                    writer.discard()
            elif kind == "stop":
                break
    finally:
        for writer in writers.values():
            writer.discard()
        del ring
        shm.close()


class EncoderProcess:
    """The encoder process and its ring of frames (module docstring).

    Args:
        shape: A frame's (height, width, 3) [px].
        fps: Frames per second of the videos [Hz].
        codec: A key of :data:`~mearm.dataset.lerobot_format.VIDEO_CODECS`.

    Raises:
        EncoderError: the process could not be started.
    """

    def __init__(self, shape: tuple[int, int, int], fps: int, codec: str):
        self.shape = shape
        ctx = multiprocessing.get_context("spawn")  # no copy of the sort's GL context, threads
        self._shm = SharedMemory(create=True, size=SLOTS * int(np.prod(shape)))
        self._ring = np.ndarray((SLOTS, *shape), np.uint8, buffer=self._shm.buf)
        self._dropped = ctx.Value("q", -1, lock=False)
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(
            target=_serve,
            args=(child, self._shm.name, shape, fps, codec, self._dropped),
            name="mearm-encoder",
            daemon=True,
        )
        try:
            with _sigint_ignored():  # a Ctrl-C while it starts must not kill it
                self._proc.start()
        except OSError as exc:
            self._release()
            raise EncoderError(f"cannot start the video encoder process ({exc})") from None
        child.close()
        self._free = list(range(SLOTS))
        self._done: dict[int, str | None] = {}

    def open(self, episode: int, path: Path) -> None:
        """Start episode ``episode``'s video at ``path``."""
        self._send(("open", episode, str(path)))

    def slot(self) -> tuple[int, np.ndarray]:
        """A free slot of the ring: its number and its (h, w, 3) uint8 RGB buffer.

        Waits for the encoder while every slot holds a frame not yet taken, until half of
        them are free again: a recording that outruns its encoder waits once for every
        :data:`SLOTS` / 2 frames, not once a frame (each wait costs a wake-up, long on a
        busy machine).
        """
        if not self._free:
            while len(self._free) < SLOTS // 2:
                self._pump(POLL_S)
        k = self._free.pop()
        return k, self._ring[k]

    def frame(self, episode: int, slot: int, repeat: int = 1) -> None:
        """Encode the frame in ``slot`` as the next ``repeat`` frames of ``episode``."""
        self._send(("frame", episode, slot, repeat))

    def finish(self, episode: int) -> None:
        """Episode ``episode`` has all its frames: write its file (see :meth:`done`)."""
        self._send(("finish", episode))

    def cancel(self, episode: int) -> None:
        """Drop episode ``episode``: its frames still queued are not encoded, its file goes."""
        self._dropped.value = episode
        self._send(("cancel", episode))

    def done(self, episode: int, *, wait: bool) -> tuple[bool, str | None]:
        """Whether episode ``episode``'s file is written, and the error if it failed.

        Raises:
            EncoderError: the encoder process died.
        """
        self._pump(0)
        while wait and episode not in self._done:
            self._pump(POLL_S)
        if episode not in self._done:
            return False, None
        return True, self._done.pop(episode)

    def close(self) -> None:
        """Stop the process (its unfinished episodes are dropped) and free the ring."""
        if self._proc.is_alive():
            with contextlib.suppress(OSError):
                self._conn.send(("stop", -1))
            self._proc.join(timeout=5)
            if self._proc.is_alive():
                self._proc.kill()
                self._proc.join()
        self._release()

    def _release(self) -> None:
        self._conn.close()
        del self._ring
        self._shm.close()
        with contextlib.suppress(FileNotFoundError):
            self._shm.unlink()

    def _send(self, msg: tuple[Any, ...]) -> None:
        try:
            self._conn.send(msg)
        except OSError:
            self._died()

    def _pump(self, timeout: float) -> None:
        """Take the encoder's messages: slots given back, episodes written."""
        try:
            ready = self._conn.poll(timeout)
            while ready:
                msg = self._conn.recv()
                if msg[0] == "free":
                    self._free.append(msg[1])
                else:
                    self._done[msg[1]] = msg[2]
                ready = self._conn.poll(0)
        except (EOFError, OSError):
            self._died()
        if timeout and not self._proc.is_alive():
            self._died()

    def _died(self) -> None:
        raise EncoderError(f"the video encoder process stopped (exit code {self._proc.exitcode})")


@contextlib.contextmanager
def _sigint_ignored() -> Any:
    """Ignore Ctrl-C in this block (a process started here inherits that, and keeps it)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)


class InlineEncoder:
    """:class:`EncoderProcess`'s interface, encoding in the calling thread as frames come.

    For a process whose cores are all busy already (a worker of ``mearm experiment
    --jobs``): another process would only take turns with it.
    """

    def __init__(self, shape: tuple[int, int, int], fps: int, codec: str):
        import av

        self._av = av
        self.shape = shape
        self._fps, self._codec = fps, codec
        self._buffer = np.empty(shape, np.uint8)
        self._writers: dict[int, EpisodeWriter] = {}
        self._done: dict[int, str | None] = {}

    def open(self, episode: int, path: Path) -> None:  # noqa: D102
        self._writers[episode] = EpisodeWriter(
            self._av, path, self._fps, self.shape[:2], self._codec
        )

    def slot(self) -> tuple[int, np.ndarray]:  # noqa: D102
        return 0, self._buffer

    def frame(self, episode: int, slot: int, repeat: int = 1) -> None:  # noqa: D102
        frame = self._av.VideoFrame.from_ndarray(self._buffer, format="rgb24")
        self._writers[episode].add(frame, repeat)

    def finish(self, episode: int) -> None:  # noqa: D102
        self._writers.pop(episode).close()
        self._done[episode] = None

    def cancel(self, episode: int) -> None:  # noqa: D102
        writer = self._writers.pop(episode, None)
        if writer is not None:
            writer.discard()

    def done(self, episode: int, *, wait: bool) -> tuple[bool, str | None]:  # noqa: D102
        if episode not in self._done:
            return False, None
        return True, self._done.pop(episode)

    def close(self) -> None:  # noqa: D102
        for writer in self._writers.values():
            writer.discard()
        self._writers.clear()
