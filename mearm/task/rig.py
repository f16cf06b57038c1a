"""Opening the rig a config describes, and running one sort on it.

The world (if simulated), camera and servo bus, and one sort with its run-log records:
what ``mearm sort`` and ``mearm experiment`` share.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from mearm.backends import open_parts, require_table, table_world, uses_world
from mearm.config import Config, SceneObject
from mearm.errors import MearmError
from mearm.hardware.bus import ServoBus
from mearm.interrupts import named
from mearm.kinematics import ArmModel
from mearm.sim import World
from mearm.task.check import check_consistency
from mearm.task.report import SortReport
from mearm.task.sorter import CalibrateFirst, EpisodeRecorder, SortAborted, Sorter
from mearm.vision import Camera

if TYPE_CHECKING:
    from mearm.runlog.writer import RunLog  # a log is written only when asked for


@dataclass
class Rig:
    """The parts of one rig, simulated or real.

    Attributes:
        world: The simulated table, or ``None`` on a real rig (camera and servos real).
        camera: The frame source.
        bus: The servo bus, connected (:func:`open_rig` connects it).
        model: The arm model.
        in_bins: In simulation, how many objects of each class lie in its bin (what a
            place is confirmed against); ``None`` on a real rig.
        placed: In simulation, how many objects of each class lay on the table at the
            start; ``None`` on a real rig.
    """

    world: World | None
    camera: Camera
    bus: ServoBus
    model: ArmModel
    in_bins: Callable[[], Mapping[str, int]] | None = None
    placed: Mapping[str, int] | None = None

    @property
    def simulated(self) -> bool:
        """Whether any part of the rig is simulated."""
        return self.in_bins is not None


class RigRecorder(EpisodeRecorder, Protocol):
    """An episode recorder that samples a rig's bus and camera while it is attached."""

    @property
    def episodes_written(self) -> int: ...  # noqa: D102
    def attach(self, bus: ServoBus, camera: Camera) -> None: ...  # noqa: D102
    def detach(self) -> None: ...  # noqa: D102


def _conveyor_sorter() -> type[Sorter]:
    """The sorter of a belt (:class:`~mearm.task.conveyor.ConveyorSorter`)."""
    from mearm.task.conveyor import ConveyorSorter  # noqa: PLC0415  (a belt's run only)

    return ConveyorSorter


def scene_layout(config: Config, scene: list[SceneObject] | None = None) -> list[dict[str, object]]:
    """The simulated table as run-log entries ``{id, color, x, y}``; empty on a real rig.

    Ids are the ones :class:`~mearm.world.World` gives (``red1``, ``red2``, …).
    """
    if not uses_world(config):
        return []
    world = table_world(config, scene)
    return [{"id": o.id, "color": o.color, "x": o.x_cm, "y": o.y_cm} for o in world.objects]


@contextlib.contextmanager
def open_rig(config: Config, scene: list[SceneObject] | None = None) -> Iterator[Rig]:
    """Open the rig of ``config.simulator`` (:func:`~mearm.backends.open_parts`); close it on exit.

    The servo bus is connected here, with the camera, before anything moves: a serial port
    that cannot be opened (or a board that does not answer) is found as the rig opens, as
    a camera that cannot be opened is, not by the first move of a sort.

    Args:
        config: The whole configuration.
        scene: Objects for the simulated table (default: ``config.task.scene``).

    Raises:
        CameraError: the camera cannot be opened.
        ServoError: the servo bus cannot be connected (e.g. a ``LinkError``).
        ConfigError: ``config`` is not a whole config, or ``scene`` not a list of
            :class:`SceneObject` (:func:`~mearm.backends.require_table`).
    """
    require_table(config, scene, "open_rig")
    model = ArmModel(config.arm)
    with open_parts(config, scene) as parts:
        parts.bus.connect()
        yield Rig(parts.world, parts.camera, parts.bus, model, parts.in_bins, parts.placed)


