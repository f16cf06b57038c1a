"""Sort the objects on the table into their colour bins (mearm sort).

On the real rig (``configs/lab.yaml``) the camera and the Arduino do the work; on the
simulated rig (``configs/sim.yaml``, the default) both are simulated and the table holds
the paper's 12-object layout unless ``--scene`` or ``--random N`` says otherwise (1 to 500
objects, as many as fit where the camera sees and the arm reaches: about 45 on the paper's
table; more is refused, saying how many fit)::

    python -m mearm.sort --config configs/sim.yaml --log run.jsonl [--view [--collision]]

The last line printed is ``sorted N of M objects (…reasons…)``, labelled simulated on a
simulated rig (``sorted 12 of 12 objects (simulated)``, ``… (simulated; 2 out of
reach)``); a run that sorted every object but then stopped on a fault (the arm could not
park) ends ``…; then stopped: not parked: …`` and exits 1. The run log's summary
record holds the same counts, per class and per reason, and the ``motion`` line's figure
as its ``motion_s``. ``--quiet`` prints only the summary: the route statistics, the
motion time, the objects left and why, and that last line (no line per route, no
per-class table). An object counts as sorted only when its place is confirmed
(simulated: the world has it in its bin; real rig: the camera no longer sees it on the
table). With ``--view --collision`` the view also draws, in translucent colours, the
collision model the routes are checked against (the arm's, the bins' and the objects'
shapes; docs/view.md).

``--record DIR`` also writes the run as a LeRobotDataset v3.0, one episode per
pick-and-place (docs/datasets.md); the dataset is written when the run is over, and
named then, before the summary: ``wrote DIR/ (N episodes, F frames)``.

A config with a belt sorts what the belt brings (docs/sorting.md); ``--scene`` and
``--random``, which lay objects on the table, are refused with it.

Exit status: 0 only when every object seen was sorted (in simulation, every object: one
the camera never saw is left too); 1 when the run ended with objects left (out of reach,
failed picks, a camera or servo fault) or stopped on a fault after the last (the arm not
parked); 2 on bad input, found before anything moves (a
camera or servo port that cannot be opened as configured, a board that does not answer
its handshake, a ``vision.work_area_px`` with no pixel in the camera's frames included);
130 on Ctrl-C (the arm is parked first), 143 on SIGTERM and 129 on SIGHUP, taken as
Ctrl-C is. The run log is written per route, so a failure loses nothing written before
it.

A ``vision.work_area_px`` polygon is checked against the camera's frames
(``camera.width_px`` × ``height_px``) before anything else, as ``mearm detect`` checks
it: one that keeps no pixel of them is refused (exit 2); one that keeps under half of
them while lying mostly outside them (taught on a photo of another size) is named in one
line on stderr (``mearm sort: warning: …``, also with ``--quiet``), and the sort goes on.

Where part of the camera's view of the table is out of the arm's reach at a pick height,
one line on stderr says how much before the arm moves (``mearm sort: note: 3% of the
camera's view of the table … is out of the arm's reach …``; not with ``--quiet``): objects
there are reported and left.

On servos that were never calibrated — a real board (``servo.backend`` ``serial`` or
``ssc32``) or the twin with a kit of servos (``twin.kit``), without a
``servo.calibration_file`` — one line on stderr says so before the arm moves and names
the ``mearm calibrate-servos`` command to run (not with ``--quiet``); the sort runs on.
With ``servo.calibrate_at_start: when_uncalibrated`` it first calibrates them by the camera
(:mod:`mearm.maker.camera_calibration.at_start`), prints one line (the fit's residual, the
seconds of arm motion) and sorts with that calibration; ``--save-calibration FILE`` also
writes it. A fit that does not converge stops the sort before its first pick (exit 1).

Each file the sort writes is named on stdout as it lands, also with ``--quiet``:
``wrote PATH`` for ``--save-mjcf PATH`` (before the run) and ``--save-calibration FILE``
(after the calibration's line), each after ``wrote PATH.bak (the old PATH)`` where it
replaces a file (kept first; not an MJCF that already holds the same scene), and ``wrote
DIR/ (N episodes, F frames)`` for ``--record DIR`` (once the run is over and the dataset
written, before the summary). The outcome stays the last line. An output that is the
``--scene`` or ``--config`` file, or the file of another output or of ``--log`` (by any
name), is refused before any work (exit 2): it would replace what the run reads or the
log it is writing.
"""

