"""Sort seeded random scenes in the physical twin and count what lands in its bin.

    mearm twin-scenes --config configs/sim_mujoco.yaml --scenes 50 --objects 12 --jobs 2

Each scene is ``random_scene(config, objects, seed)`` for seeds ``--first-seed`` … +
scenes − 1 (default from 0), sorted by the same loop as ``mearm sort`` (``run_sort``) on
the MuJoCo twin; an object counts only when the physics has it in its class's bin, too
slow to leave it. Prints one line per scene, the total with the scenes sorted per minute
(wall time, worker start included), every object left with its reason, and exits 1 if
any scene stopped on a fault (a stall, a camera's failure, ``twin.faults``: the sort did
not do its job; the seeds are said last, on stderr) or the share sorted is below
``--require`` (default 0: no share asked for). The share is the twin's count: the
objects in their bins of those the scenes hold. A scene's line counts its objects as
the sort does: those it saw and those the twin knows it never saw. Where that is not
what the scene held (one first seen where the arm hid the table taken for one carried
off before) or the sort counted fewer sorted than the twin has in their bins, the line
says how many its scene held and how many lie in their bins. The total
counts only the objects the camera saw (the rest are ``left`` as never seen); where
they or those in their bins are not all the scenes held, it says so: ``sorted 449 of
449 objects seen, 450 in the scenes; 450 in their bins``.

**Workers** (``--jobs N``, default 2): scenes are sorted in N worker processes, each
started once for the whole sweep (it imports the twin and the renderer once, gets the
config once and then only seeds); ``--jobs 1`` sorts in this process. A scene depends
only on its seed, so the lines are printed in seed order and are the same whatever N:
each scene builds its own model (scenes differ in objects; compiling one takes a few
milliseconds, against seconds of sorting) and its own renderer.
"""

from __future__ import annotations

import math
import os
import signal
import sys
import time
from collections import Counter
from collections.abc import Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor

from mearm import interrupts
from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    config_from_args,
    ordered_results,
    plain_float,
    plain_int,
    run,
    worker_count,
)
from mearm.config import Config
from mearm.config.base import MAX_SEED
from mearm.config.sections import MAX_SCENE_OBJECTS
from mearm.errors import MearmError
from mearm.task.report import LEFT_REASONS
from mearm.task.sorter import SortAborted

#: A scene's objects (the sort's count: those seen and those the twin knows it never
#: saw), those seen, those sorted, those in their bins (the twin's count), the objects
#: left per reason, the fault that stopped it and each object left and why.
Result = tuple[int, int, int, int, dict[str, int], str | None, list[str]]

#: What a worker sorts: the config and objects per scene, set once by :func:`_start_worker`.
_WORK: tuple[Config, int] | None = None


class _Stopped(Exception):
    """Ctrl-C (or SIGTERM, SIGHUP) stopped a scene sorted in this process: its result."""

    def __init__(self, result: Result):
        super().__init__("interrupted")
        self.result = result


def _one(config: Config, objects: int, seed: int, *, stop: bool = False) -> Result:
    """Sort one scene: its :data:`Result`.

    ``stop``: a sort Ctrl-C stopped raises :class:`_Stopped` with its result (in this
    process the sort takes the Ctrl-C as an interrupted sort; a worker's parent stops
    the sweep itself).
    """
    from mearm.maker.camera_calibration.at_start import for_config
    from mearm.task.rig import run_sort
    from mearm.task.scene import random_scene

    scene = random_scene(config, objects, seed=seed)
    try:
        report = run_sort(config, scene=scene, echo=None, calibrate_first=for_config(config))
    except SortAborted as exc:
        if exc.outcome is None:
            if stop and exc.interrupted:
                raise _Stopped((len(scene), 0, 0, 0, {}, exc.reason, [])) from None
            return len(scene), 0, 0, 0, {"fault": len(scene)}, exc.reason, []
        out = exc.outcome  # what it sorted before the fault, and what the fault left
        result: Result = (
            out.n_objects,
            sum(out.seen.values()),
            out.n_sorted,
            sum(out.in_bins.values()),
            dict(out.left),
            exc.reason,
            [],
        )
        if stop and exc.interrupted:
            raise _Stopped(result) from None
        return result
    out = report.outcome
    notes = [f"{s.object_id}: {s.reason}" for s in report.skipped]
    seen = sum(out.seen.values())
    binned = sum(out.in_bins.values())
    return out.n_objects, seen, out.n_sorted, binned, dict(out.left), None, notes


