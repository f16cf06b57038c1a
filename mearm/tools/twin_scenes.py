"""Sort seeded random scenes in the physical twin and count what lands in its bin.

    mearm twin-scenes --config configs/sim_mujoco.yaml --scenes 50 --objects 12

Each scene is ``random_scene(config, objects, seed)`` for seeds ``--first-seed`` … +
scenes − 1 (default from 0), sorted by the same loop as ``mearm sort`` (``run_sort``) on
the MuJoCo twin; an object counts only when the physics has it in its class's bin, too
slow to leave it. Prints one line per scene, the total and every object left with its
reason, and exits 1 if the share sorted is below ``--require`` (default 0: report only).
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor

from mearm.cli import ArgumentParser, add_config_argument, config_from_args, run
from mearm.config import Config
from mearm.config.base import MAX_SEED
from mearm.errors import MearmError
from mearm.task.report import LEFT_REASONS
from mearm.task.sorter import SortAborted

Result = tuple[int, int, dict[str, int], str | None, list[str]]


def _one(config: Config, objects: int, seed: int) -> Result:
    """Sort one scene; (seen, sorted, left per reason, fault, each object left and why)."""
    from mearm.task.rig import run_sort
    from mearm.task.scene import random_scene

    scene = random_scene(config, objects, seed=seed)
    try:
        report = run_sort(config, scene=scene, echo=None)
    except SortAborted as exc:
        if exc.outcome is None:
            return len(scene), 0, {"fault": len(scene)}, exc.reason, []
        out = exc.outcome  # what it sorted before the fault, and what the fault left
        return out.n_seen, out.n_sorted, dict(out.left), exc.reason, []
    out = report.outcome
    notes = [f"{s.object_id}: {s.reason}" for s in report.skipped]
    return out.n_seen, out.n_sorted, dict(out.left), None, notes


def main(argv: Sequence[str] | None = None) -> int:
    """Sort the scenes and print the counts; 1 if the share is under --require."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument("--scenes", type=int, default=50, help="scenes, seeds S … S+N−1")
    parser.add_argument(
        "--first-seed", type=int, default=0, help="S, the first scene's seed (default 0)"
    )
    parser.add_argument("--objects", type=int, default=12, help="objects per scene")
    parser.add_argument("--jobs", type=int, default=2, help="scenes sorted at once")
    parser.add_argument(
        "--require", type=float, default=0.0, help="exit 1 below this share sorted (0…1)"
    )
    args = parser.parse_args(argv)
    if args.scenes < 1 or args.objects < 1 or args.jobs < 1 or not 0 <= args.require <= 1:
        raise MearmError("--scenes, --objects and --jobs must be ≥ 1 and --require in [0, 1]")
    if not 0 <= args.first_seed <= MAX_SEED - args.scenes + 1:
        raise MearmError(
            f"--first-seed must be in [0, {MAX_SEED - args.scenes + 1}] for {args.scenes} "
            f"scenes, got {args.first_seed}"
        )
    config = config_from_args(args)
    if config.simulator != "mujoco":
        raise MearmError(
            f"{args.config}: simulator is {config.simulator!r}; this counts twin sorts"
        )
    t0 = time.perf_counter()
    seen = done = 0
    left: Counter[str] = Counter()
    with ProcessPoolExecutor(max_workers=args.jobs) as pool:
        seeds = range(args.first_seed, args.first_seed + args.scenes)
        futures = [pool.submit(_one, config, args.objects, s) for s in seeds]
        for seed, fut in zip(seeds, futures, strict=True):
            n, k, why, fault, notes = fut.result()
            seen, done = seen + n, done + k
            left.update(why)
            reasons = ", ".join(f"{v} {LEFT_REASONS.get(r, r)}" for r, v in why.items())
            extra = f" ({reasons})" if reasons else ""
            print(
                f"seed {seed:3d}: sorted {k:2d} of {n:2d}{extra}" + (f"; {fault}" if fault else "")
            )
            for line in notes:
                print(f"  {line}")
    share = done / seen if seen else 0.0
    print(
        f"twin, {args.scenes} scenes of {args.objects}: sorted {done} of {seen} objects "
        f"({100 * share:.1f} %) in {time.perf_counter() - t0:.0f} s"
    )
    for reason, n in left.most_common():
        print(f"  left: {n} {LEFT_REASONS.get(reason, reason)}")
    return 0 if share >= args.require else 1


if __name__ == "__main__":
    run(main)
