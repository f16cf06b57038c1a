"""Encoding episodes' frames in another process, the frames passed through shared memory.

The recording process writes each frame into a slot of a ring in shared memory
(:meth:`EncoderProcess.slot`) and sends the slot's number: the twin's camera writes the
state the frame is drawn from (:meth:`EncoderProcess.draw`; the encoder process draws
it from the scene's model, sent once, :meth:`EncoderProcess.scene`), any other camera its
pixels (:meth:`EncoderProcess.frame`). The encoder process (:mod:`mearm.dataset.encoder_server`)
turns it into a video frame, gives the slot back and encodes it into the episode's
fragmented MP4 (:mod:`mearm.dataset.fragments`), while the sort goes on. A message says when an
episode's file is complete. When the encoder has :data:`DRAW_HERE_BEHIND` frames still to
take, the twin's next frame is drawn by the recording process itself
(:meth:`EncoderProcess.behind`): the cores are shared by whichever process has work. The
ring bounds how far the encoder may fall behind (:data:`SLOTS` frames, and
:data:`~mearm.dataset.encoder_server.DRAWN_QUEUE` drawn for each encoding thread): a
recording that draws faster than it encodes waits for a slot, and an interrupted run
waits for at most those frames of its finished episodes to be encoded.

The encoder ignores Ctrl-C, SIGTERM and SIGHUP (a terminal or a supervisor sends them to
the whole process group; the recording process decides what is kept) and ends when the
recording process goes away, killed or not. The ring's segment leaves ``/dev/shm`` as
soon as the encoder process has it mapped
(:func:`~mearm.dataset.encoder_server.serve` unlinks its name): the kernel frees
its memory when the last of the two processes lets go, however they end. A kill of both
before that (within a second of the start, say ``kill -9`` of the process group, which
takes :mod:`multiprocessing`'s resource tracker too) leaves the segment named, by its
creator's process id (:data:`RING_PREFIX`): the next ring made removes it
(:func:`remove_stale_rings`), before ``/dev/shm`` fills with them.

LeRobot encodes in a thread of the recording process (``StreamingVideoEncoder``), where
SVT-AV1's and the frame conversion's CPU share the sort's core.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import secrets
import signal
import sys
import threading
from multiprocessing.shared_memory import SharedMemory
from pathlib import Path
from typing import Any

import numpy as np

from mearm.dataset.encoder_server import (  # noqa: F401  (re-exported: the ring, a writer)
    SLOTS,
    STATE_CAPACITY,
    EpisodeWriter,
    YuvConverter,
    open_episode_video,
    pixel_sample,
    rgb_frame,
    ring_bytes,
    ring_views,
    serve,
)
from mearm.dataset.errors import EncoderError

#: How long to wait for the encoder process at a time before checking it is alive [s].
POLL_S = 0.2
#: Frames the encoder process may have still to take (draw, or copy) before the recording
#: process draws the next one itself (:meth:`EncoderProcess.behind`).
DRAW_HERE_BEHIND = 12
#: Where Linux keeps POSIX shared memory (:class:`SharedMemory`'s segments): a tmpfs.
SHM_DIR = Path("/dev/shm")
#: How a ring's segment is named: ``mearm-ring-<pid of its creator>-<random hex>``.
RING_PREFIX = "mearm-ring-"


class RingMemoryError(OSError):
    """The ring's shared memory cannot be had: a full ``/dev/shm``, mostly.

    Attributes:
        filename: The segment's path.
        needs: The ring's size [bytes].
    """

    def __init__(self, exc: OSError, name: str, needs: int):
        super().__init__(exc.errno, exc.strerror, str(SHM_DIR / name.lstrip("/")))
        self.needs = needs

    @property
    def what(self) -> str:
        """What the memory is for, in a user's words."""
        return f"the video encoder's {SLOTS} frames need {self.needs / 1e6:.1f} MB of shared memory"


def ring_memory(size: int) -> SharedMemory:
    """``size`` bytes of shared memory, every page of it had now.

    A segment's pages are otherwise had when first written: in a full ``/dev/shm`` (a
    tmpfs) the first frame written into the ring killed the sort with SIGBUS ("Bus
    error"), the arm mid-move. Reserved here (``posix_fallocate``), a full one is an
    error before the sort starts.

    Raises:
        RingMemoryError: the segment cannot be made or its pages had (ENOSPC: full).
    """
    remove_stale_rings()
    while True:
        name = f"{RING_PREFIX}{os.getpid()}-{secrets.token_hex(4)}"
        try:
            shm = SharedMemory(name, create=True, size=size)
            break
        except FileExistsError:  # another ring of this process's: draw another name
            continue
        except OSError as exc:
            raise RingMemoryError(exc, str(exc.filename or name), size) from None
    fd = getattr(shm, "_fd", -1)  # CPython's, on POSIX; Windows commits it as it maps it
    if fd >= 0 and hasattr(os, "posix_fallocate"):
        try:
            os.posix_fallocate(fd, 0, size)
        except OSError as exc:
            _remove(shm)
            raise RingMemoryError(exc, shm.name, size) from None
    return shm