def run_sort(
    config: Config,
    *,
    scene: list[SceneObject] | None = None,
    log: RunLog | None = None,
    trial: int | None = None,
    seed: int | None = None,
    argv: list[str] | None = None,
    echo: Callable[[str], None] | None = print,
    view_factory: Callable[[Rig], Any] | None = None,
    on_view: Callable[[Any], None] | None = None,
    recorder: RigRecorder | None = None,
    calibrate_first: CalibrateFirst | None = None,
    on_open: Callable[[Rig], None] | None = None,
) -> SortReport:
    """Write the trial's header, open the rig, sort, close everything.

    The config's consistency is checked first (:func:`~mearm.task.check.check_consistency`),
    before any device opens; its notes are the caller's to say (``mearm sort`` says them
    on stderr, apart from the sort's lines). A failure before the sort starts (an
    inconsistent config, a camera or servo that never opens, a recording whose encoder
    cannot start) still leaves a fault and a summary in the log after the header.

    Args:
        config: The whole configuration.
        scene: The simulated table (default: ``config.task.scene``).
        log: Run log, or ``None``.
        trial: Trial number for the log.
        seed: The seed the scene was drawn with, for the header.
        argv: The command line, for the header.
        echo: Called with each line the sort prints (``None``: silent).
        view_factory: Builds a view for the opened rig (``None``: no view).
        on_view: Called with the view after the sort (e.g. to keep it open).
        recorder: Records the sort as a dataset (:class:`mearm.dataset.DatasetRecorder`):
            attached to the rig's bus and camera while the sort runs.
        calibrate_first: Calibrates servos never calibrated before the first pick, where
            ``servo.calibrate_at_start`` asks for it
            (:func:`mearm.maker.camera_calibration.at_start.for_config`).
        on_open: Called with the rig once it is open, before the view and the sort: for
            what is worth saying only of a rig whose camera opened (``mearm sort``'s
            note on servos never calibrated), without opening the camera twice.

    Raises:
        SortAborted: the sort stopped early (the log says why).
        MearmError, KeyboardInterrupt: before the sort started (logged as a fault).
        ConfigError: ``config`` is not a whole config, or ``scene`` not a list of
            :class:`SceneObject`: before anything, the log untouched.
    """
    require_table(config, scene, "run_sort")
    view = None
    started = False
    try:
        if log is not None:
            log.header(config, trial=trial, seed=seed, argv=argv, scene=scene_layout(config, scene))
        # a table laid out replaces the config's own, whose walls are never built: the
        # config is checked without it (the table's own walls are check_scene's)
        check_consistency(config if scene is None else config.with_scene([]))
        if scene is not None:
            # the sorter plans against the table laid out, not the config's own: the
            # twin's bin walls grow with the objects they hold, and so must its model's
            config = config.with_scene(scene)
        with open_rig(config, scene) as rig:
            if on_open is not None:
                on_open(rig)
            if view_factory is not None:
                view = view_factory(rig)
                rig.bus.paced = True  # let the eye follow the arm
            # a belt's objects move: tracked and intercepted (imported for a belt only)
            kind = Sorter if config.belt is None else _conveyor_sorter()
            sorter = kind(
                config, rig.camera, rig.bus, model=rig.model, log=log, view=view, echo=echo,
                trial=trial, in_bins=rig.in_bins, placed=rig.placed, recorder=recorder,
                calibrate_first=calibrate_first,
            )  # fmt: skip
            if recorder is not None:
                # its encoder failing to start (a full /dev/shm) is before the sort, too
                recorder.attach(rig.bus, rig.camera)
            started = True  # from here on the sorter logs its own faults
            try:
                report = sorter.run()
            finally:
                if recorder is not None:
                    recorder.detach()
            if view is not None and on_view is not None:
                on_view(view)
            return report
    except (MearmError, KeyboardInterrupt) as exc:
        reason = str(exc) if isinstance(exc, MearmError) else f"interrupted ({named(exc)})"
        if log is not None and not started:
            with contextlib.suppress(MearmError):  # no header yet: nothing to close
                log.fault(f"before the sort started: {reason}", trial=trial)
                log.summary(trial=trial, ok=False, objects={}, left={})
        elif log is not None and not isinstance(exc, SortAborted):
            # after the sort's own records (e.g. Ctrl-C while closing the view): close the
            # trial if the sort had not yet
            with contextlib.suppress(MearmError):
                log.fault(f"after the sort: {reason}", trial=trial)
                log.summary(trial=trial, ok=False)
        raise
    finally:
        if view is not None:
            view.close()