from __future__ import annotations

import argparse
import gc
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

# The imports below make some 50,000 objects that live as long as the process (pydantic's
# schemas, the arm's and the camera's tables). Collecting them frees nothing: run as a
# program, the sort pauses the collector while they are made and then sets them aside
# (gc.freeze): 50–60 ms of the simulated sort's CPU (docs/benchmarks.md).
_PAUSE_COLLECTOR = __name__ == "__main__" and gc.isenabled()
if _PAUSE_COLLECTOR:
    gc.disable()
try:
    from mearm import interrupts
    from mearm.cli import (
        EXIT_FAILURE,
        EXIT_OK,
        ArgumentParser,
        add_config_argument,
        backup_written,
        check_output_file,
        config_from_args,
        counted,
        echo_line,
        invoked_as,
        plain_int,
        refuse_own_inputs,
        run,
        seed_value,
        write_text_atomic,
    )
    from mearm.config import Config, SceneObject
    from mearm.config.sections import MAX_SCENE_OBJECTS
    from mearm.dataset.arguments import (
        add_record_arguments,
        check_record_arguments,
        close_recorder,
        recorder_from_args,
    )
    from mearm.errors import MearmError
    from mearm.hardware.errors import ServoError
    from mearm.task import Rig, SortAborted, check_scene, load_scene, random_scene, run_sort
    from mearm.task.check import calibration_note, check_consistency
    from mearm.task.report import SortReport, summary_without_table
    from mearm.task.sorter import CalibrateFirst, calibrates_at_start, check_calibrate_at_start
    from mearm.vision.errors import CameraError
    from mearm.vision.work_area import check_work_area  # loaded by the sorter's tracking
finally:
    if _PAUSE_COLLECTOR:
        gc.freeze()
        gc.enable()


if TYPE_CHECKING:
    from mearm.dataset.recorder import DatasetRecorder  # imported with --record only
    from mearm.view import ArmView  # imported with --view only