def remove_stale_rings() -> list[str]:
    """Remove the rings in ``/dev/shm`` whose creator is gone; their names.

    Only a ring both of whose processes were killed before the encoder had mapped it is
    still named there (module docstring); its creator's process id is in its name. One of
    a process that is alive (or of another user's, which this one may not signal) stays.
    """
    try:
        names = [n for n in os.listdir(SHM_DIR) if n.startswith(RING_PREFIX)]
    except OSError:  # no /dev/shm (not Linux), or not readable: nothing to look after
        return []
    removed = []
    for name in names:
        pid = name.removeprefix(RING_PREFIX).partition("-")[0]
        if not pid.isdigit() or _alive(int(pid)):
            continue
        with contextlib.suppress(OSError):  # removed meanwhile, or not ours to remove
            (SHM_DIR / name).unlink()
            removed.append(name)
    return removed


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (a process of another user's does)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _remove(shm: SharedMemory) -> None:
    """Unmap ``shm`` and remove its segment from ``/dev/shm`` (if the encoder did not).

    A segment left there keeps its memory (the ring's ~24 MB) until this process ends
    (:mod:`multiprocessing`'s resource tracker removes it then): a long run whose encoder
    failed to start again and again filled ``/dev/shm``.
    """
    shm.close()
    with contextlib.suppress(FileNotFoundError):  # removed already
        shm.unlink()


class EncoderProcess:
    """The encoder process and its ring of frames (module docstring).

    Args:
        shape: A frame's (height, width, 3) [px].
        fps: Frames per second of the videos [Hz].
        codec: A key of :data:`~mearm.dataset.lerobot_format.VIDEO_CODECS`.

    Raises:
        RingMemoryError: the ring's shared memory cannot be had (a full ``/dev/shm``).
        EncoderError: the process could not be started (out of file descriptors or
            processes); nothing made for it is left (the ring's segment removed).
    """

    def __init__(self, shape: tuple[int, int, int], fps: int, codec: str):
        self.shape = shape
        ctx = multiprocessing.get_context("spawn")  # no copy of the sort's GL context, threads
        self._shm = ring_memory(ring_bytes(shape))
        # a step after the ring that fails releases what was made, the ring's segment too
        with contextlib.ExitStack() as made:
            made.callback(_remove, self._shm)
            self._ring, self._states = ring_views(self._shm.buf, shape)
            made.callback(self._drop_views)  # first: the segment cannot close under them
            try:
                self._dropped = ctx.Value("q", -1, lock=False)
                self._conn, child = ctx.Pipe()
                made.callback(self._conn.close)
                with child:  # the process started has its own end
                    self._proc = ctx.Process(
                        target=serve,
                        args=(child, self._shm.name, shape, fps, codec, self._dropped),
                        name="mearm-encoder",
                        daemon=True,
                    )
                    with _sigint_ignored():  # a Ctrl-C while it starts must not kill it
                        self._proc.start()
            except OSError as exc:  # out of file descriptors or processes
                raise EncoderError(f"cannot start the video encoder process ({exc})") from None
            made.pop_all()
        self._free = list(range(SLOTS))
        self._done: dict[int, tuple[str | None, np.ndarray | None]] = {}
        self._heard = False  # a message came from the encoder (it started)

    def scene(self, source: Any) -> bool:
        """Draw the frames sent with :meth:`draw` from ``source`` from now on; whether it can.

        ``source`` (a :class:`~mearm.sim.twin.twin_frame_state.TwinFrameSource`) is
        pickled to the encoder process, which opens its renderer there. ``False``: its
        frame's state does not fit a slot (:data:`STATE_CAPACITY`); draw them here.
        """
        if source.state_size > STATE_CAPACITY:
            return False
        self._send(("scene", -1, source))
        return True

    def state(self, slot: int) -> np.ndarray:
        """A slot's room for a frame's state, (:data:`STATE_CAPACITY`,) float64."""
        return self._states[slot]

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

    def behind(self) -> bool:
        """Whether the encoder has :data:`DRAW_HERE_BEHIND` frames or more still to take.

        Then the recording process draws the next frame itself (:meth:`frame`) rather than
        send its state (:meth:`draw`): the encoder's process cannot keep up (its drawing
        and its encoding share what the sort leaves of the cores), and the sort would
        soon wait for a slot with nothing to do; drawn here, the frame costs the encoder
        only its encoding. Called after :meth:`slot` (the slot taken is not counted).
        """
        self._pump(0)
        return SLOTS - 1 - len(self._free) >= DRAW_HERE_BEHIND

    def frame(self, episode: int, slot: int, repeat: int = 1) -> None:
        """Encode the frame in ``slot`` as the next ``repeat`` frames of ``episode``."""
        self._send(("frame", episode, slot, repeat))

    def draw(self, episode: int, slot: int, repeat: int = 1) -> None:
        """Draw the frame of the state in ``slot`` (:meth:`state`) and encode it so."""
        self._send(("draw", episode, slot, repeat))

    def finish(self, episode: int) -> None:
        """Episode ``episode`` has all its frames: write its file (see :meth:`done`)."""
        self._send(("finish", episode))

    def cancel(self, episode: int) -> None:
        """Drop episode ``episode``: its frames still queued are not encoded, its file goes."""
        self._dropped.value = episode
        self._send(("cancel", episode))

    def done(self, episode: int, *, wait: bool) -> tuple[bool, str | None, np.ndarray | None]:
        """Whether episode ``episode``'s file is written, the error if it failed, its pixels.

        The pixels: each frame's :func:`~mearm.dataset.encoder_server.pixel_sample`, for
        the image statistics, (frames · k, 3) uint8.

        Raises:
            EncoderError: the encoder process died.
        """
        self._pump(0)
        while wait and episode not in self._done:
            self._pump(POLL_S)
        if episode not in self._done:
            return False, None, None
        return True, *self._done.pop(episode)

    def close(self) -> None:
        """Stop the process (its unfinished episodes are dropped) and free the ring."""
        if self._proc.is_alive():
            with contextlib.suppress(OSError):
                self._conn.send(("stop", -1))
            self._proc.join(timeout=5)
            if self._proc.is_alive():
                self._proc.kill()
                self._proc.join()
        self._conn.close()
        self._drop_views()
        _remove(self._shm)

    def _drop_views(self) -> None:
        """Let go of the arrays on the ring's memory (while they are there it cannot close)."""
        del self._ring, self._states

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
                self._heard = True
                if msg[0] == "free":
                    self._free.append(msg[1])
                else:
                    self._done[msg[1]] = (msg[2], msg[3])
                ready = self._conn.poll(0)
        except (EOFError, OSError):
            self._died()
        if timeout and not self._proc.is_alive():
            self._died()

    def _died(self) -> None:
        why = f"the video encoder process stopped (exit code {self._proc.exitcode})"
        raise EncoderError(why + _script_hint(heard=self._heard))


def _script_hint(*, heard: bool) -> str:
    """Why a spawned encoder that never answered may have died: a script without a guard.

    A spawned process imports the ``__main__`` script first; one that records at its top
    level, not under ``if __name__ == "__main__":``, stops the child with Python's
    "bootstrapping phase" error. Said only for a script outside mearm (its commands are
    guarded) and an encoder that never answered.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if heard or path is None or Path(path).resolve().is_relative_to(Path(__file__).parents[1]):
        return ""
    return (
        f"; if {Path(path).name} is your own script, put what it runs under "
        '`if __name__ == "__main__":` (the encoder is a process of its own, which imports '
        "the script first)"
    )


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
        self._convert = YuvConverter(av)
        self._writers: dict[int, EpisodeWriter] = {}
        self._done: dict[int, tuple[str | None, np.ndarray | None]] = {}

    def open(self, episode: int, path: Path) -> None:  # noqa: D102
        self._writers[episode] = EpisodeWriter(
            self._av, path, self._fps, self.shape[:2], self._codec, convert=self._convert
        )

    def slot(self) -> tuple[int, np.ndarray]:  # noqa: D102
        return 0, self._buffer

    def frame(self, episode: int, slot: int, repeat: int = 1) -> None:  # noqa: D102
        frame = rgb_frame(self._av, self._buffer)
        self._writers[episode].add(frame, repeat, pixel_sample(self._buffer))

    def finish(self, episode: int) -> None:  # noqa: D102
        writer = self._writers.pop(episode)
        writer.close()
        self._done[episode] = (None, writer.pixels())

    def cancel(self, episode: int) -> None:  # noqa: D102
        writer = self._writers.pop(episode, None)
        if writer is not None:
            writer.discard()

    def done(  # noqa: D102
        self, episode: int, *, wait: bool
    ) -> tuple[bool, str | None, np.ndarray | None]:
        if episode not in self._done:
            return False, None, None
        return True, *self._done.pop(episode)

    def close(self) -> None:  # noqa: D102
        for writer in self._writers.values():
            writer.discard()
        self._writers.clear()
