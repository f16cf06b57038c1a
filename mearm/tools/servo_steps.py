r"""The twin's servo step responses, as a table and a plot (docs/twin.md).

    mearm servo-steps --csv steps.csv                    # this model's responses
    mearm servo-steps --before old.csv --out docs/images/servo_steps.png --force

(``python tools/servo_steps.py`` from the checkout.) Each response starts from a fresh
twin at home (``configs/sim_mujoco.yaml`` unless ``--config``): one joint is commanded
``--degrees`` away (10° and 60° by default: inside and at its speed limit; up from home,
or down where its limit is nearer, or, where neither keeps the tool above the table, from
a start that far from one of its limits to it, reached and held first; a step that fits
no way is refused before any measurement, naming the largest that does) by one move of
the real bus, and the
physics runs on with that command; its measured angle is sampled every 4 ms for 0.6 s
(simulated). ``--csv`` writes
``joint,step_deg,t_s,angle_deg`` rows; ``--before`` draws another run's CSV (an earlier
model's, written by this command run against it) dashed under this model's, which is
how the plot in docs/twin.md compares the servo model before and after a change. An
existing ``--csv`` or ``--out`` is refused before the measurement unless ``--force``
(the plot in docs/images is redrawn with it), and one that is the ``--config`` or
``--before`` file even with it; a folder on their path that does not exist yet is made,
as ``mkdir -p`` would.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    check_output_file,
    config_from_args,
    plain_float,
    refuse_own_inputs,
    refuse_to_replace,
)
from mearm.config import Config
from mearm.errors import MearmError
from mearm.fileio import write_atomic
from mearm.hardware import ArmCommand, ServoMap
from mearm.kinematics.errors import JointLimitError

if TYPE_CHECKING:
    from mearm.sim.twin.twin_bus import TwinArm

#: Sampling interval and length of each response (simulated) [s].
SAMPLE_S, LENGTH_S = 0.004, 0.6
#: Time a start away from home is held before the step (simulated) [s].
START_SETTLE_S = 1.0
DEFAULT_CONFIG = Path("sim_mujoco")  # the shipped config, by name
Rows = list[tuple[str, float, float, float]]


#: Poses checked along a step for the tool's clearance of the table, ends included.
STEP_SAMPLES = 9


class _Clearance:
    """Whether the tool (jaws, their servo, the hand) stays above the table in a pose."""

    def __init__(self, config: Config):
        from mearm.kinematics import ArmModel  # noqa: PLC0415  (Pinocchio: the check only)
        from mearm.sim.table_collision import collision_model  # noqa: PLC0415

        self.model = ArmModel(config.arm)
        self.collision = collision_model(config, self.model, clearance_cm=0.0)

    def above(self, joints: dict[str, float]) -> bool:
        q = self.model.chain.from_named(joints)
        return self.collision.tool_lowest_cm(q)[0] >= 0.0


def step_command(
    config: Config, joint: str, step: float, clear: _Clearance | None = None
) -> tuple[ArmCommand, ArmCommand] | None:
    """The step's start and end: ``joint`` moved ``step``, the rest at home; or ``None``.

    Tried in turn: up from home, down from home, then up to the joint's upper limit and
    down to its lower one from a start that far away. Allowed: inside the joint's limits
    and every servo's pulse range (the MeArm v1's elbow servo turns shoulder + elbow), as
    the bus checks before it sends, and the tool above the table all the way: the paper
    arm's shoulder stepped 60° down from home drove its jaws into the table and stopped
    40° short, drawn as if it were the servo's response.
    """
    smap = ServoMap.from_arm(config.arm)
    clear = clear or _Clearance(config)
    tool = {a.name: a.home for a in config.arm.tool.actuators}
    home = config.arm.home()
    spec = next(j for j in config.arm.actuated_joints() if j.name == joint)
    starts = [(home[joint], 1), (home[joint], -1)]
    if spec.limits is not None:
        starts += [(spec.limits.max - step, 1), (spec.limits.min + step, -1)]
    for start, way in starts:
        poses = [
            {**home, joint: start + way * step * k / (STEP_SAMPLES - 1)}
            for k in range(STEP_SAMPLES)
        ]
        try:
            for pose in (poses[0], poses[-1]):
                smap.check(ArmCommand(pose, tool))
        except JointLimitError:  # a pulse range's refusal is one too
            continue
        if all(clear.above(p) for p in poses):
            return ArmCommand(poses[0], tool), ArmCommand(poses[-1], tool)
    return None


def check_steps(config: Config, steps_deg: Sequence[float]) -> None:
    """Refuse, before any measurement, a step some joint cannot take either way from home.

    Raises:
        MearmError: naming ``--degrees``, the joint and the largest step it takes.
    """
    clear = _Clearance(config)
    for joint in config.arm.actuated_joints():
        for step in steps_deg:
            if step_command(config, joint.name, step, clear) is not None:
                continue
            low, high = 0.0, step  # the largest allowed step
            for _ in range(40):
                mid = (low + high) / 2
                fits = step_command(config, joint.name, mid, clear) is not None
                low, high = (mid, high) if fits else (low, mid)
            room = math.floor(low * 10) / 10
            raise MearmError(
                f"--degrees {step:g}: {joint.name} cannot step {step:g} {joint.unit} inside "
                "its limits and its servo's pulse range with the tool above the table, the "
                f"other joints at home; at most {room:g} here"
            )


class _Response:
    """The bus's sampler during one step: the joint's angle every :data:`SAMPLE_S` from t = 0.

    The twin samples within its physics (:class:`~mearm.hardware.bus.Sampler`), so the
    command period the step's move runs is sampled too: recorded only after the move, a
    response began at 20 ms, already 1.7° into a 10° step. A sample the bus takes late
    (the twin skips the time of a scene at rest) stands for every one due by then, as
    nothing moved meanwhile.
    """

    def __init__(self, arm: TwinArm, joint: str, step: float, rows: Rows):
        self.arm, self.joint, self.step, self.rows = arm, joint, step, rows
        self.t0_s, self.start = arm.time_s, arm.actual_joints[joint]
        self.taken = 0
        self.sample(arm)  # t = 0: the angle before the command

    @property
    def due_s(self) -> float:
        """When the next sample is due on the bus's clock [s]; infinite after the last."""
        if self.taken >= round(LENGTH_S / SAMPLE_S):
            return math.inf
        return self.t0_s + self.taken * SAMPLE_S

    def sample(self, bus: object) -> None:
        """Take every sample due by now (``bus`` is the twin this response samples)."""
        moved = self.arm.actual_joints[self.joint] - self.start
        while self.arm.time_s >= self.due_s - 1e-9:
            self.rows.append((self.joint, self.step, self.taken * SAMPLE_S, moved))
            self.taken += 1


