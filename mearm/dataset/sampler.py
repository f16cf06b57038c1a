"""Sampling a rig into episodes: the frames drawn, their video encoded elsewhere.

:class:`EpisodeSampler` is the servo bus's sampler (:class:`~mearm.hardware.bus.Sampler`):
whenever the bus's clock (the command periods streamed, the holds and waits; the twin's
physics time) passes the next frame's time, it takes one frame at ``fps``: the state and
the action (:mod:`mearm.dataset.recorder`), and the camera's frame: the twin's camera
writes the state it is drawn from into the encoder's shared memory and the encoder's
process draws it (:class:`DrawsElsewhere`) unless that process is behind (then it is
drawn here, the same pixels); another camera's frame is drawn or converted into it here.
The sorter opens an episode per pick-and-place (or one per scene) and ends or abandons
it; an ended episode goes on to :meth:`EpisodeSampler._accept` once its video is encoded,
in order. A sort that calibrates its servos by the camera at its start hands the
calibration over (:meth:`EpisodeSampler.servos_calibrated`) and each of its episodes
carries it, so a replay runs the servos the sort ran, however the episode reaches the
dataset. A pick the dataset holds already, run again as a trial cut off by a kill is
resumed, is not recorded but timed (:class:`Rerun`): the pick after it carries that, so
the dataset says where it starts, after the held episode.

Two kinds: :class:`~mearm.dataset.recorder.DatasetRecorder` writes each into a dataset
(the video encoded by another process); :class:`EpisodeCapture` keeps them, videos
encoded in its own process, for a worker process to send back with its trial.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

import cv2
import numpy as np

from mearm.config import Config, SceneObject
from mearm.dataset import lerobot_format as L
from mearm.dataset.encoder_server import STATS_PIXEL_STRIDE  # noqa: F401  (re-exported)
from mearm.dataset.errors import DatasetWriteError, EncoderError
from mearm.dataset.reading import RecordedScene
from mearm.dataset.video_encoder import EncoderProcess, InlineEncoder, RingMemoryError
from mearm.fileio import signals_held
from mearm.hardware.bus import MeasuresWorld, ServoBus
from mearm.vision import Camera

if TYPE_CHECKING:
    from mearm.config.servo_file import ServoCalibrationFile

Per = Literal["pick", "scene"]
Encoder = EncoderProcess | InlineEncoder


def state_names(config: Config) -> list[str]:
    """The names of ``observation.state`` and ``action``, in order."""
    arm = config.arm
    return [*arm.home(), *(a.name for a in arm.tool.actuators), "gripper_closed"]


def task_sentence(class_name: str) -> str:
    """The task of a pick-and-place as a sentence."""
    return f"put the {class_name} object in the {class_name} bin"


#: The task of an episode that is a whole scene.
SCENE_TASK = "put each object in the bin of its class"


def start_calibration(nominal: Config, calibrated: Config) -> ServoCalibrationFile | None:
    """The servo calibration file that gives ``nominal`` the servos of ``calibrated``.

    Each actuator whose servo (or narrowed limits) the calibration changed, replacing the
    nominal one (``replaces``: a twin with a kit of servos keeps its physics, as the sort's
    did). ``None``: it changed none. What the sort's calibration at its start
    (``servo.calibrate_at_start``) hands back is the calibrated config, not its fits.
    """
    from mearm.config.servo_file import (  # noqa: PLC0415  (a sort that calibrated only)
        ActuatorFit,
        ServoCalibrationFile,
        now_iso,
        servo_of,
    )
    from mearm.hardware.mapping import ServoMap  # noqa: PLC0415

    def limits(config: Config) -> dict[str, tuple[float, float]]:
        arm = config.arm
        out = {j.name: (j.limits.min, j.limits.max) for j in arm.actuated_joints() if j.limits}
        out.update({a.name: (a.limits.min, a.limits.max) for a in arm.tool.actuators})
        return out

    was_limits, now_limits = limits(nominal), limits(calibrated)
    smap = ServoMap.from_arm(nominal.arm)
    fits = []
    for actuator in (*smap.joints, *smap.tool, smap.gripper):
        name = actuator.name
        was, now = servo_of(nominal.arm, name), servo_of(calibrated.arm, name)
        narrowed = now_limits.get(name)
        narrowed = narrowed if narrowed != was_limits.get(name) else None
        if now != was or narrowed is not None:
            fits.append(ActuatorFit(name, actuator.unit, now, (), 0.0, was, narrowed))
    if not fits:
        return None
    board = "the servos' calibration by the camera at a sort's start, kept by its recording"
    return ServoCalibrationFile(nominal.arm.name, board, "", now_iso(), tuple(fits))


@dataclass
class Rerun:
    """A pick the dataset holds already, run again as its trial is: timed, not recorded.

    ``mearm experiment --resume`` runs a trial cut off by a kill again from its start,
    and records only the picks the dataset does not hold. The pick after a held one
    starts where the held one left the arm: to say so, the dataset needs when the held
    pick began on this run's bus clock and its actions, one a frame as an episode's
    (to check that it ran as recorded), not its frames.

    Attributes:
        tag: The trial's seed and the pick's number in it.
        start_s: The bus clock when it began [s].
        actions: Its ``action`` at each frame's time, as an episode's.
    """

    tag: tuple[int | None, int | None]
    start_s: float
    actions: list[np.ndarray] = field(default_factory=list)

    @property
    def length(self) -> int:
        """Its frames so far."""
        return len(self.actions)


@dataclass
class _Episode:
    """An episode being recorded, then waiting for its video to be encoded.

    Attributes:
        number: Its number in this recording (the encoder's name for it).
        path: Its video, being encoded (a fragmented MP4).
        start_s: The bus clock when it began [s].
        task: Its task sentence.
        tag: The trial's seed and the pick's number in the trial, if in an experiment.
        video: The encoded video's bytes, once carried to another process (a trial run
            by a worker process); ``None`` while it is at ``path``.
        scene: The scene it sorts, as a replay rebuilds it, if known.
        servos: The text of the servo calibration file of its sort's calibration at the
            start (:meth:`EpisodeSampler.servos_calibrated`); ``None``: the config's own.
            Carried with the episode, so one a worker process recorded keeps it too.
        before: The pick before it, if the dataset holds that one already and this run
            ran it again (:class:`Rerun`): the episode continues the held one.
    """

    number: int
    path: Path
    start_s: float
    task: str
    tag: tuple[int | None, int | None]
    states: list[np.ndarray] = field(default_factory=list)
    actions: list[np.ndarray] = field(default_factory=list)
    pixels: list[np.ndarray] = field(default_factory=list)
    video: bytes | None = None
    scene: RecordedScene | None = None
    servos: str | None = None
    before: Rerun | None = None

    @property
    def length(self) -> int:
        return len(self.states)


@runtime_checkable
class DrawsRGB(Protocol):
    """A camera that draws its frame of now into a buffer, RGB (the twin's camera)."""

    def peek_rgb(self, out: np.ndarray) -> None:
        """Draw the frame ``peek()`` would give into ``out``, (h, w, 3) uint8 RGB."""


@runtime_checkable
class DrawsElsewhere(Protocol):
    """A camera whose frames another process can draw from their state (the twin's)."""

    def frame_source(self) -> Any:
        """What that process needs, pickled to it once a scene; ``None``: draw here."""

    def frame_state(self, out: np.ndarray) -> bool:
        """Write the state of the frame of now into ``out``; ``False``: draw this one here."""


class EpisodeSampler:
    """Samples a rig into episodes (module docstring); what becomes of them is a subclass's.

    Args:
        config: The rig's config (the arm's joint and tool names, the camera's size).
        fps: Frames per second of stream time [Hz], ≥ 1.
        per: One episode per ``"pick"`` (pick-and-place) or per ``"scene"`` (a whole sort).
        codec: The video encoding, a key of
            :data:`~mearm.dataset.lerobot_format.VIDEO_CODECS` (``"av1"``, ``"h264"``).
        scratch: Where episodes' videos are encoded.

    Raises:
        ValueError: ``fps`` below 1, ``per`` or ``codec`` unknown (the CLI checks them first).
    """

    def __init__(self, config: Config, *, fps: int, per: Per, codec: str, scratch: Path):
        if fps < 1:
            raise ValueError(f"fps must be at least 1, got {fps}")
        if per not in ("pick", "scene"):
            raise ValueError(f"per must be 'pick' or 'scene', got {per!r}")
        if codec not in L.VIDEO_CODECS:
            raise ValueError(f"codec must be one of {', '.join(L.VIDEO_CODECS)}, got {codec!r}")
        self.fps = int(fps)
        self.per = per
        self.codec = codec
        self.names = state_names(config)
        self._size = (config.camera.height_px, config.camera.width_px)
        self._scratch = scratch
        self._bus: ServoBus | None = None
        self._camera: Camera | None = None
        self._draw_rgb: Callable[[np.ndarray], None] | None = None
        # the encoder's process draws the camera's frames from their states: the encoder
        # and the camera's frame_state
        self._elsewhere: tuple[EncoderProcess, Callable[[np.ndarray], bool]] | None = None
        self._episode: _Episode | None = None
        self._pending: deque[_Episode] = deque()
        self._encoder: Encoder | None = None
        self._numbers = 0
        self._trial: int | None = None
        self._picks = 0
        self._held: set[int | None] = set()
        # a held pick being run again (timed, not recorded), and the last one that ended
        self._rerun: Rerun | None = None
        self._reran: Rerun | None = None
        #: The scene the episodes sort, as a replay rebuilds it, if known.
        self.scene: RecordedScene | None = None
        #: The sort's servo calibration at its start, as a file's text (each episode's).
        self._servos: str | None = None
        #: ``--config`` and ``--set`` as a replay finds them
        #: (:func:`~mearm.dataset.arguments.kept_config`), if known: with them each
        #: trial's episodes keep its table (:meth:`start_trial`).
        self.kept_config: tuple[str | None, tuple[str, ...]] | None = None
        self.episodes_written = 0
        self.frames_written = 0
        self.episodes_skipped = 0

    # ----------------------------------------------------------------- a subclass's

    def _open_encoder(self) -> Encoder:
        """The encoder of this sampler's episodes (another process)."""
        return EncoderProcess((*self._size, 3), self.fps, self.codec)

    def _accept(self, ep: _Episode) -> None:
        """An episode whose video is encoded (at ``ep.path``), in order."""
        raise NotImplementedError

    def _settle(self, *, wait: bool) -> None:
        """After :meth:`_accept`: ``wait`` until every episode accepted is written."""

    def _write_failed(self, path: Path, exc: OSError, why: str = "") -> DatasetWriteError:
        """The error of a file that could not be written (a full disk), to raise.

        ``why``: what the file is for (:meth:`DatasetWriteError.of`).
        """
        return DatasetWriteError.of(path, exc, kept=self.episodes_written, why=why)

    def _held_tags(self) -> Iterable[tuple[int | None, int | None]]:
        """The (trial seed, pick) of the episodes held already (not recorded again)."""
        return ()

    def attach(self, bus: ServoBus, camera: Camera) -> None:
        """Sample this rig from now on: its bus's commands and clock, its camera.

        A sort begins: its servos are the config's until it says it calibrated them
        (:meth:`servos_calibrated`).

        Raises:
            DatasetWriteError, EncoderError: the encoder cannot start
                (:meth:`_start_encoder`); the rig is left as it was.
        """
        if self._encoder is None:
            self._encoder = self._start_encoder()
        self._bus, self._camera = bus, camera
        self._servos = None
        self._rerun = self._reran = None
        # looked up once: a runtime protocol's isinstance walks its members every time
        self._draw_rgb = camera.peek_rgb if isinstance(camera, DrawsRGB) else None
        bus.sampler = self
        self._elsewhere = None
        if isinstance(camera, DrawsElsewhere) and isinstance(self._encoder, EncoderProcess):
            source = camera.frame_source()
            if source is not None and self._encoder.scene(source):
                self._elsewhere = (self._encoder, camera.frame_state)

    def _start_encoder(self) -> Encoder:
        """:meth:`_open_encoder`; its shared memory not to be had is a failed write.

        A full ``/dev/shm`` fails the recording as a full disk does (exit 1, one line
        naming the segment), before the sort moves the arm.

        Raises:
            DatasetWriteError: the encoder's shared memory cannot be had.
            EncoderError: its process could not be started.
        """
        try:
            return self._open_encoder()
        except RingMemoryError as exc:
            raise self._write_failed(Path(exc.filename), exc, why=exc.what) from None

    def detach(self) -> None:
        """Stop sampling the rig (an open episode is dropped; finished ones are written)."""
        self.abandon()
        if self._bus is not None and self._bus.sampler is self:
            self._bus.sampler = None
        self._bus = self._camera = None
        self._elsewhere = None

    def servos_calibrated(self, nominal: Config, calibrated: Config) -> None:
        """The sort calibrated its servos at its start: its episodes keep that calibration.

        The sorter says so (``servo.calibrate_at_start``) after :meth:`attach`, before its
        first pick. Each episode opened from here on carries it as a servo calibration
        file's text (:func:`start_calibration`), which the dataset keeps with the sort's
        first episode written and a replay applies: in this process or, sent back with a
        worker's trial (:class:`EpisodeCapture`), in the command's.
        """
        cal = start_calibration(nominal, calibrated)
        self._servos = None if cal is None else cal.text()

    def start_trial(self, trial_seed: int, table: Sequence[SceneObject] | None = None) -> None:
        """The episodes from here on are of the experiment's trial with this seed.

        Each is tagged with the seed and its pick's number in the trial. A pick the
        dataset holds already (the trial ran before, and a kill cut it or its log short)
        is not recorded again. With :attr:`kept_config`, each keeps the trial's simulated
        ``table`` (``None``: a real rig's, not known) as the scene a replay lays, its
        noise drawn from ``trial_seed``, as the trial's config
        (:func:`~mearm.experiment.trial_config`).

        The encoder starts here if it has not yet: its process's start-up (its imports,
        about 0.25 s of CPU) then runs while this process builds the trial's rig, not
        while the sort records. One that cannot start is tried again, and said, by
        :meth:`attach`.
        """
        self._trial, self._picks = trial_seed, 0
        if self.kept_config is not None:
            self.scene = None
            if table is not None:
                self.scene = RecordedScene.laid(table, *self.kept_config, noise_seed=trial_seed)
        self._held = {pick for seed, pick in self._held_tags() if seed == trial_seed}
        if self._encoder is None:
            with contextlib.suppress(EncoderError, RingMemoryError):
                self._encoder = self._open_encoder()

    @property
    def due_s(self) -> float:
        """The bus clock's time of the next frame [s] (infinite with no episode open).

        A held pick run again (:class:`Rerun`) is timed at the frames an episode's are.
        """
        timed = self._episode if self._episode is not None else self._rerun
        return float("inf") if timed is None else timed.start_s + timed.length / self.fps

    def sample(self, bus: ServoBus) -> None:
        """Take every frame due by the bus's clock, as the run is now (drawn once)."""
        ep = self._episode
        if ep is None and self._rerun is None:
            return
        due = self.due_s
        if bus.clock_s < due - 1e-9:
            return
        repeat = int((bus.clock_s - due + 1e-9) * self.fps) + 1
        state, action = self._measure(bus)
        if ep is None:  # a held pick run again: its actions only, nothing drawn
            assert self._rerun is not None
            self._rerun.actions.extend([action] * repeat)
            return
        encoder = self._encoder
        assert self._camera is not None and encoder is not None
        slot, rgb = encoder.slot()
        elsewhere = self._elsewhere
        if (
            elsewhere is not None
            and not elsewhere[0].behind()
            and elsewhere[1](elsewhere[0].state(slot))
        ):
            elsewhere[0].draw(ep.number, slot, repeat)
        else:
            if self._draw_rgb is not None:
                self._draw_rgb(rgb)
            else:
                cv2.cvtColor(self._camera.peek(), cv2.COLOR_BGR2RGB, dst=rgb)
            encoder.frame(ep.number, slot, repeat)
        ep.states.extend([state] * repeat)
        ep.actions.extend([action] * repeat)

    def _measure(self, bus: ServoBus) -> tuple[np.ndarray, np.ndarray]:
        confirmed, sent = bus.state, bus.commanded
        joints = dict(bus.actual_joints) if isinstance(bus, MeasuresWorld) else None

        def vector(cmd: Any, measured: dict[str, float] | None) -> np.ndarray:
            values: dict[str, float] = {}
            if cmd is not None:
                values.update(cmd.joints)
                values.update(cmd.tool)
                values["gripper_closed"] = float(cmd.gripper_closed)
            if measured is not None:
                values.update(measured)
            return np.array([values.get(n, np.nan) for n in self.names], dtype=np.float32)

        return vector(confirmed, joints), vector(sent, None)

    def begin(self, class_name: str) -> None:
        """A pick-and-place of an object of ``class_name`` starts: open its episode.

        Per scene, the first call opens the scene's episode and later ones do nothing.
        A pick of a trial run again that the dataset holds already is not recorded, but
        timed (per pick, :class:`Rerun`): the episode of the pick after it carries that.
        Per scene, a trial the dataset holds an episode of is held whole: that episode
        is the whole trial's.
        """
        if self._episode is not None:
            if self.per == "scene":
                return
            self._drop()
        if self._bus is None or self._encoder is None:
            raise RuntimeError("attach() the recorder to a rig before an episode")
        pick, self._picks = self._picks, self._picks + 1
        reran, self._rerun, self._reran = self._reran, None, None
        if pick in self._held or (self.per == "scene" and self._held):
            self.episodes_skipped += 1
            if self.per == "pick":
                self._rerun = Rerun((self._trial, pick), self._bus.clock_s)
                self.sample(self._bus)
            return
        self._take_encoded(wait=False)
        self._scratch.mkdir(parents=True, exist_ok=True)
        number, self._numbers = self._numbers, self._numbers + 1
        path = self._scratch / f"episode-{number}.mp4"
        task = SCENE_TASK if self.per == "scene" else task_sentence(class_name)
        tag = (self._trial, pick if self._trial is not None else None)
        self._episode = _Episode(
            number, path, self._bus.clock_s, task, tag, scene=self.scene, servos=self._servos,
            before=reran,
        )  # fmt: skip
        self._encoder.open(number, path)
        self.sample(self._bus)

    def end(self) -> None:
        """The pick-and-place ended: its episode is written once encoded (per pick).

        A held pick run again ends its timing: the next pick's episode carries it.
        """
        if self.per == "pick":
            self._reran, self._rerun = self._rerun, None
            self._finish()

    def end_run(self) -> None:
        """The sort ended normally: write the scene's episode and every one still encoding."""
        if self.per == "scene":
            self._finish()
        self._take_encoded(wait=True)

    def abandon(self) -> None:
        """Drop the episode being recorded (a fault or Ctrl-C cut it short).

        The finished episodes still being encoded are written first (at most
        :data:`~mearm.dataset.video_encoder.SLOTS` frames to encode): the sorter abandons
        before it logs how the sort ended, and the dataset then holds every pick the log
        says was finished.
        """
        self._drop()
        self._take_encoded(wait=True)

    def close(self) -> None:
        """Take the finished episodes, drop an unfinished one, stop the encoder."""
        try:
            self.detach()
        finally:
            if self._encoder is not None:
                self._encoder.close()
                self._encoder = None
            self._pending.clear()

    def _drop(self) -> None:
        self._rerun = self._reran = None
        ep, self._episode = self._episode, None
        if ep is not None and self._encoder is not None:
            self._encoder.cancel(ep.number)

    def _finish(self) -> None:
        ep, self._episode = self._episode, None
        if ep is None or self._encoder is None:
            return
        if ep.length < 2:  # nothing was sent: no motion to learn from
            self._encoder.cancel(ep.number)
            return
        self._encoder.finish(ep.number)
        self._pending.append(ep)
        self._take_encoded(wait=False)

    def _take_encoded(self, *, wait: bool) -> None:
        """Accept the episodes whose video is encoded, in order.

        ``wait``: every finished episode, encoded and accepted (and written,
        :meth:`_settle`), before this returns (Ctrl-C held back meanwhile).
        """
        encoder = self._encoder
        with no_interrupt() if wait else contextlib.nullcontext():
            while self._pending and encoder is not None:
                ep = self._pending[0]
                done, error, pixels = encoder.done(ep.number, wait=wait)
                if not done:
                    break
                self._pending.popleft()
                if error is not None:
                    ep.path.unlink(missing_ok=True)
                    number = re.search(r"\[Errno (\d+)\]", error)
                    if number is not None:  # its file could not be written (a full disk)
                        self._settle(wait=True)  # the episodes before it are written first
                        code = int(number.group(1))
                        raise self._write_failed(ep.path, OSError(code, os.strerror(code)))
                    raise EncoderError(f"an episode's video failed: {error}")
                ep.pixels = [] if pixels is None else [pixels]
                self._accept(ep)
            self._settle(wait=wait)


class EpisodeCapture(EpisodeSampler):
    """Keeps the episodes of a trial, their videos encoded in this process, to send on.

    What a worker process of ``mearm experiment --jobs N --record`` records: its trial's
    episodes go back with the trial's log records, and the command writes them into the
    dataset in trial order (:meth:`~mearm.dataset.recorder.DatasetRecorder.write_episodes`).
    Every core already runs a trial, so the encoding stays in the worker.
    """

    def __init__(self, config: Config, *, fps: int, per: Per, codec: str):
        scratch = Path(tempfile.mkdtemp(prefix="mearm-episodes-"))
        super().__init__(config, fps=fps, per=per, codec=codec, scratch=scratch)
        self.episodes: list[_Episode] = []

    def _open_encoder(self) -> Encoder:
        return InlineEncoder((*self._size, 3), self.fps, self.codec)

    def _accept(self, ep: _Episode) -> None:
        ep.video = ep.path.read_bytes()
        ep.path.unlink(missing_ok=True)
        self.episodes.append(ep)
        self.episodes_written += 1
        self.frames_written += ep.length

    def close(self) -> None:  # noqa: D102
        try:
            super().close()
        finally:
            shutil.rmtree(self._scratch, ignore_errors=True)


def no_interrupt() -> contextlib.AbstractContextManager[None]:
    """Hold Ctrl-C back until the block ends (an episode being written); it comes then.

    SIGTERM and SIGHUP too (:func:`mearm.fileio.signals_held`): in the main thread
    they are taken after the block, whichever thread the kernel gave them to (blocked
    in the main thread alone, they went to another, the recorder's writer thread, and
    Python raised ``KeyboardInterrupt`` inside the block all the same); in another
    thread (a Dask worker's trial), blocked there until it ends.
    """
    return signals_held()
