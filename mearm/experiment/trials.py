"""Trials of an experiment: each one's seed, config and layout, and running them.

Trial k draws its layout, servo noise and camera noise from its own seed
(:func:`trial_seed`), so any trial can be rerun alone; :func:`run_trial` runs one
wherever it is called (a worker process, a Dask worker) and hands its records back.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.config import Config, SceneObject
from mearm.experiment.errors import TrialFailed
from mearm.hardware.errors import ServoError
from mearm.interrupts import answered, named
from mearm.runlog import RunLog
from mearm.task import SortAborted, random_scene, run_sort
from mearm.task.rig import open_rig
from mearm.task.sorter import CalibrateFirst, calibrates_at_start
from mearm.vision.errors import CameraError

if TYPE_CHECKING:
    from mearm.dataset.recorder import DatasetRecorder

#: Objects per class in a random trial layout (the paper: 12 objects, 4 of each colour),
#: for a config whose own table is empty (a belt's, a real rig's).
PER_CLASS = 4


def trial_counts(config: Config) -> dict[str, int]:
    """How many objects of each class a random trial lays.

    As many as the config's own table holds (``task.scene``: the paper's 4 of each on
    ``sim.yaml``, 2 of each on the MeArm v1's smaller table, which 12 objects do not
    fit), or :data:`PER_CLASS` of each when the config lays none.
    """
    counts = dict.fromkeys(config.task.class_names, 0)
    for obj in config.task.scene:
        counts[obj.color] += 1
    if not any(counts.values()):
        return dict.fromkeys(config.task.class_names, PER_CLASS)
    return {name: n for name, n in counts.items() if n}


def trial_seed(seed: int, trial: int) -> int:
    """A trial's own seed, distinct for every (seed, trial) pair."""
    return int(np.random.SeedSequence([seed, trial]).generate_state(1)[0])


def trial_config(config: Config, seed: int) -> Config:
    """The config of one simulated trial: servo and camera noise reseeded."""
    servo = config.servo.model_copy(
        update={"error_model": config.servo.error_model.model_copy(update={"seed": seed})}
    )
    camera = config.camera.model_copy(update={"seed": seed})
    return config.model_copy(update={"servo": servo, "camera": camera})


@dataclass(frozen=True)
class TrialPlan:
    """What trial ``number`` of an experiment is, before it runs.

    Attributes:
        number: The trial number (from 0).
        seed: Its own seed (:func:`trial_seed`).
        config: Its config (:func:`trial_config`).
        layout: The simulated table it sorts, or ``None`` for the config's (a real rig).
    """

    number: int
    seed: int
    config: Config
    layout: list[SceneObject] | None


def plan_trial(
    config: Config, seed: int, number: int, scene: list[SceneObject] | None = None
) -> TrialPlan:
    """Trial ``number`` of the experiment with base ``seed`` (and ``--scene``, if given)."""
    s = trial_seed(seed, number)
    cfg = trial_config(config, s)
    layout = scene
    if layout is None and cfg.camera.kind == "sim":
        layout = random_scene(cfg, trial_counts(cfg), s)
    return TrialPlan(number, s, cfg, layout)


def _drives_a_board(config: Config) -> bool:
    """Whether the rig's servos are a real board on a port (not simulated, not simavr's)."""
    return config.servo.backend in ("serial", "ssc32")


def _opens_devices(config: Config) -> bool:
    """Whether the rig opens a device that may not be there.

    A servo board on a port, or a camera that is not simulated: a simulated part is
    always there.
    """
    return _drives_a_board(config) or config.camera.kind != "sim"


