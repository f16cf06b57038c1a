"""Run repeated sorting trials into one run log, as in the paper's experiments.

Each trial sorts a new layout of as many objects of each class as the config's own table
holds (the paper's 4 of each on ``sim.yaml``; 4 of each when it holds none) at least 1 cm apart
(or the same ``--scene`` every time) and appends its records, under one header per trial,
to the run log; ``python -m mearm.analyze`` reads it back::

    python -m mearm.experiment --config configs/sim.yaml --trials 100 --seed 0 --log trials.jsonl

On a real rig (camera not simulated) each trial waits for you to lay the objects out and
press Enter. That needs a terminal: without one (standard input not a terminal, or
closed) the run stops with exit 2 before anything moves; ``--yes`` starts every trial
without asking. Simulated trials draw the layout, the servo noise and the camera noise
from the trial's own seed, so any trial can be rerun alone.

**Workers.** ``--jobs N`` runs simulated trials in N worker processes; ``--scheduler
ADDRESS`` on a Dask cluster (``tcp://host:port`` of a running scheduler, or ``local`` for
a LocalCluster of ``--jobs`` processes; the ``cluster`` extra). Either way each trial's
records come back as data and are appended in trial order: the log is the serial run's.

**Resuming.** The log is only ever appended to. Running again with the same ``--log``
continues the experiment: every trial already in it must have been written by this same
run — trial k's header has the seed, config and layout that ``--config``, ``--set``,
``--seed`` and ``--scene`` give trial k — else the run refuses with exit 2 and names the
first difference. It then starts at the trial after the last *finished* one (a trial
with its summary, which includes one that stopped early on a fault of the rig and said
so). A trial cut off before its summary (the process was killed), stopped by Ctrl-C
(:attr:`~mearm.runlog.Trial.interrupted`) or by its recording, a file of the dataset not
written (:attr:`~mearm.runlog.Trial.recording_stopped`), is run again under the same
number and seed:
its partial records stay in the log, and ``mearm analyze`` leaves them out because the
same trial comes back finished later (:meth:`~mearm.runlog.RunLogContents.latest`). A
torn last line (killed mid-write) is moved into a side file ``<log>.torn-<offset>``
first (:mod:`mearm.runlog.repair`). A log damaged anywhere else is not resumed. When the
log already holds the trials asked for, the run says so and prints their totals. A
dataset (``--record --resume``) that holds this experiment's trials recorded per pick
or per scene is recorded into the same way: another ``--record-per`` is refused, exit 2
(:meth:`~mearm.dataset.recorder.DatasetRecorder.check_trials_per`).

**Exit status.** 0 when every object of every trial in the log was sorted and no trial
stopped early; 1 when objects were left or a trial stopped on a fault (the totals line
``sorted N of M objects over K trials (…reasons…)`` says why, and is repeated on
stderr), whether in this run or in the trials it resumed; 1 too, and no trial after it,
when a trial on a servo board (``serial``, ``ssc32``) stopped on a fault of its servos, the
line naming the fault (:func:`~mearm.experiment.trials.run_trials`); 130 on Ctrl-C; 2 on bad input,
a rig that does not open included: a servo port that cannot be opened, a board that does
not answer its handshake or a camera that cannot be opened is found before the first
trial, with nothing written (:func:`~mearm.experiment.trials.check_rig_opens`).
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from contextlib import nullcontext
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mearm import interrupts
from mearm.cli import (
    EXIT_FAILURE,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    counted,
    invoked_as,
    plain_int,
    seed_value,
    worker_count,
)
from mearm.config import Config, SceneObject
from mearm.config.files import unit_warning
from mearm.dataset.arguments import (
    add_record_arguments,
    check_record_arguments,
    close_recorder,
    kept_config,
    recorder_from_args,
)
from mearm.errors import MearmError
from mearm.experiment.cluster import CLUSTER_EXTRA
from mearm.experiment.errors import TrialFailed
from mearm.experiment.ordered_log import _append_in_order, open_workers
from mearm.experiment.pool import Workers
from mearm.experiment.resume import Resume, ready_to_append, resume_point
from mearm.experiment.trials import (
    Recording,
    check_rig_opens,
    plan_trial,
    run_trials,
    trial_seed,
)
from mearm.hardware.errors import ServoError
from mearm.runlog import LogLock, RunLog, read_runlog
from mearm.runlog.errors import RunLogError
from mearm.task import SortAborted, check_scene, load_scene
from mearm.task.check import check_consistency
from mearm.task.report import Outcome
from mearm.vision.errors import CameraError

if TYPE_CHECKING:
    from mearm.dataset.reading import RecordedScene
    from mearm.dataset.recorder import DatasetRecorder

#: Why a real rig's run cannot start without a terminal (and how to run it anyway).
NEEDS_TERMINAL = (
    "needs a terminal to confirm each layout (a real rig waits for Enter before every "
    "trial); pass --yes to start every trial without asking"
)


def _has_terminal() -> bool:
    stdin = sys.stdin
    try:
        return stdin is not None and stdin.isatty()
    except (ValueError, OSError):  # a closed stream
        return False


def terminal_prompt(trials: int) -> Callable[[int], None]:
    """The wait before each trial of a real rig: Enter on the terminal.

    Raises:
        MearmError: Standard input is not a terminal (checked now, before anything
            moves), or it ends at a prompt (raised by the wait).
    """
    if not _has_terminal():
        raise MearmError(NEEDS_TERMINAL)

    def wait(k: int) -> None:
        try:
            input(f"trial {k + 1}/{trials}: lay out the objects, then press Enter ")
        except EOFError:
            raise MearmError(
                f"input ended at the prompt of trial {k}: {NEEDS_TERMINAL}; the same --log "
                f"resumes at trial {k}"
            ) from None

    return wait


def main(argv: Sequence[str] | None = None) -> int:
    """Run the trials; see the module docstring. SIGTERM and SIGHUP stop it as Ctrl-C does."""
    with interrupts.stop_signals_as_ctrl_c():
        return _experiment(argv)


def _experiment(argv: Sequence[str] | None) -> int:
    args = _arguments(argv)
    config = config_from_args(args)
    if config.belt is not None:  # each trial lays a table the conveyor sorter would ignore
        raise MearmError(
            "experiment lays random objects on the table each trial; a config with a belt "
            "sorts only what the belt brings: run repeated belt sorts with mearm "
            "conveyor-sweep, or one with mearm sort"
        )
    check_consistency(config)  # before the scene, the log or any output: the config first
    scene = _scene(args, config)
    wait = None
    if config.camera.kind != "sim" and not args.yes:
        wait = terminal_prompt(args.trials)

    # one writer per log: taken before the log is read for resuming, so no other run
    # appends between that reading and this run's first record (a new log: RunLog's own)
    held = LogLock(args.log) if args.log.is_file() else None
    try:
        return _resume(args, config, scene, wait, held)
    finally:
        if held is not None:
            held.release()


def _parser() -> ArgumentParser:
    parser = ArgumentParser(
        prog=invoked_as("python -m mearm.experiment"), description=__doc__.splitlines()[0]
    )
    add_config_argument(parser)
    parser.add_argument(
        "--trials", type=plain_int, default=100, help="number of trials in all (default 100)"
    )
    parser.add_argument("--seed", type=seed_value, default=0, help="base seed (default 0)")
    parser.add_argument(
        "--log",
        type=Path,
        required=True,
        help="JSON-lines log; one that holds trials of this run is continued",
    )
    parser.add_argument("--scene", type=Path, help="use this layout in every trial")
    parser.add_argument(
        "--yes",
        action="store_true",
        help="real rig: start every trial without waiting for Enter (needed without a "
        "terminal; lay the objects out beforehand)",
    )
    parser.add_argument(
        "--jobs",
        type=worker_count,
        default=None,
        help="simulated trials run at once, in worker processes (default 1; this machine "
        f"has {os.cpu_count()} CPUs), or the workers of --scheduler local; the log is the "
        "same, in trial order",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run the simulated trials on a Dask cluster: a running scheduler's address "
        "(tcp://host:port) or 'local' (a LocalCluster of --jobs processes, default 2); the "
        f"log is the same, in trial order (needs {CLUSTER_EXTRA})",
    )
    add_record_arguments(parser)
    return parser


def _arguments(argv: Sequence[str] | None) -> Any:
    """The parsed arguments, checked against each other (``--jobs`` set)."""
    parser = _parser()
    args = parser.parse_args(argv)
    check_record_arguments(parser, args)
    if args.record is not None and args.scheduler is not None:
        parser.error("--record writes the dataset here: with --jobs, not with --scheduler")
    if args.trials < 1:
        parser.error(f"--trials must be ≥ 1, got {args.trials}")
    if args.scheduler not in (None, "local") and args.jobs is not None:
        parser.error(
            f"--jobs sets the workers of --scheduler local; the cluster at {args.scheduler} "
            "has its own workers"
        )
    if args.jobs is None:
        args.jobs = 2 if args.scheduler == "local" else 1
    return args


def _scene(args: Any, config: Config) -> list[SceneObject] | None:
    """The ``--scene`` layout (checked), or ``None``.

    Raises:
        MearmError: ``--scene``, ``--scheduler`` or ``--jobs`` > 1 on a real rig (its camera
            not ``sim``: it sorts one trial at a time).
    """
    scene = load_scene(args.scene, config.task.class_names) if args.scene else None
    if scene is not None and config.camera.kind != "sim":
        raise MearmError("--scene lays out the simulated table; this config's camera is not 'sim'")
    if scene is not None:  # (without it, each trial draws its own, inside the work area too)
        check_scene(config, scene, str(args.scene), work_area=True)
    if args.scheduler is not None and config.camera.kind != "sim":
        raise MearmError(
            "--scheduler runs simulated trials on a cluster; this config's camera is not "
            "'sim' (a real rig sorts one trial at a time, here)"
        )
    if args.jobs > 1 and config.camera.kind != "sim":
        raise MearmError(
            f"--jobs {args.jobs} runs simulated trials at once; this config's camera is not "
            "'sim' (a real rig sorts one trial at a time)"
        )
    return scene


def _resume(
    args: Any,
    config: Config,
    scene: list[SceneObject] | None,
    wait: Callable[[int], None] | None,
    held: LogLock | None,
) -> int:
    """Where the log leaves off, the workers, then the run (:func:`main`'s second half)."""
    resume = resume_point(args.log, config, args.seed, scene)
    if resume.done >= args.trials:
        more = (
            f"; the totals are of the first {args.trials} (mearm analyze reads them all)"
            if resume.done > args.trials
            else ""
        )
        print(
            f"{args.log} already holds {counted(resume.done, 'complete trial')} "
            f"(--trials {args.trials}): nothing to run{more}"
        )
        return _verdict(args.log, args.trials)
    # before any trial is written: a rig that does not open raises RigNotOpened, bad input
    # said by run() (one line, exit 2), the log as it was
    check_rig_opens(config, args.seed, resume.done, scene)
    recorder = recorder_from_args(args, config)  # its directory checked before any trial
    written = _Written(args.log, recorder, args.record)
    try:
        if recorder is not None:  # its trials as the dataset holds them: per pick or scene
            trials = {trial_seed(args.seed, k): k for k in range(args.trials)}
            recorder.check_trials_per(trials)
            recorder.check_trials_scenes(
                trials, _scene_of(recorder, config, args.seed, scene, trials)
            )
        # Workers first: a scheduler that cannot be used leaves the log as it was.
        parallel = args.jobs > 1 or args.scheduler is not None
        jobs = min(args.jobs, args.trials - resume.done)
        with (
            open_workers(config, args.seed, scene, jobs, args.scheduler, _recording(args))
            if parallel
            else nullcontext()
        ) as workers:
            stopped, failed = _run(
                args, config, scene, resume, wait, workers, written, recorder, held
            )
    finally:
        try:
            close_recorder(recorder, args.record)
        finally:
            written.say()  # what is in place, stopped or not, before the totals line
    if stopped is not None:
        return stopped
    return _verdict(args.log, args.trials, failed=failed)


def _scene_of(
    recorder: DatasetRecorder,
    config: Config,
    seed: int,
    scene: list[SceneObject] | None,
    trials: dict[int, int],
) -> Callable[[int], RecordedScene | None]:
    """The scene the trial of a seed records (as :meth:`EpisodeSampler.start_trial` keeps it)."""
    from mearm.dataset.reading import RecordedScene  # noqa: PLC0415  (a recorded run's)

    def scene_of(trial: int) -> RecordedScene | None:
        layout = plan_trial(config, seed, trials[trial], scene).layout
        if recorder.kept_config is None or layout is None:
            return None
        return RecordedScene.laid(layout, *recorder.kept_config, noise_seed=trial)

    return scene_of


class _Written:
    """The files of a run, named in ``wrote`` lines once it is over (if it wrote them).

    Every file a command writes is named on stdout; a run stopped by Ctrl-C or a failure
    names what it wrote too, before its line on stderr. A log the run did not append to
    (it stopped before its first record) is not named.
    """

    def __init__(self, log: Path, recorder: DatasetRecorder | None, record: Path | None):
        self.log, self.recorder, self.record = log, recorder, record
        self._size = _size(log)

    def opened(self, held: LogLock | None) -> None:
        """Note the log's size once this run holds its lock (the run appends from here).

        ``held`` is ``None`` when the log did not exist as the run started: read as empty,
        it was locked only now, when this run opened it. Another run that wrote it in the
        meantime (a ``--scheduler local`` takes seconds to start) has ended, so the lock
        did not stop it; appending now would run its trials a second time into one file.

        Raises:
            RunLogError: Another run wrote the log after this one read it as empty; it is
                left as that run left it (the same command resumes it).
        """
        self._size = _size(self.log)
        if held is None and self._size:
            raise RunLogError(
                self.log,
                "was written by another run while this one started (there was no log when "
                "this run read it): nothing appended; run the same command again to resume "
                "it, or give this run another --log",
            )

    def say(self) -> None:
        """Print a ``wrote`` line for the log and the dataset, each if it was written."""
        if _size(self.log) != self._size:
            print(f"wrote {self.log}", flush=True)
        recorder = self.recorder
        if recorder is not None and recorder.episodes_written:
            episodes = counted(recorder.episodes_written, "episode")
            frames = counted(recorder.frames_written, "frame")
            print(f"wrote {self.record}/ ({episodes}, {frames}{recorder.held_note()})", flush=True)


def _size(path: Path) -> int | None:
    """The size of file ``path`` [bytes], ``None`` if there is none."""
    try:
        return path.stat().st_size
    except OSError:
        return None


def _say_resuming(log: Path, resume: Resume, trials: int) -> None:
    """The ``resuming LOG: …`` line, when the log holds trials of this run (or attempts)."""
    if not (resume.done or resume.cut_off or resume.interrupted or resume.recording_stopped):
        return
    why = " and ".join(
        w
        for w, n in (
            ("interrupted", resume.interrupted),  # (the log says by what)
            ("stopped by its recording (a file not written)", resume.recording_stopped),
            ("cut off", resume.cut_off),
        )
        if n
    )
    again = f"; trial {resume.done} again, it was {why}" if why else ""
    print(
        f"resuming {log}: {counted(resume.done, 'complete trial')} there, running trials "
        f"{resume.done}..{trials - 1}{again}"
    )


def _run(
    args: Any,
    config: Config,
    scene: list[SceneObject] | None,
    resume: Resume,
    wait: Callable[[int], None] | None,
    workers: Workers | None,
    written: _Written,
    recorder: DatasetRecorder | None = None,
    held: LogLock | None = None,
) -> tuple[int | None, bool]:
    """The run of :func:`main` once its input is checked (and its workers are ready).

    Returns:
        The exit status of a run that stopped (Ctrl-C, a failure), else ``None``: the
        totals line follows once the dataset is closed (:func:`_verdict`); and whether a
        trial of this run stopped early.
    """
    _say_resuming(args.log, resume, args.trials)  # every input accepted
    warning = unit_warning(config)  # lengths like mm, angles like radians: not the arm built
    if warning is not None:
        print(f"{_prog()}: warning: {warning}", file=sys.stderr, flush=True)
    set_aside = ready_to_append(args.log, resume)
    if set_aside is not None:
        print(
            f"wrote {set_aside} (the torn last line of {args.log}, killed mid-write: its "
            f"{len(resume.torn.data) if resume.torn else 0} bytes moved there)",
            flush=True,
        )

    from tqdm import tqdm

    t0 = time.perf_counter()
    with (
        RunLog(args.log, lock=held) as log,
        tqdm(
            total=args.trials, initial=resume.done, unit="trial", file=sys.stderr, disable=None
        ) as bar,
    ):
        written.opened(held)
        try:
            if workers is None:
                outcomes = run_trials(
                    config,
                    args.trials,
                    args.seed,
                    log,
                    scene=scene,
                    start=resume.done,
                    wait_for_user=wait,
                    progress=lambda done: _step(bar, recorder),
                    recorder=recorder,
                )
            else:
                numbers = range(resume.done, args.trials)
                outcomes = _append_in_order(
                    workers, numbers, args.log, lambda done: _step(bar, recorder), recorder
                )
        except SortAborted as exc:
            if not exc.interrupted and recorder is not None and recorder.failure is not None:
                raise recorder.failure from None  # one line, exit 1 (the log has the trial)
            print(f"{_prog()}: stopped: {exc.reason}{_left(args, config, scene)}", file=sys.stderr)
            return interrupts.exit_status(), False
        except TrialFailed as exc:  # the log holds the trial: the same command goes on
            print(f"{_prog()}: stopped: {exc}{_left(args, config, scene)}", file=sys.stderr)
            return EXIT_FAILURE, False
        except (CameraError, ServoError) as exc:
            print(f"{_prog()}: {exc}", file=sys.stderr)
            return EXIT_FAILURE, False
        except KeyboardInterrupt as exc:  # between two trials' sorts (none was moving)
            why = f"interrupted ({interrupts.named(exc)}) between trials"
            print(f"{_prog()}: stopped: {why}{_left(args, config, scene)}", file=sys.stderr)
            return interrupts.exit_status(), False
    wall = time.perf_counter() - t0
    failed = [(k, r) for k, r in outcomes.items() if r is not None]
    where = "1 process" if workers is None else f"{workers.count} {workers.where}"
    print(
        f"{counted(len(outcomes), 'trial')} written to {args.log} in {wall:.0f} s "
        f"({60 * len(outcomes) / wall:.1f} trials/min, {where}); {len(failed)} stopped early"
    )
    for k, reason in failed:
        print(f"  trial {k}: {reason}")
    analyze = invoked_as("python -m mearm.analyze", "analyze")
    print(f"analyse: {analyze} {args.log} --out {_free_report_folder()}/")
    return None, bool(failed)


def _free_report_folder() -> str:
    """The first of ``report``, ``report-2``, ``report-3`` … that analyze writes into.

    ``mearm analyze --out`` refuses to replace a report already there without ``--force``.
    """
    from mearm.analyze import OUTPUT_NAMES  # noqa: PLC0415  (the hint only)

    for n in range(1, 1000):
        name = "report" if n == 1 else f"report-{n}"
        folder = Path(name)
        if not folder.exists() or (
            folder.is_dir() and not any((folder / out).exists() for out in OUTPUT_NAMES)
        ):
            return name
    return "NEW_FOLDER"


def _left(args: Any, config: Config, scene: list[SceneObject] | None) -> str:
    """``; N of M trials complete in LOG: …`` for a run stopped before its last trial.

    A stop that lands after the last trial was logged (the workers' last one finished as
    the Ctrl-C came) says every trial is complete and nothing is left to run: the command
    run again would only refuse to add trials.
    """
    try:
        done = resume_point(args.log, config, args.seed, scene).done
    except (MearmError, OSError):  # the log unreadable now: the stop's reason says enough
        return ""
    if done >= args.trials:
        return (
            f"; {done} of {counted(args.trials, 'trial')} complete in {args.log}: the stop "
            "came after the last, nothing is left to run"
        )
    again = " with --resume" if args.record is not None else ""
    return (
        f"; {done} of {counted(args.trials, 'trial')} complete in {args.log}: the same "
        f"command{again} runs the rest"
    )


def _prog() -> str:
    """The command as typed (``mearm experiment``, ``python -m mearm.experiment``)."""
    return invoked_as("python -m mearm.experiment")


def _verdict(path: Path, trials: int, *, failed: bool = False) -> int:
    """Print the totals line (:func:`_totals`); 0 if the trials left nothing, else 1.

    ``failed``: a trial of this run stopped early (exit 1 whatever the totals say).

    Objects left are the experiment's data, and the log keeps them; but the command's job
    was to sort them, so, as ``mearm sort``, it exits 1 and says why on stderr, too.
    """
    line, clean = _totals(path, trials)
    print(line)
    if clean:
        return EXIT_FAILURE if failed else 0
    print(f"{_prog()}: {line}", file=sys.stderr)
    return EXIT_FAILURE


def _recording(args: Any) -> Recording | None:
    """What the worker processes record, with ``--record``."""
    if args.record is None:
        return None
    return Recording(args.record_fps, args.record_per, args.record_codec, kept_config(args))


def _step(bar: Any, recorder: DatasetRecorder | None) -> None:
    """One more trial on the progress bar, with the episodes recorded so far."""
    if recorder is not None:
        bar.set_postfix_str(f"{recorder.episodes_written} episodes", refresh=False)
    bar.update(1)


def _totals(path: Path, trials: int) -> tuple[str, bool]:
    """``sorted N of M objects over K trials (…reasons…)``, from the log's summaries.

    Counts each trial number once (the attempt ``mearm analyze`` reads), resumed trials
    included; ``; J stopped early`` ends it when trials stopped on a fault.

    Returns:
        The line, and whether every object was sorted and no trial stopped early.
    """
    total = Outcome()
    done: set[int] = set()
    stopped = 0
    for trial in read_runlog(path).latest().trials:
        s = trial.summary
        number = trial.header.trial
        if s is None or number is None or number in done or number >= trials:
            continue
        done.add(number)
        stopped += not s.ok
        for name, n in (s.objects or s.sorted).items():
            total.seen[name] = total.seen.get(name, 0) + n
        for name, n in s.sorted.items():
            total.sorted[name] = total.sorted.get(name, 0) + n
        for kind, n in (s.left or {}).items():
            total.left[kind] = total.left.get(kind, 0) + n
    line = total.line()
    head, _, rest = line.partition(" objects")
    line = f"{head} objects over {counted(len(done), 'trial')}{rest}"
    left = total.n_sorted != sum(total.seen.values()) or any(total.left.values())
    if stopped:
        line += f"; {stopped} stopped early"
    return line, not left and not stopped