#: Whether this worker has seen Ctrl-C: the scenes it is handed after that are not sorted.
_STOPPED = False
#: Whether this worker is sorting a scene (Ctrl-C then interrupts it).
_SORTING = False


def _on_interrupt(signum: int, frame: object) -> None:
    """A worker's Ctrl-C: stop the scene it sorts; sort no more."""
    global _STOPPED
    _STOPPED = True
    if _SORTING:
        raise KeyboardInterrupt


def _start_worker(config: Config, objects: int, parent: int) -> None:
    """A worker's one-time setup: keep the config, import what every scene needs.

    Ctrl-C (the terminal sends it to the workers, too) stops the scene a worker sorts as
    an interrupted sort, and the scenes already queued for it are not started; the parent
    cancels the rest. An idle worker does not die of it with a traceback of its own. A
    worker whose parent (``parent``) is gone ends (:func:`mearm.interrupts.end_when_orphaned`).
    """
    global _WORK
    signal.signal(signal.SIGINT, _on_interrupt)
    interrupts.end_when_orphaned(parent, busy=lambda: _SORTING)
    _WORK = (config, objects)
    import mearm.sim.twin.twin_bus  # noqa: F401, PLC0415  (MuJoCo, the model builder)
    import mearm.sim.twin.twin_camera  # noqa: F401, PLC0415  (the renderer, OpenCV)
    import mearm.task.rig  # noqa: F401, PLC0415
    import mearm.task.scene  # noqa: F401, PLC0415


def _in_worker(seed: int) -> Result:
    """Sort scene ``seed`` with the worker's config (none after Ctrl-C)."""
    global _SORTING
    assert _WORK is not None, "_start_worker was not run"
    if _STOPPED:
        raise KeyboardInterrupt
    _SORTING = True
    try:
        return _one(*_WORK, seed)
    finally:
        _SORTING = False


def sweep(config: Config, objects: int, seeds: Sequence[int], jobs: int) -> Iterator[Result]:
    """Each seed's :data:`Result`, in the order of ``seeds``, sorted by ``jobs`` workers.

    ``jobs`` 1 sorts here, one scene after another; more start that many worker
    processes once (:func:`_start_worker`) and hand them seeds. Leaving the iterator
    early (Ctrl-C, an error) cancels the scenes not yet started.
    """
    if jobs == 1:
        for seed in seeds:
            try:
                yield _one(config, objects, seed, stop=True)
            except _Stopped as stopped:  # this scene's line, then no more scenes (exit 130)
                yield stopped.result
                raise KeyboardInterrupt from None
        return
    pool = ProcessPoolExecutor(
        max_workers=min(jobs, len(seeds)),
        initializer=_start_worker,
        initargs=(config, objects, os.getpid()),
    )
    yield from ordered_results(pool, _in_worker, ((s,) for s in seeds))


def _percent(share: float) -> str:
    """``share`` as a percentage to 0.1, rounded down: 2999 of 3000 is 99.9, never 100.0."""
    return f"{math.floor(share * 1000 + 1e-9) / 10:.1f}"


def main(argv: Sequence[str] | None = None) -> int:
    """Sort the scenes and print the counts; 1 on a scene a fault stopped, or under --require.

    SIGTERM and SIGHUP stop it as Ctrl-C does; only this process gets them, so the
    workers finish the scenes they sort and the pool is shut down (a SIGTERM used to end
    this process alone and leave its workers waiting for ever).
    """
    with interrupts.stop_signals_as_ctrl_c():
        return _twin_scenes(argv)


