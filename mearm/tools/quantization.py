"""The TCP error caused by servo command quantisation: whole degrees, whole microseconds.

paper §5: whole-degree commands (``Servo.write``) cost about 0.4 cm of TCP error at the
paper arm's reach; 1 µs pulses are about ten times finer. This measures both (and
``none``) over random reachable poses of the config's arm with its channel mapping.
Simulated figures: FK of the quantised joints against FK of the exact ones, nothing else
(no offset, no noise); ``--json`` says so too (``"simulated": true``).

Example::

    mearm quantization --config configs/sim.yaml --poses 2000 --seed 0
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    config_from_args,
    plain_int,
    run,
    seed_value,
)
from mearm.hardware.mapping import Quantization

MODES: tuple[Quantization, ...] = ("degree", "microsecond", "none")


def main(argv: Sequence[str] | None = None) -> int:
    """Print mean, std, 95th percentile and max TCP error per quantisation mode."""
    parser = ArgumentParser(prog="mearm quantization", description=__doc__.splitlines()[0])
    add_config_argument(parser)
    parser.add_argument("--poses", type=plain_int, default=2000, help="random reachable poses")
    parser.add_argument("--seed", type=seed_value, default=0, help="seed of the poses")
    parser.add_argument("--json", action="store_true", help='print JSON (marked "simulated": true)')
    args = parser.parse_args(argv)
    if not 1 <= args.poses <= 1_000_000:  # as ik-stalls' --targets: a typo is not an hour's run
        parser.error(f"--poses must be in [1, 1000000], got {args.poses}")
    config = config_from_args(args)
    from mearm.sim.kinematic.servo_bus import quantization_ee_error_cm  # noqa: PLC0415

    rows = {}
    for mode in MODES:
        e = quantization_ee_error_cm(config, mode, n=args.poses, seed=args.seed)
        rows[mode] = {
            "mean_cm": float(e.mean()),
            "std_cm": float(e.std()),
            "p95_cm": float(np.percentile(e, 95)),
            "max_cm": float(e.max()),
        }
    if args.json:
        # simulated, as the table says: FK of quantised joints, not a measured arm
        record = {"simulated": True, "poses": args.poses, "seed": args.seed, "modes": rows}
        print(json.dumps(record))
        return 0
    print(f"TCP error from command quantisation alone, {args.poses} random reachable poses")
    print(f"{'mode':<12} {'mean':>8} {'std':>8} {'p95':>8} {'max':>8}   [cm, simulated]")
    for mode, r in rows.items():
        print(
            f"{mode:<12} {r['mean_cm']:8.4f} {r['std_cm']:8.4f} {r['p95_cm']:8.4f} "
            f"{r['max_cm']:8.4f}"
        )
    ratio = rows["microsecond"]["mean_cm"] / rows["degree"]["mean_cm"]
    print(f"microsecond / degree mean error: {ratio:.3f}")
    return 0


if __name__ == "__main__":
    run(main)
