"""The ``motion`` section: the predicted motion time of the paper's scene."""

from __future__ import annotations

from mearm.tools.benchmarks.bench_base import BenchOptions, Row, against, section

#: The paper's motion time for its 12 objects: about 6 s per pick or place motion, 24 of
#: them [s].
PAPER_MOTION_S = 144.0
#: The predicted motion time over the paper's must stay at or below this.
MOTION_OVER_PAPER_TARGET = 0.25


@section("motion")
def bench_motion(options: BenchOptions) -> list[Row]:
    """The predicted motion time of the paper's scene in each object order (simulated)."""
    from mearm.config import load_config  # noqa: PLC0415
    from mearm.task.rig import run_sort  # noqa: PLC0415

    rows = []
    for order in ("class", "nearest"):
        config = load_config("sim", overrides=[f"task.order={order}"])
        report = run_sort(config, echo=None)
        motion = report.motion
        assert motion is not None  # the sort ran to its summary
        done = f"sorted {report.outcome.n_sorted} of {report.outcome.n_objects}"
        if not report.complete:
            done = f"INCOMPLETE: {done}"
        note = (
            f"arm {motion.arm_s:.2f} s at the servos' speed limits + gripper and tool "
            f"{motion.tool_s:.2f} s ({motion.tool_moves} settings); {done}"
        )
        label = "the paper's colour order" if order == "class" else "nearest object first"
        rows.append(Row("motion", f"paper scene, {label}: motion", motion.total_s, "s", note))
        bound = MOTION_OVER_PAPER_TARGET
        target = f"≤ {bound:g} ({bound * PAPER_MOTION_S:g} s)"
        ratio = Row(
            "motion",
            f"paper scene, {label}: ÷ the paper's ≈ {PAPER_MOTION_S:g} s",
            motion.total_s / PAPER_MOTION_S,
            "x",
            f"target {target}",
        )
        rows.append(against(ratio, target, at_most=bound, valid=report.complete))
    return rows