def check_rig_opens(
    config: Config, seed: int, number: int, scene: list[SceneObject] | None = None
) -> None:
    """Open the rig of trial ``number`` and close it again, where it has devices.

    Each trial opens the rig itself (:func:`~mearm.task.run_sort`), which connects the
    servo bus with the camera; a rig that does not open there is logged as a trial that
    stopped before its sort (header, fault, summary): a trial the log holds as finished,
    that a resumed run does not run again. A port that cannot be opened, a board that does
    not answer its handshake or a camera that cannot be opened is bad input, found by this
    before the log, the dataset or the first prompt is touched. Nothing moves.

    Raises:
        RigNotOpened: the servo bus cannot be connected (e.g. a ``LinkError``) or the
            camera cannot be opened: bad input (exit 2), said by :func:`mearm.cli.run` as
            every command's error line is (``mearm check-camera``'s, too).
    """
    if not _opens_devices(config):
        return
    plan = plan_trial(config, seed, number, scene)
    try:
        with open_rig(plan.config, plan.layout):
            pass
    except (CameraError, ServoError) as exc:
        from mearm.task.armcheck import RigNotOpened  # noqa: PLC0415  (a rig that did not open)

        raise RigNotOpened(str(exc)) from exc


def _calibrate_first(config: Config) -> CalibrateFirst | None:
    """What calibrates a trial's servos by the camera first, where its config asks for it.

    Imported only then: the camera's calibration costs every experiment 0.08 s of CPU.
    """
    if not calibrates_at_start(config):
        return None
    from mearm.maker.camera_calibration.at_start import calibrator  # noqa: PLC0415

    return calibrator()


def run_trials(
    config: Config,
    trials: int,
    seed: int,
    log: RunLog,
    *,
    scene: list[SceneObject] | None = None,
    start: int = 0,
    wait_for_user: Callable[[int], None] | None = None,
    progress: Callable[[int], None] | None = None,
    recorder: DatasetRecorder | None = None,
) -> dict[int, str | None]:
    """Run trials ``start`` .. ``trials``−1, one header per trial in ``log``.

    Args:
        config: The rig.
        trials: How many in the whole experiment.
        seed: Base seed; trial k uses :func:`trial_seed` (seed, k).
        log: Where the records go.
        scene: The same layout every trial instead of a random one.
        start: The first trial to run (the ones before are in the log already).
        wait_for_user: Called with the trial number before each trial on a real rig (to
            lay out the objects).
        progress: Called after each trial with the number of trials run so far.
        recorder: Records every trial's sorts into one dataset (``--record``), each
            episode tagged with its trial: a pick the dataset holds already (a trial cut
            off by a kill, run again) is not recorded twice.

    Returns:
        Per trial run, ``None`` if it cleared the table, else the reason it stopped.

    Raises:
        SortAborted: a trial was interrupted with Ctrl-C, or stopped by a recording that
            failed (a full disk); the log holds what was done.
        TrialFailed: a trial on a servo board (``servo.backend`` ``serial`` or ``ssc32``)
            stopped on a fault of its servos: the arm is where the fault left it, and the
            next trial would open the port again (an Uno resets) and move it home in one
            command from a pose nobody knows. The log holds the trial, finished: the same
            command runs the rest once the rig is fixed.
    """
    outcomes: dict[int, str | None] = {}
    for k in range(start, trials):
        plan = plan_trial(config, seed, k, scene)
        if wait_for_user is not None:
            wait_for_user(k)
        if recorder is not None:
            recorder.start_trial(plan.seed, plan.layout)
        try:
            run_sort(
                plan.config, scene=plan.layout, log=log, trial=k, seed=plan.seed, echo=None,
                recorder=recorder, calibrate_first=_calibrate_first(plan.config),
            )  # fmt: skip
            outcomes[k] = None
        except SortAborted as exc:
            if exc.interrupted or (recorder is not None and recorder.failure is not None):
                raise  # Ctrl-C, or a recording that failed: no trial after it is recorded
            outcomes[k] = exc.reason
            if exc.servo_fault and _drives_a_board(plan.config):
                if progress is not None:
                    progress(len(outcomes))
                rest = (
                    "; no trial after it started: a fault of the servo board stops the experiment"
                    if k + 1 < trials
                    else ""
                )
                raise TrialFailed(f"trial {k}: {exc.reason}{rest}") from None
        if progress is not None:
            progress(len(outcomes))
    return outcomes


