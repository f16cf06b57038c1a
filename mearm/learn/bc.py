"""Train the behaviour-cloning baseline on the expert's demonstrations.

    python -m mearm.learn.bc --env mearm/PickPlace-v0 --episodes 200 --jobs 2 --out bc.pt
    mearm eval-policy --env mearm/PickPlace-v0 --policy bc.pt --first-seed 100000

Collects ``--episodes`` expert episodes (seeds ``--first-seed`` …, in ``--jobs``
workers; ``--demos FILE.npz`` keeps them, with what they were collected for, or reuses
them if the file exists and was collected for the same ``--env``, ``--config``,
``--first-seed`` and ``--episodes``; another file is refused), then fits
the MLP of :mod:`mearm.learn.baseline` by Adam on the mean squared error of the joints'
steps and the gripper's cross-entropy, for ``--steps`` minibatches of ``--batch``, on
the CPU with a fixed seed. Names each file it writes (``wrote FILE``: the demonstrations
once collected, then the baseline). Evaluate it on seeds it never saw (``--first-seed``
of eval-policy past the training seeds).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from mearm.cli import (
    ArgumentParser,
    check_output_file,
    plain_int,
    refuse_to_replace,
    run,
    seed_value,
    worker_count,
)
from mearm.config import load_config
from mearm.envs import MAX_EPISODE_STEPS
from mearm.envs.actions import ActionSpec
from mearm.envs.evaluate import check_seed_range
from mearm.envs.twin_env import default_fps
from mearm.errors import MearmError
from mearm.learn.baseline import HIDDEN, build_mlp, features, save_baseline
from mearm.learn.collect import Demos, collect, read_demos
from mearm.learn.errors import DemosError, import_torch


@dataclass(frozen=True)
class Trained:
    """A fitted network and the scaling of its inputs and outputs.

    Attributes:
        net: The network.
        mean: The inputs' mean, (d,).
        std: Their spread, (d,).
        scaling: The outputs' mean and scale, (2, n) (0 and 1 for the gripper's logit).
        joints: How many outputs are joint steps.
        loss: The last minibatch's loss.
    """

    net: Any
    mean: np.ndarray
    std: np.ndarray
    scaling: np.ndarray
    joints: int
    loss: float


def train(
    demos: Demos,
    joints: int,
    *,
    steps: int = 10000,
    batch: int = 256,
    lr: float = 1e-3,
    hidden: int = HIDDEN,
    seed: int = 0,
) -> Trained:
    """Fit the MLP to ``demos``, whose first ``joints`` action values are joints.

    The targets are the joints' steps, the tool's settings and the gripper
    (:mod:`mearm.learn.baseline`); inputs and targets are standardised, so that every
    joint and tool actuator weighs alike in the loss. One thread: on a few shared cores
    more only contend.

    Raises:
        MearmError: no demonstrations.
    """
    torch = import_torch()
    if len(demos.action) == 0:
        raise MearmError("no demonstrations to learn from (no expert episode succeeded)")
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    rng = np.random.default_rng(seed)
    x = features(demos.agent_pos, demos.environment_state, demos.step)
    mean = x.mean(axis=0)
    std = x.std(axis=0) + 1e-3
    target = demos.action.astype(np.float64).copy()
    target[:, :joints] -= demos.agent_pos[:, :joints]
    scaling = np.zeros((2, target.shape[1]))
    scaling[1] = 1.0
    scaling[0, :-1] = target[:, :-1].mean(axis=0)
    scaling[1, :-1] = target[:, :-1].std(axis=0) + 1e-3
    X = torch.from_numpy((x - mean) / std)
    Y = torch.from_numpy(((target - scaling[0]) / scaling[1]).astype(np.float32))
    net = build_mlp(X.shape[1], Y.shape[1], hidden)
    opt = torch.optim.Adam(net.parameters(), lr=lr)
    bce = torch.nn.BCEWithLogitsLoss()
    loss_value = float("nan")
    for _ in range(steps):
        idx = torch.from_numpy(rng.integers(len(X), size=min(batch, len(X))))
        out = net(X[idx])
        y = Y[idx]
        loss = ((out[:, :-1] - y[:, :-1]) ** 2).mean() + bce(out[:, -1], y[:, -1])
        opt.zero_grad()
        loss.backward()
        opt.step()
        loss_value = float(loss.detach())
    return Trained(net, mean, std, scaling, joints, loss_value)


#: What decides a demos file's episodes, in the order a mismatch is named: key, flag.
DEMOS_KEYS = (
    ("env_id", "--env"),
    ("config", "--config"),
    ("first_seed", "--first-seed"),
    ("episodes", "--episodes"),
)


def demos_meta(args: Any) -> dict[str, Any]:
    """What this run's demonstrations are collected for (kept in the ``--demos`` file).

    The config as the file it names, so that ``sim_mujoco`` and its path are one config.
    """
    from mearm.config.files import resolve_config_path  # noqa: PLC0415

    return {
        "env_id": args.env,
        "config": str(resolve_config_path(args.config).resolve()),
        "first_seed": args.first_seed,
        "episodes": args.episodes,
    }


def check_demos_meta(path: Path, meta: dict[str, Any] | None, wanted: dict[str, Any]) -> None:
    """Refuse a demos file collected for another run than this one (or that does not say).

    Raises:
        DemosError: no metadata (an older file), or the first key that differs.
    """
    redo = f"give another --demos path, or delete {path} to collect anew"
    if meta is None:
        raise DemosError(
            f"--demos {path}: does not say what its episodes were collected for (an older "
            f"file), so it cannot be checked against this run; {redo}"
        )
    for key, flag in DEMOS_KEYS:
        if meta.get(key) != wanted[key]:
            raise DemosError(
                f"--demos {path}: collected with {flag} {meta.get(key)}, not {wanted[key]}; {redo}"
            )


def main(argv: Sequence[str] | None = None) -> int:
    """Collect (or read) the demonstrations, train, save."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="mearm/PickPlace-v0", help="environment id")
    parser.add_argument("--config", default="sim_mujoco", help="twin config (name or file)")
    parser.add_argument(
        "--episodes", type=plain_int, default=200, help="expert episodes to learn from"
    )
    parser.add_argument("--first-seed", type=seed_value, default=0, help="their first seed")
    parser.add_argument("--jobs", type=worker_count, default=2, help="collecting workers")
    parser.add_argument(
        "--demos",
        type=Path,
        default=None,
        help="keep them here (.npz), or reuse them if collected for this --env, --config, "
        "--first-seed and --episodes",
    )
    parser.add_argument("--steps", type=plain_int, default=10000, help="training minibatches")
    parser.add_argument("--batch", type=plain_int, default=256, help="minibatch size")
    parser.add_argument("--out", type=Path, required=True, help="the baseline's file (.pt)")
    parser.add_argument(
        "--force", action="store_true", help="replace an existing --out (a baseline trained before)"
    )
    args = parser.parse_args(argv)
    for flag, value in (("--episodes", args.episodes), ("--steps", args.steps),
                        ("--batch", args.batch)):  # fmt: skip
        if value < 1:
            raise MearmError(f"{flag} must be at least 1, got {value}")
    if args.out.suffix != ".pt":
        raise MearmError(
            f"--out must end in .pt (eval-policy knows a baseline by it), got {args.out}"
        )
    if args.env not in MAX_EPISODE_STEPS:
        raise MearmError(f"--env must be one of {', '.join(MAX_EPISODE_STEPS)}, got {args.env!r}")
    check_seed_range(args.first_seed, args.episodes)
    check_output_file(args.out, "--out")
    refuse_to_replace(args.out, "--out", args.force)  # a baseline trained for minutes
    if args.demos is not None:
        if args.demos.exists() and not args.demos.is_file():
            raise MearmError(f"--demos {args.demos}: exists and is not a file; give a .npz file")
        if args.demos.resolve() == args.out.resolve():
            raise MearmError(f"--out {args.out} is the --demos file: write the baseline elsewhere")
        if not args.demos.exists():
            check_output_file(args.demos, "--demos")
    import_torch()  # the missing extra is said before any work
    config = load_config(args.config, path_as="--config")  # a bad config, before any work
    joints = ActionSpec.of(config).joints
    options = {"config": args.config}
    wanted = demos_meta(args)
    demos: Demos | None = None
    if args.demos is not None and args.demos.exists():  # read and checked before any work
        demos, meta = read_demos(args.demos)
        check_demos_meta(args.demos, meta, wanted)
    t0 = time.perf_counter()
    if demos is None:
        seeds = range(args.first_seed, args.first_seed + args.episodes)
        demos = collect(args.env, options, seeds, args.jobs)
        if args.demos is not None:
            try:
                demos.save(args.demos, wanted)
            except OSError as exc:
                raise MearmError(f"cannot write --demos {args.demos}: {exc}") from None
            print(f"wrote {args.demos}")
    kept = len(np.unique(demos.episode))
    print(
        f"{len(demos.action)} steps of {kept} expert episodes in {time.perf_counter() - t0:.0f} s"
    )
    t1 = time.perf_counter()
    fit = train(demos, joints, steps=args.steps, batch=args.batch)
    meta = {"env_id": args.env, "env_options": options, "episodes": kept,
            "seeds": [int(demos.episode.min()), int(demos.episode.max())],
            "fps": default_fps(config)}  # fmt: skip
    try:
        save_baseline(args.out, fit.net, fit.mean, fit.std, fit.scaling, fit.joints, meta)
    except OSError as exc:
        raise MearmError(f"cannot write --out {args.out}: {exc}") from None
    wall = time.perf_counter() - t1
    print(f"trained {args.steps} steps in {wall:.0f} s (loss {fit.loss:.4f})")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    run(main)
