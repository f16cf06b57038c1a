r"""Objects sorted from a conveyor belt, and the tracking error at the grip, per belt speed.

    mearm conveyor-sweep --speeds 1,2,3,4,5                    # kinematic simulator
    mearm conveyor-sweep --config configs/sim_conveyor.yaml --speeds 1,2,3,4,5   # twin

For each speed, sorts what the belt of the config (``configs/sim_conveyor_kinematic.yaml``
unless ``--config``) brings, at that speed, with the conveyor sorter
(:mod:`mearm.task.conveyor`): the same seeded arrivals each time. As the jaws close on
an object it compares where the tracker put it with where the simulator has it: the
tracking error at the grip. Prints one row per speed: objects the belt brought, sorted,
missed on the belt, and the error's mean and largest, all simulated (the header says so),
then a last line with the objects sorted at all speeds. Exits 1 when an object was not
sorted at some speed, with one line on stderr naming those speeds; a sort stopped by a
fault exits 1 too (Ctrl-C: 130), naming the speed it stopped at. The simulator is what
the error is measured against: a config whose camera is not simulated is refused.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from mearm import interrupts
from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    float_list,
)
from mearm.config import Config, config_from_dict
from mearm.errors import ConfigError, MearmError

#: The config the sweep runs unless ``--config`` names another.
DEFAULT_CONFIG = "sim_conveyor_kinematic"


@dataclass
class SpeedRow:
    """One speed's run."""

    speed_cm_s: float
    brought: int = 0
    sorted: int = 0
    missed: int = 0
    errors_cm: list[float] = field(default_factory=list)

    def line(self) -> str:
        """The row of the table."""
        e = self.errors_cm
        err = f"{np.mean(e):.3f} / {max(e):.3f}" if e else "–"
        return f"| {self.speed_cm_s:g} | {self.brought} | {self.sorted} | {self.missed} | {err} |"


def at_speed(config: Config, speed_cm_s: float) -> Config:
    """The config with its belt at ``speed_cm_s`` (checked as any config is)."""
    data = config.model_dump(mode="json")
    data["belt"]["speed_cm_s"] = speed_cm_s
    return config_from_dict(data)


def _true_positions(rig: object) -> list[np.ndarray]:
    """Where the simulator has each object not yet in a bin (x, y) [cm]."""
    world = getattr(rig, "world", None)
    if world is not None:
        return [np.array([o.x_cm, o.y_cm]) for o in world.table_objects()]
    bus = rig.bus  # type: ignore[attr-defined]
    in_bin = bus.objects_in_bin()
    return [bus.object_pose(i).position_cm[:2] for i in bus.object_ids if i not in in_bin]


def run_speed(
    config: Config, speed_cm_s: float, on_open: Callable[[], None] | None = None
) -> SpeedRow:
    """Sort the belt's objects at one speed; the row of the table.

    ``on_open`` is called once the rig is open (the twin built: a scene it refuses, such
    as bins too low for what the belt brings, is refused before).
    """
    from mearm.sim.belt import belt_arrivals
    from mearm.task.conveyor import ConveyorSorter, GripAim
    from mearm.task.rig import open_rig

    cfg = at_speed(config, speed_cm_s)
    row = SpeedRow(speed_cm_s, brought=len(belt_arrivals(cfg)))
    with open_rig(cfg) as rig:
        if on_open is not None:
            on_open()

        def measure(aim: GripAim) -> None:
            truths = _true_positions(rig)
            if truths:
                row.errors_cm.append(min(math.dist(aim.aim_cm, t) for t in truths))

        sorter = ConveyorSorter(
            cfg, rig.camera, rig.bus, model=rig.model, echo=None, in_bins=rig.in_bins,
            on_grip=measure,
        )  # fmt: skip
        report = sorter.run()
    row.sorted = report.outcome.n_sorted
    row.missed = report.outcome.left.get("missed_belt", 0)
    return row


def summary(rows: Sequence[SpeedRow]) -> tuple[str, str | None]:
    """The sweep's last line, and the stderr line of one that fell short (``None``: none did).

    The count is over every speed's run: each brings the same arrivals.
    """
    brought = sum(r.brought for r in rows)
    done = sum(r.sorted for r in rows)
    speeds = f"{len(rows)} speed" + ("s" if len(rows) > 1 else "")
    short = [r for r in rows if r.sorted < r.brought]
    if not short:
        return f"sorted {done} of {brought} objects at {speeds} (simulated)", None
    at = ", ".join(f"{r.sorted} of {r.brought} at {r.speed_cm_s:g} cm/s" for r in short)
    return (
        f"sorted {done} of {brought} objects at {speeds} (simulated; short at "
        f"{', '.join(f'{r.speed_cm_s:g}' for r in short)} cm/s)",
        f"not every object sorted: {at}",
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Run the sweep and print its table."""
    from mearm.task.scene import check_scene
    from mearm.task.sorter import SortAborted

    parser = ArgumentParser(prog="mearm conveyor-sweep", description=__doc__.splitlines()[0])
    add_config_argument(parser, default=DEFAULT_CONFIG)
    parser.add_argument(
        "--speeds",
        type=float_list(name="speeds"),
        default=[1.0, 2.0, 3.0, 4.0, 5.0],
        help="belt speeds [cm/s], comma-separated (default 1,2,3,4,5)",
    )
    args = parser.parse_args(argv)
    config = config_from_args(args)
    if config.belt is None:
        raise MearmError(f"{args.config}: the config has no belt (set belt: …)")
    if config.camera.kind != "sim":  # the error is measured against the simulator's objects
        raise MearmError(
            f"{args.config}: the sweep measures against the simulator's objects; this "
            f"config's camera is '{config.camera.kind}', not 'sim'"
        )
    check_scene(config, config.task.scene)  # a belt that brings nothing, as mearm sort
    twice = sorted({v for v in args.speeds if args.speeds.count(v) > 1})
    if twice:  # the same sort again: a row that adds nothing, and a total that counts it twice
        raise MearmError(
            f"--speeds: {', '.join(f'{v:g}' for v in twice)} cm/s given twice; give each once"
        )
    for v in args.speeds:  # a speed the arm cannot follow stops here, before any run
        try:
            at_speed(config, v)
        except ConfigError as exc:  # named as typed: --speeds, not the config key it sets
            raise MearmError(f"--speeds {v:g}: {'; '.join(exc.problems)}") from None
    rows: list[SpeedRow] = []
    header = [
        "| belt speed [cm/s] (simulated) | brought | sorted | missed on the belt | "
        "tracking error at the grip, mean / max [cm] |",
        "|---|---|---|---|---|",
    ]

    def print_header() -> None:  # once the first rig opened: a refused scene prints none
        while header:
            print(header.pop(0), flush=True)

    for v in args.speeds:
        try:
            row = run_speed(config, v, on_open=print_header)
        except SortAborted as exc:  # a fault or Ctrl-C: the arm parked where it could be
            print(f"stopped at {v:g} cm/s after {len(rows)} of {len(args.speeds)} speeds")
            print(f"{parser.prog}: stopped at {v:g} cm/s: {exc.reason}", file=sys.stderr)
            return interrupts.exit_status() if exc.interrupted else EXIT_FAILURE
        rows.append(row)
        print(row.line(), flush=True)
    last, short = summary(rows)
    print(last)
    if short is not None:
        print(f"{parser.prog}: {short}", file=sys.stderr)
        return EXIT_FAILURE
    return EXIT_OK


if __name__ == "__main__":
    from mearm.cli import run

    run(main)