def _twin_scenes(argv: Sequence[str] | None) -> int:
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    add_config_argument(parser, default="sim_mujoco")
    parser.add_argument(
        "--scenes",
        type=plain_int,
        default=50,
        metavar="N",
        help="N scenes, seeds S … S+N−1 (default 50)",
    )
    parser.add_argument(
        "--first-seed",
        type=plain_int,
        default=0,
        metavar="S",
        help="S, the first scene's seed (default 0)",
    )
    parser.add_argument(
        "--objects", type=plain_int, default=12, help="objects per scene (default 12)"
    )
    parser.add_argument(
        "--jobs",
        type=worker_count,
        default=2,
        help=f"worker processes sorting scenes at once (default 2; this machine has "
        f"{os.cpu_count()} CPUs); 1 sorts in this process",
    )
    parser.add_argument(
        "--require",
        type=plain_float,
        default=0.0,
        help="exit 1 below this share sorted (0…1; default 0: no share asked for; a "
        "scene stopped on a fault exits 1 whatever it is)",
    )
    args = parser.parse_args(argv)
    if args.scenes < 1:
        raise MearmError(f"--scenes must be ≥ 1, got {args.scenes}")
    if not 1 <= args.objects <= MAX_SCENE_OBJECTS:
        raise MearmError(f"--objects must be 1 to {MAX_SCENE_OBJECTS} a scene, got {args.objects}")
    if not 0 <= args.require <= 1:
        raise MearmError(f"--require is a share sorted, 0 to 1, got {args.require}")
    if not 0 <= args.first_seed <= MAX_SEED - args.scenes + 1:
        raise MearmError(
            f"--first-seed must be in [0, {MAX_SEED - args.scenes + 1}] for {args.scenes} "
            f"scenes, got {args.first_seed}"
        )
    config = config_from_args(args)
    if config.simulator != "mujoco":
        raise MearmError(
            f"--config {args.config}: simulator is {config.simulator!r}; twin-scenes sorts "
            "in the twin: give a config with simulator: mujoco (sim_mujoco, ...)"
        )
    if config.belt is not None:
        raise MearmError(
            f"--config {args.config}: it has a belt, whose sort takes only what the belt "
            "brings, and twin-scenes sorts random tables: sweep a belt with mearm "
            f"conveyor-sweep --config {args.config}"
        )
    t0 = time.perf_counter()
    seen = done = binned = 0
    left: Counter[str] = Counter()
    stopped: list[int] = []  # the seeds whose sort a fault stopped
    seeds = range(args.first_seed, args.first_seed + args.scenes)
    results = sweep(config, args.objects, seeds, args.jobs)
    for seed, (n, s, k, b, why, fault, notes) in zip(seeds, results, strict=True):
        seen, done, binned = seen + s, done + k, binned + b
        if fault is not None:
            stopped.append(seed)
        left.update(why)
        reasons = [f"{v} {LEFT_REASONS.get(r, r)}" for r, v in why.items()]
        if n != args.objects or b != k:
            reasons.append(f"{args.objects} in the scene, {b} in their bins")
        extra = f" ({', '.join(reasons)})" if reasons else ""
        print(
            f"seed {seed:3d}: sorted {k:2d} of {n:2d}{extra}" + (f"; {fault}" if fault else ""),
            flush=True,
        )
        for line in notes:
            print(f"  {line}")
    wall = time.perf_counter() - t0
    held = args.scenes * args.objects
    share = binned / held
    pool = min(args.jobs, args.scenes)
    workers = "1 process" if pool == 1 else f"{pool} workers"
    of = f"{seen} objects"
    if seen != held or binned != done:
        of = f"{seen} objects seen, {held} in the scenes; {binned} in their bins"
    print(
        f"twin, {args.scenes} {'scene' if args.scenes == 1 else 'scenes'} of {args.objects}: "
        f"sorted {done} of {of} "
        f"({_percent(share)} %) in {wall:.0f} s, {60 * args.scenes / wall:.1f} scenes/min "
        f"({workers})"
    )
    for reason, n in left.most_common():
        print(f"  left: {n} {LEFT_REASONS.get(reason, reason)}")
    if stopped:  # a sort a fault stopped did not do its job, whatever share is asked for
        print(f"mearm twin-scenes: {_stopped_line(stopped, args.scenes)}", file=sys.stderr)
    if share < args.require:
        print(  # the run's job was the share asked for: said last, as eval-policy says it
            f"mearm twin-scenes: sorted {_percent(share)} % is below --require "
            f"{args.require:g} ({_percent(args.require)} %)",
            file=sys.stderr,
        )
    return 1 if stopped or share < args.require else 0


#: Most seeds a sweep's fault line names; the rest are counted.
_SEEDS_NAMED = 10


def _stopped_line(seeds: Sequence[int], scenes: int) -> str:
    """``2 of 50 scenes stopped on a fault (seeds 7, 31)``: each named, the first ten."""
    named = ", ".join(str(s) for s in seeds[:_SEEDS_NAMED])
    if len(seeds) > _SEEDS_NAMED:
        named += f" and {len(seeds) - _SEEDS_NAMED} more"
    word = "seed" if len(seeds) == 1 else "seeds"
    of = f"{scenes} {'scene' if scenes == 1 else 'scenes'}"
    return f"{len(seeds)} of {of} stopped on a fault ({word} {named})"


if __name__ == "__main__":
    run(main)