def responses(config: Config, steps_deg: list[float]) -> Rows:
    """Each actuated joint's response to each step: (joint, step, t, angle) rows.

    Each step goes up from home where the joint's limits allow it, else down
    (:func:`step_command`; :func:`check_steps` refuses one that fits neither way). A
    response starts at t = 0 with the angle before the command (0) and is sampled every
    :data:`SAMPLE_S` while t < :data:`LENGTH_S`, the command's own period included.
    """
    from mearm.sim.twin.twin_bus import TwinArm

    rows: Rows = []
    clear = _Clearance(config)
    for joint in config.arm.actuated_joints():
        for step in steps_deg:
            arm = TwinArm(config)
            arm.connect()
            steps = step_command(config, joint.name, step, clear)
            assert steps is not None  # check_steps refused it
            first, command = steps
            if first.joints[joint.name] != config.arm.home()[joint.name]:
                arm.move(first)  # a start away from home: there first, at rest
                arm.settle(START_SETTLE_S)
            response = _Response(arm, joint.name, step, rows)
            arm.sampler = response
            arm.move(command)
            arm.settle(response.t0_s + LENGTH_S - arm.time_s)
            arm.sampler = None
    return rows


#: Largest magnitude of a number in a --before CSV (degrees, seconds).
MAX_CSV_VALUE = 1e4


def read_rows(path: Path) -> Rows:
    """Rows of a CSV this script wrote."""
    try:
        with path.open(newline="") as f:
            rows = [
                (r["joint"], float(r["step_deg"]), float(r["t_s"]), float(r["angle_deg"]))
                for r in csv.DictReader(f)
            ]
    except (OSError, KeyError, ValueError, UnicodeDecodeError) as exc:
        raise MearmError(f"--before {path}: not a CSV this script wrote ({exc})") from exc
    if not rows:
        raise MearmError(f"--before {path}: no responses in it")
    for k, (_, *numbers) in enumerate(rows, 2):
        if not all(math.isfinite(v) and abs(v) <= MAX_CSV_VALUE for v in numbers):
            raise MearmError(
                f"--before {path}: line {k}: step_deg, t_s and angle_deg must be finite and "
                f"within ±{MAX_CSV_VALUE:g}, got {numbers}"
            )
    return rows