@dataclass(frozen=True)
class Recording:
    """How a worker records its trials' picks (``--record`` with ``--jobs``).

    Attributes:
        fps: Frames per second of the run's time [Hz].
        per: ``"pick"`` or ``"scene"``: what an episode is.
        codec: The video's codec (``--record-codec``).
        kept_config: ``--config`` and ``--set`` as a replay finds them
            (:func:`~mearm.dataset.arguments.kept_config`): each trial's episodes keep
            its table with them; ``None``: no table kept.
    """

    fps: int
    per: str
    codec: str
    kept_config: tuple[str | None, tuple[str, ...]] | None = None


@dataclass(frozen=True)
class TrialResult:
    """What a worker reports back about trial ``number``.

    Attributes:
        number: The trial.
        ran: Whether it ran (a worker that saw Ctrl-C starts no more trials).
        reason: ``None`` if it cleared the table, else why it stopped.
        interrupted: It was stopped by Ctrl-C.
        error: A camera or servo that failed it (as the serial run reports it), if one did.
        records: Its run-log lines (JSON lines, as bytes), for the command to append.
        episodes: Its picks recorded, videos encoded (:class:`~mearm.dataset.sampler.
            EpisodeCapture`), for the command to write into the dataset.
    """

    number: int
    ran: bool = True
    reason: str | None = None
    interrupted: bool = False
    error: str | None = None
    records: bytes = b""
    episodes: tuple[Any, ...] = ()


def run_trial(
    config: Config,
    seed: int,
    scene: list[SceneObject] | None,
    number: int,
    recording: Recording | None = None,
    running: Callable[[bool], None] | None = None,
) -> TrialResult:
    """Run trial ``number`` wherever this is called; its records come back as data.

    The trial writes its log into a temporary folder of the machine it runs on, which is
    read back and removed: a worker (a process here, or a Dask worker elsewhere) needs
    no file system shared with the command, only the arguments. With ``recording``, its
    picks come back as episodes, too. ``running`` is told when the trial starts and
    ends (a worker process's Ctrl-C interrupts only a running trial).
    """
    capture = None
    with tempfile.TemporaryDirectory(prefix="mearm-trial-") as tmp:
        part = Path(tmp) / f"trial-{number}.jsonl"
        try:
            if running is not None:
                running(True)  # noqa: FBT003 - the hook's one argument: started
            plan = plan_trial(config, seed, number, scene)
            if recording is not None:
                from mearm.dataset.sampler import EpisodeCapture

                capture = EpisodeCapture(
                    plan.config, fps=recording.fps, per=recording.per,  # type: ignore[arg-type]
                    codec=recording.codec,
                )  # fmt: skip
                capture.kept_config = recording.kept_config
                capture.start_trial(plan.seed, plan.layout)
            with RunLog(part, exclusive=True, fsync=False) as log:
                run_sort(
                    plan.config, scene=plan.layout, log=log, trial=number, seed=plan.seed,
                    echo=None, recorder=capture, calibrate_first=_calibrate_first(plan.config),
                )  # fmt: skip
            result = TrialResult(number)
        except SortAborted as exc:
            result = TrialResult(number, reason=exc.reason, interrupted=exc.interrupted)
        except KeyboardInterrupt as exc:  # before the sort started; run_sort logged it if so
            answered()
            result = TrialResult(number, reason=f"interrupted ({named(exc)})", interrupted=True)
        except (CameraError, ServoError) as exc:
            result = TrialResult(number, reason=str(exc), error=str(exc))
        finally:
            if running is not None:
                running(False)  # noqa: FBT003 - ended
            if capture is not None:
                capture.close()
        episodes = tuple(capture.episodes) if capture is not None else ()
        return replace(
            result, records=part.read_bytes() if part.exists() else b"", episodes=episodes
        )
