"""``python -m mearm.experiment``: repeated sorting trials, as in the paper's experiments.

Each trial sorts a new layout of 4 objects of each class at least 1 cm apart
(or the same ``--scene`` every time) and appends its records, under one header per trial,
to the run log; ``python -m mearm.analyze`` reads it back::

    python -m mearm.experiment --config configs/sim.yaml --trials 100 --seed 0 --log trials.jsonl

On a real rig (camera not simulated) each trial waits for you to lay the objects out and
press Enter. Simulated trials draw the layout, the servo noise and the camera noise from
the trial's own seed, so any trial can be rerun alone.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from mearm.cli import (
    EXIT_FAILURE,
    EXIT_INTERRUPTED,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    run,
)
from mearm.config import Config, SceneObject
from mearm.exceptions import CameraError, MearmError, ServoError
from mearm.runlog import RunLog
from mearm.task import SortAborted, load_scene, random_scene, run_sort

#: Objects per class in a random trial layout (the paper: 12 objects, 4 of each colour).
PER_CLASS = 4


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


def run_trials(
    config: Config,
    trials: int,
    seed: int,
    log: RunLog,
    *,
    scene: list[SceneObject] | None = None,
    wait_for_user: Callable[[int], None] | None = None,
    progress: Callable[[int], None] | None = None,
) -> list[str | None]:
    """Run ``trials`` sorts, one header per trial in ``log``.

    Args:
        config: The rig.
        trials: How many.
        seed: Base seed; trial k uses :func:`trial_seed` (seed, k).
        log: Where the records go.
        scene: The same layout every trial instead of a random one.
        wait_for_user: Called before each trial on a real rig (to lay out the objects).
        progress: Called after each trial with the number done.

    Returns:
        Per trial, ``None`` if it cleared the table, else the reason it stopped.

    Raises:
        SortAborted: a trial was interrupted with Ctrl-C (the log holds what was done).
    """
    outcomes: list[str | None] = []
    for k in range(trials):
        s = trial_seed(seed, k)
        cfg = trial_config(config, s)
        layout = scene
        if layout is None and cfg.camera.kind == "sim":
            layout = random_scene(cfg, dict.fromkeys(cfg.task.class_names, PER_CLASS), s)
        if wait_for_user is not None:
            wait_for_user(k)
        try:
            run_sort(cfg, scene=layout, log=log, trial=k, seed=s, echo=None)
            outcomes.append(None)
        except SortAborted as exc:
            if exc.interrupted:
                raise
            outcomes.append(exc.reason)
        if progress is not None:
            progress(k + 1)
    return outcomes


def main(argv: Sequence[str] | None = None) -> int:
    """Run the trials; see the module docstring."""
    parser = ArgumentParser(prog="python -m mearm.experiment", description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument("--trials", type=int, default=100, help="number of trials (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    parser.add_argument("--log", type=Path, required=True, help="JSON-lines log to append to")
    parser.add_argument("--scene", type=Path, help="use this layout in every trial")
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error(f"--trials must be ≥ 1, got {args.trials}")
    config = config_from_args(args)
    scene = load_scene(args.scene, config.task.class_names) if args.scene else None
    if scene is not None and config.camera.kind != "sim":
        raise MearmError("--scene lays out the simulated table; this config's camera is not 'sim'")

    wait = None
    if config.camera.kind != "sim":

        def wait(k: int) -> None:
            input(f"trial {k + 1}/{args.trials}: lay out the objects, then press Enter ")

    from tqdm import tqdm

    with (
        RunLog(args.log) as log,
        tqdm(total=args.trials, unit="trial", file=sys.stderr, disable=None) as bar,
    ):
        try:
            outcomes = run_trials(
                config,
                args.trials,
                args.seed,
                log,
                scene=scene,
                wait_for_user=wait,
                progress=lambda done: bar.update(1),
            )
        except SortAborted as exc:
            print(f"mearm.experiment: stopped: {exc.reason}", file=sys.stderr)
            return EXIT_INTERRUPTED
        except (CameraError, ServoError) as exc:
            print(f"mearm.experiment: {exc}", file=sys.stderr)
            return EXIT_FAILURE
    failed = [(k, r) for k, r in enumerate(outcomes) if r is not None]
    print(f"{len(outcomes)} trials written to {args.log}; {len(failed)} stopped early")
    for k, reason in failed:
        print(f"  trial {k}: {reason}")
    print(f"analyse: python -m mearm.analyze {args.log} --out report/")
    return EXIT_FAILURE if failed else 0


if __name__ == "__main__":
    run(main)