def csv_text(rows: Rows) -> str:
    """The rows as the CSV ``--csv`` writes."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["joint", "step_deg", "t_s", "angle_deg"])
    writer.writerows((j, f"{s:g}", f"{t:.4f}", f"{a:.5f}") for j, s, t, a in rows)
    return out.getvalue()


def plot(rows: Rows, before: Rows, out: Path) -> None:
    """Responses (solid) over ``before`` (dashed), one panel per joint."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    joints = list(dict.fromkeys(j for j, *_ in rows))
    fig, axes = plt.subplots(1, len(joints), figsize=(4 * len(joints), 3.2), squeeze=False)
    for ax, joint in zip(axes[0], joints, strict=True):
        for label, data, style in (("before", before, "--"), ("now", rows, "-")):
            for step in sorted({s for j, s, *_ in data if j == joint}):
                t = [r[2] for r in data if r[0] == joint and r[1] == step]
                a = [abs(r[3]) for r in data if r[0] == joint and r[1] == step]
                ax.plot(t, a, style, label=f"{step:g}° {label}")
        ax.set_title(joint)
        ax.set_xlabel("time after the command [s] (simulated)")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("joint moved [°]")
    axes[0][-1].legend(fontsize=7)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=80)
    write_atomic(out, buf.getvalue())
    print(f"wrote {out}")


def main(argv: Sequence[str] | None = None) -> int:
    """Measure the responses; write the CSV and the plot asked for."""
    parser = ArgumentParser(description=__doc__.splitlines()[0])
    add_config_argument(parser, default=str(DEFAULT_CONFIG))
    parser.add_argument(
        "--degrees",
        type=plain_float,
        nargs="+",
        default=[10.0, 60.0],
        help="the steps, each up from home or, past a limit, down (default: 10 60)",
    )
    parser.add_argument(
        "--csv", type=Path, help="write the responses here (CSV; missing folders are made)"
    )
    parser.add_argument("--before", type=Path, help="an earlier run's CSV, drawn dashed (--out)")
    parser.add_argument(
        "--out", type=Path, help="write the plot here (PNG; missing folders are made)"
    )
    parser.add_argument(
        "--force",
        action="store_true",
        help="replace an existing --csv or --out (never the --config or --before file)",
    )
    args = parser.parse_args(argv)
    if args.csv is None and args.out is None:
        parser.error("nothing to write: give --csv FILE, --out FILE.png, or both")
    if args.before is not None and args.out is None:
        parser.error("--before is drawn in the plot: use it with --out FILE.png")
    if args.out is not None and args.out.suffix.lower() != ".png":
        parser.error(f"--out {args.out}: the plot is a PNG, so its name ends in .png")
    if bad := [d for d in args.degrees if not 0 < d <= 90]:
        raise MearmError(f"--degrees must be in (0, 90], got {bad[0]:g}")
    for flag, path in (("--csv", args.csv), ("--out", args.out)):
        if path is not None:  # a missing folder is made when the file is written
            check_output_file(path, flag)
    outputs = [p.resolve() for p in (args.csv, args.out) if p is not None]
    if len(set(outputs)) < len(outputs) or (
        args.before is not None and args.before.resolve() in outputs
    ):
        raise MearmError("--csv, --out and --before must be three different files")
    from mearm.config.files import resolve_config_path  # noqa: PLC0415  (an output given)

    refuse_own_inputs(
        [("--csv", args.csv), ("--out", args.out)],
        [("--config", resolve_config_path(args.config)), ("--before", args.before)],
    )
    refuse_to_replace(args.csv, "--csv", args.force)
    refuse_to_replace(args.out, "--out", args.force)
    before = read_rows(args.before) if args.before else []
    config = config_from_args(args)
    check_steps(config, args.degrees)
    rows = responses(config, args.degrees)
    try:
        if args.csv:
            write_atomic(args.csv, csv_text(rows))
            print(f"wrote {args.csv}")
        if args.out:
            plot(rows, before, args.out)
    except OSError as exc:
        raise MearmError(f"cannot write: {exc.strerror or exc} ({exc.filename})") from None
    return 0