def add_scene_arguments(parser: ArgumentParser) -> None:
    """``--scene FILE`` / ``--random N --seed S`` for the simulated table."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument(
        "--scene",
        type=Path,
        help="simulated table: a YAML list of {color, x, y} [cm] (color: a class name)",
    )
    group.add_argument(
        "--random",
        type=plain_int,
        metavar="N",
        help=(
            f"simulated table: N random objects (1 to {MAX_SCENE_OBJECTS}, as many as fit "
            "where the camera sees and the arm reaches: more is refused, saying how many fit)"
        ),
    )
    parser.add_argument("--seed", type=seed_value, help="seed for --random (default 0)")


def scene_from_args(args: object, config: Config) -> list[SceneObject] | None:
    """The scene the arguments ask for, or ``None`` for the config's own.

    On a simulated table the scene (the config's own included) is checked first
    (:func:`~mearm.task.scene.check_scene`): an object the camera could not see whole
    would be left out of the count.
    """
    scene_path = getattr(args, "scene", None)
    n = getattr(args, "random", None)
    if (scene_path is not None or n is not None) and config.camera.kind != "sim":
        raise MearmError(
            "--scene and --random lay out the simulated table; this config's camera is "
            f"'{config.camera.kind}', not 'sim'"
        )
    if (scene_path is not None or n is not None) and config.belt is not None:
        # the conveyor sorter takes only what lies on the belt: the table's would be left
        raise MearmError(
            "--scene and --random lay out objects on the table; a config with a belt sorts "
            "only what the belt brings (belt.arrivals): drop them, or use a config without "
            "a belt"
        )
    scene = None
    if scene_path is not None:
        scene = load_scene(scene_path, config.task.class_names)
    elif n is not None:  # in 1..MAX_SCENE_OBJECTS (_check_arguments)
        scene = random_scene(config, n, seed=getattr(args, "seed", None) or 0)
    if config.camera.kind == "sim":
        source = str(scene_path) if scene_path is not None else "--random" if n else "task.scene"
        check_scene(
            config,
            config.task.scene if scene is None else scene,
            source,
            work_area=scene is not None,  # laid out for this run: where it is looked for
        )
    return scene


def _hold(url: str) -> None:
    """Keep serving the view until Ctrl-C.

    Said on stderr: the sort's outcome, printed before, stays stdout's last line.
    """
    try:  # (a Ctrl-C as soon as the line is read closes the view as well)
        print(f"meshcat view stays open at {url}; Ctrl-C to close", file=sys.stderr, flush=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        interrupts.answered()  # the Ctrl-C it waits for: the sort's outcome is the exit


def _parser() -> ArgumentParser:
    """The command line of :func:`main`."""
    parser = ArgumentParser(
        prog=invoked_as("python -m mearm.sort"), description=__doc__.splitlines()[0]
    )
    add_config_argument(parser)
    add_scene_arguments(parser)
    parser.add_argument("--log", type=Path, help="append a JSON-lines run log here")
    parser.add_argument("--view", action="store_true", help="show the run in meshcat")
    parser.add_argument(
        "--hold", action="store_true", help="with --view: keep the view open after the run (Ctrl-C)"
    )
    parser.add_argument(
        "--collision",
        action="store_true",
        help="with --view: also draw the collision model the sort plans with (the arm's, "
        "the bins' and the objects' shapes, translucent)",
    )
    parser.add_argument(
        "--quiet",
        action="store_true",
        help="print only the summary: the route statistics, the motion time, the objects "
        "left and why, and the last line (sorted N of M objects); no line per route, no "
        "per-class table",
    )
    parser.add_argument(
        "--save-mjcf",
        type=Path,
        metavar="PATH",
        help="also write the whole scene (arm, table, bins, objects, camera) as one "
        "self-contained MJCF for MuJoCo's own viewer",
    )
    parser.add_argument(
        "--save-calibration",
        type=Path,
        metavar="FILE",
        help="with servo.calibrate_at_start: when_uncalibrated, also write the servos' "
        "calibration the sort makes at its start, as mearm calibrate-servos does (an "
        "existing calibration is kept as FILE.bak)",
    )
    add_record_arguments(parser)
    return parser


def _check_arguments(parser: ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 (``parser.error``) on options that do not go together or a bad output path."""
    check_record_arguments(parser, args)
    if args.random is not None and not 1 <= args.random <= MAX_SCENE_OBJECTS:
        # none would sort nothing and call it done (exit 0)
        parser.error(
            f"--random N lays N objects on the table: N must be 1 to {MAX_SCENE_OBJECTS}, "
            f"got {args.random}"
        )
    if args.seed is not None and args.random is None:
        parser.error("--seed draws the scene of --random N: use it with --random")
    args.seed = 0 if args.seed is None else args.seed
    if args.hold and not args.view:
        parser.error("--hold keeps the view open: use it with --view")
    if args.collision and not args.view:
        parser.error("--collision draws the collision model in the view: use it with --view")
    if args.save_mjcf is not None:
        check_output_file(args.save_mjcf, "--save-mjcf")
    if args.save_calibration is not None:
        check_output_file(args.save_calibration, "--save-calibration")
    _refuse_shared_files(args)


def _refuse_shared_files(args: argparse.Namespace) -> None:
    """Refuse, before any work, an output that is an input or another output (by any name).

    ``--save-mjcf`` over the ``--scene`` or ``--config`` file would replace what the run
    reads; over the ``--log`` file (or ``--save-calibration`` over it) it would replace
    the log the run is writing, whose records would then go to a file no longer there.

    Raises:
        MearmError: two of the run's files are one.
    """
    outputs = [("--save-mjcf", args.save_mjcf), ("--save-calibration", args.save_calibration)]
    if all(path is None for _, path in outputs):
        return  # the log alone: RunLog refuses a file that is not a run log
    from mearm.config.files import resolve_config_path  # noqa: PLC0415  (an output given)
    from mearm.fileio import file_identity  # noqa: PLC0415

    config_file = resolve_config_path(args.config) if args.config is not None else None
    refuse_own_inputs(outputs, [("--scene", args.scene), ("--config", config_file)])
    named = [(flag, path) for flag, path in [*outputs, ("--log", args.log)] if path is not None]
    for i, (flag, path) in enumerate(named):
        for other_flag, other in named[i + 1 :]:
            ids = file_identity(path), file_identity(other)
            # files not made yet are one where their paths resolve to one
            same = ids[0] == ids[1] if None not in ids else path.resolve() == other.resolve()
            if same:
                raise MearmError(
                    f"{flag} {path}: is also the {other_flag} file {other}: give each its own file"
                )


def _check_work_area(config: Config) -> None:
    """Check ``vision.work_area_px`` against the camera's frames, before anything moves.

    A polygon taught on a photo of another size may keep none of the camera's frame
    (nothing could ever be found: refused) or only a corner of it (the objects elsewhere
    are never seen: one warning line on stderr, and the sort goes on), as ``mearm
    detect`` says it (:func:`~mearm.vision.work_area.check_work_area`).

    Raises:
        ConfigError: no pixel of the camera's frame lies in the polygon.
    """
    polygon = config.vision.work_area_px
    if polygon is None:
        return
    size = (config.camera.width_px, config.camera.height_px)
    warning = check_work_area(polygon, size, "the camera")
    if warning is not None:
        print(f"mearm sort: warning: {warning}", file=sys.stderr, flush=True)


def _calibrate_first(config: Config, save: Path | None) -> CalibrateFirst | None:
    """What calibrates the servos at the start, if the config asks for it (exit 2: bad input).

    Raises:
        MearmError: a rig without what it needs, ``--save-calibration`` on a config that
            makes no calibration, or over a file that is not a servo calibration.
    """
    check_calibrate_at_start(config)
    if save is not None and not calibrates_at_start(config):
        raise MearmError(
            "--save-calibration writes the calibration a sort makes at its start "
            "(servo.calibrate_at_start: when_uncalibrated, no servo.calibration_file): "
            "this config makes none"
        )
    if not calibrates_at_start(config):
        return None
    from mearm.config.servo_file import check_replace  # noqa: PLC0415  (calibrating only)
    from mearm.maker.camera_calibration.at_start import calibrator  # noqa: PLC0415

    if save is not None:
        check_replace(save, force="", elsewhere="another --save-calibration")
    return calibrator(save)


def _view_factory(config: Config, *, collision: bool) -> Callable[[Rig], object]:
    """What opens the meshcat view of a rig (and its collision model with ``collision``)."""

    def make_view(rig: Rig) -> object:
        from mearm.sim.table_collision import collision_model
        from mearm.view import ArmView

        view = ArmView(rig.model, config)
        try:
            if collision:
                # built as the sorter builds its own (which it keeps to itself); the view
                # keeps this one in step with what it draws: the objects seen on the
                # table, the jaws' opening, the arm's joints
                model = collision_model(config, rig.model, clearance_cm=config.task.clearance_cm)
                view.show_collision(model, track_world=True)
        except BaseException:
            view.close()
            raise
        echo_line(f"meshcat view: {view.url}", flush=True)
        return view

    return make_view


def main(argv: Sequence[str] | None = None) -> int:
    """Run the sort; see the module docstring. SIGTERM and SIGHUP stop it as Ctrl-C does."""
    with interrupts.stop_signals_as_ctrl_c():
        return _sort(argv)


def _sort(argv: Sequence[str] | None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    _check_arguments(parser, args)
    config = config_from_args(args)
    # a table laid out by --scene or --random replaces the config's own, whose bins'
    # walls (built to hold its objects stacked) the sort never builds: the config is
    # checked without it, and the table laid out against every bin's walls as it grows
    # them (check_scene, random_scene). Checked with its own table, sim_paper_arm with
    # task.classes.red.height_cm=2.18 refused --random 1 for the 10.9 cm walls of the
    # four reds of a table it was not going to sort
    laid_out = args.scene is not None or args.random is not None
    checked = config.with_scene([]) if laid_out else config
    # before the scene, the log or any output (the view's reach surveyed for its note)
    consistency = check_consistency(checked, notes=not args.quiet)
    _check_work_area(config)
    calibrate_first = _calibrate_first(config, args.save_calibration)
    scene = scene_from_args(args, checked)
    mjcf = _scene_mjcf(config, scene) if args.save_mjcf is not None else None
    # its directory checked before any motion; a --scene table kept for a replay
    recorder = recorder_from_args(args, config, scene)
    lines: list[str] = []
    # the summary waits for the dataset's wrote line (the dataset is written as the
    # recorder closes, after the run): quiet, it is printed at the end anyway
    held = _SummaryHeld()
    echo = _quiet_echo(lines) if args.quiet else held if recorder is not None else echo_line

    # the view draws the table laid out, its bins' walls as the twin and the planner have them
    make_view = _view_factory(
        config if scene is None else config.with_scene(scene), collision=args.collision
    )

    if args.log:
        from mearm.runlog import RunLog  # noqa: PLC0415  (only a run that keeps a log)

        log = RunLog(args.log, sort_run=True)
    else:
        log = None
    if log is not None:
        echo_line(f"run log: {args.log}", flush=True)
    calibration = calibration_note(config, _config_args(args))
    if args.quiet and calibration is not None and not calibration.startswith("warning:"):
        calibration = None  # a note; a warning is said also with --quiet
    # the config's notes (servos never calibrated, with the command that calibrates them;
    # a camera's view partly out of the arm's reach) said once the rig is open, before the
    # arm moves: a camera that is not there ends the sort before it starts (logged, exit 2)
    # with one line on stderr, not the notes too; and a real camera is opened once (some
    # webcams are slow to, or fail to, reopen)
    # an arm whose lengths look like mm or angles like radians is valid but not the arm
    # that was built: said also with --quiet, as the work area's warning is
    warnings = [f"warning: {w}" for w in consistency.warnings]
    notes = [*warnings, *filter(None, [calibration]), *([] if args.quiet else consistency.notes)]
    report: SortReport | None = None
    aborted: SortAborted | None = None  # why the sort stopped, said on stderr
    outcome = _Outcome(recorder, args, held, lines, config)

    def hold(view: ArmView) -> None:
        """``--hold``: the outcome first, then the view kept open until Ctrl-C."""
        outcome.say(sorted_=True)
        _hold(view.url)

    try:
        if mjcf is not None:  # the last of the inputs accepted (the log's lock included)
            _save_mjcf(args.save_mjcf, mjcf)
        report = run_sort(
            config,
            scene=scene,
            log=log,
            seed=args.seed if args.random is not None else None,
            argv=list(sys.argv[1:] if argv is None else argv),
            echo=echo,
            view_factory=make_view if args.view else None,
            on_view=hold if args.hold else None,
            recorder=recorder,
            calibrate_first=calibrate_first,
            on_open=_said_on_open(notes),
        )
    except SortAborted as exc:
        aborted = exc
    except (CameraError, ServoError) as exc:
        # raised only before the sort started (inside it, a fault is SortAborted): a
        # camera or link that cannot be opened as configured, found before any motion:
        # bad input, said by run() as every command's error line is (one line, exit 2)
        from mearm.task.armcheck import RigNotOpened  # noqa: PLC0415  (did not open)

        raise RigNotOpened(str(exc)) from exc
    except KeyboardInterrupt as exc:
        # outside the sort's own loop (opening the rig or the view, closing them): the
        # arm is at home or was parked by the sorter
        print(f"mearm sort: interrupted ({interrupts.named(exc)})", file=sys.stderr)
        return interrupts.exit_status()
    finally:
        if log is not None:
            log.close()
        outcome.say(
            sorted_=report is not None or aborted is not None,
            stopped="" if aborted is None else aborted.reason,
        )
    if aborted is not None:
        print(f"mearm sort: stopped: {aborted.reason}", file=sys.stderr)
        return interrupts.exit_status() if aborted.interrupted else EXIT_FAILURE
    assert report is not None  # run_sort returned
    if not report.complete:
        print(f"mearm sort: {report.line()}", file=sys.stderr)
        return EXIT_FAILURE
    return EXIT_OK


class _Outcome:
    """The sort's outputs once it has run: the dataset named, then the summary.

    The outcome is the last line. Said once: before a ``--hold``'s wait, or as the
    command ends.
    """

    def __init__(
        self,
        recorder: DatasetRecorder | None,
        args: argparse.Namespace,
        held: _SummaryHeld,
        lines: list[str],
        config: Config,
    ) -> None:
        self._recorder, self._args, self._held = recorder, args, held
        self._lines, self._config = lines, config
        self._said = False

    def say(self, *, sorted_: bool, stopped: str = "") -> None:
        """Close the recorder, name its dataset and print the summary held back.

        Args:
            sorted_: Whether the sort ran (``--quiet``: its summary is printed).
            stopped: Why the sort stopped, if it did (said already: not said again).
        """
        if self._said:
            return
        self._said = True
        try:
            close_recorder(self._recorder, self._args.record, said=stopped)
            _say_dataset_written(self._recorder, self._args.record)
        finally:  # the summary, its outcome last, once the dataset is named
            self._held.flush()
            if self._args.quiet and sorted_:
                _print_summary(self._lines, self._config)


class _SummaryHeld:
    """Echoes a sort's lines as they come, but holds its summary back until :meth:`flush`.

    A recording's dataset is written as the recorder closes, after the sort's summary:
    the ``wrote DIR/`` line that names it comes before the summary, so the outcome stays
    the last line. The summary opens with a blank line
    (:meth:`~mearm.task.report.Reporter.summary`).
    """

    def __init__(self) -> None:
        self._summary: list[str] = []

    def __call__(self, line: str) -> None:
        if self._summary or line == "":
            self._summary.append(line)
        else:
            echo_line(line)

    def flush(self) -> None:
        """Print the summary held back (nothing if there is none)."""
        for line in self._summary:
            echo_line(line)
        self._summary.clear()


def _say_dataset_written(recorder: DatasetRecorder | None, where: Path) -> None:
    """``wrote DIR/ (N episodes, F frames)`` once the recorder is closed, if it wrote any.

    As ``mearm experiment`` names its dataset; with ``--resume``, the episodes this run
    added, then what the dataset holds in all (``; it holds M episodes, G frames``). A
    recording that wrote no episode leaves no folder it made (nothing to name).
    """
    if recorder is None or not recorder.episodes_written:
        return
    n = recorder.episodes_written
    echo_line(
        f"wrote {where}/ ({counted(n, 'episode')}, {recorder.frames_written} frames"
        f"{recorder.held_note()})"
    )


def _quiet_echo(lines: list[str]) -> Callable[[str], None]:
    """What ``--quiet`` echoes the run's lines with: each kept in ``lines``, or printed.

    A ``wrote PATH`` line (``--save-calibration``) is printed at once, the others kept for
    the summary: every file a command writes is named on stdout, and the summary keeps
    only its own lines.
    """

    def echo(line: str) -> None:
        if line.startswith("wrote "):
            echo_line(line)
        else:
            lines.append(line)

    return echo


def _said_on_open(notes: Sequence[str]) -> Callable[[Rig], None] | None:
    """What prints each of ``notes`` as one line on stderr once the rig is open.

    Notes are stderr's, as warnings and errors are (docs/getting-started.md: stdout holds
    the results): ``mearm sort: note: …``. ``None`` when there is nothing to say.
    """
    if not notes:
        return None
    text = "".join(f"mearm sort: {note}\n" for note in notes)
    return lambda rig: print(text, end="", file=sys.stderr, flush=True)


def _config_args(args: object) -> list[str]:
    """The ``--config`` and ``--set`` arguments the config came from, as typed."""
    config = getattr(args, "config", None)
    out = [] if config is None else ["--config", str(config)]
    for item in getattr(args, "set", []):
        out += ["--set", item]
    return out


def _scene_mjcf(config: Config, scene: list[SceneObject] | None) -> str:
    """The MJCF of the scene the sort will see (written once every input is accepted)."""
    from mearm.sim.twin.mjcf import generate_mjcf

    return generate_mjcf(config if scene is None else config.with_scene(scene))


def _save_mjcf(path: Path, mjcf: str) -> None:
    """Write ``--save-mjcf PATH``, an existing file kept as ``PATH.bak`` first.

    A second run, or a name shared with the user's own model, must not lose what was
    there. Each file is named on stdout as it lands, the backup first; a file that already
    holds these bytes gets no backup (it loses nothing, and an older ``.bak`` that still
    differs is kept).

    Raises:
        MearmError: the backup or the file cannot be written (the old file stays as it was).
    """
    from mearm.fileio import keep_backup  # noqa: PLC0415  (--save-mjcf only)

    try:
        backup = keep_backup(path, mjcf)
    except OSError as exc:
        raise MearmError(f"cannot keep {path} as {path}.bak: {exc.strerror or exc}") from None
    if backup is not None:  # (said as the sort's lines are: a reader gone stops nothing)
        echo_line(backup_written(path, backup), flush=True)
    write_text_atomic(path, mjcf)
    echo_line(f"wrote {path}", flush=True)


def _print_summary(lines: list[str], config: Config) -> None:
    """What ``--quiet`` prints of the sort's lines: the summary without the per-class table."""
    print("\n".join(summary_without_table(lines, len(config.task.classes))))


if __name__ == "__main__":
    run(main)
