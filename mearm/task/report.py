"""Report: what a sort did, per route and per class, to the screen and the run log."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from mearm.config import Config
from mearm.kinematics import Chain
from mearm.runlog import RunLog
from mearm.task.route import Route


@dataclass
class Skip:
    """An object left on the table, and why."""

    object_id: str
    class_name: str
    reason: str
    target_cm: tuple[float, float, float] | None = None


@dataclass
class SortReport:
    """What a sort run did.

    Attributes:
        routes: Every pick and place route, in order.
        skipped: Objects left on the table, with the reason.
        fault: Why the run stopped early, or ``None``.
    """

    routes: list[Route] = field(default_factory=list)
    skipped: list[Skip] = field(default_factory=list)
    fault: str | None = None

    def sorted_per_class(self) -> dict[str, int]:
        """Objects placed into their bin, per class."""
        out: dict[str, int] = {}
        for r in self.routes:
            if r.step == "place" and r.success:
                out[r.class_name] = out.get(r.class_name, 0) + 1
        return out

    @property
    def failed_picks(self) -> int:
        """Pick routes whose grip failed."""
        return sum(1 for r in self.routes if r.step == "pick" and not r.success)


class Reporter:
    """Writes routes, skips, faults and the summary to the screen and the run log.

    Args:
        config: The whole configuration.
        chain: The arm's joints (names, units) for the log.
        log: The run log, or ``None``.
        echo: Called with each line (``None``: silent).
        trial: Trial number for the log.
    """

    def __init__(
        self,
        config: Config,
        chain: Chain,
        log: RunLog | None,
        echo: Callable[[str], None] | None,
        trial: int | None,
    ):
        self.config = config
        self.chain = chain
        self.log = log
        self.echo = echo or (lambda _line: None)
        self.trial = trial
        self.report = SortReport()

    def route(self, route: Route) -> None:
        """Record a pick or place route."""
        plan = route.plan
        assert plan is not None
        self.report.routes.append(route)
        target = route.target.position_cm
        if self.log is not None:
            self.log.route(
                trial=self.trial,
                object_id=route.object_id,
                color=route.class_name,
                step=route.step,
                attempt=route.attempt,
                target_cm=[float(v) for v in target],
                start_joints=self.chain.named(plan.q_path[0]),
                end_joints=self.chain.named(plan.q),
                iterations=int(plan.iterations),
                status=plan.status,
                initial_error_cm=float(plan.initial_error_cm),
                final_error_cm=float(plan.final_error_cm),
                ee_cm=route.ee_cm.tolist(),
                error_cm=route.error_cm.tolist(),
                success=bool(route.success),
                elapsed_s=route.elapsed_s,
                motion_s=route.motion_s,
            )
        x, y, z = target
        mark = "ok" if route.success else "FAILED"
        self.echo(
            f"{route.step:<5} {route.object_id:<9} target ({x:6.2f}, {y:6.2f}, {z:6.2f}) cm  "
            f"{plan.iterations:4d} it  solver {plan.final_error_cm:.4f} cm  "
            f"arm {float(np.linalg.norm(route.error_cm)):.3f} cm  {mark:<6} "
            f"{route.elapsed_s * 1e3:7.1f} ms"
        )

    def skip(self, skip: Skip) -> None:
        """Record an object left on the table."""
        self.report.skipped.append(skip)
        if self.log is not None:
            self.log.skip(
                trial=self.trial,
                object_id=skip.object_id,
                color=skip.class_name,
                target_cm=None if skip.target_cm is None else list(skip.target_cm),
                reason=skip.reason,
            )
        self.echo(f"skip  {skip.object_id:<9} {skip.reason}")

    def fault(self, reason: str, last_joints: dict[str, float] | None) -> None:
        """Record why the run stopped early."""
        self.report.fault = reason
        if self.log is not None:
            self.log.fault(reason, last_joints, trial=self.trial)

    def summary(self, ok: bool) -> None:
        """Close the trial in the log and print the per-class table."""
        if self.log is not None:
            self.log.summary(trial=self.trial, ok=ok)
        rep = self.report
        per_class = rep.sorted_per_class()
        width = max(7, *(len(c.name) + 1 for c in self.config.task.classes))
        self.echo("")
        self.echo(f"{'class':<{width}} sorted  skipped")
        for cls in self.config.task.classes:
            n_skip = sum(1 for s in rep.skipped if s.class_name == cls.name)
            self.echo(f"{cls.name:<{width}} {per_class.get(cls.name, 0):6d}  {n_skip:7d}")
        routes = [r for r in rep.routes if r.plan is not None]
        if routes:
            its = np.array([r.plan.iterations for r in routes if r.plan is not None])
            solver_err = np.array([r.plan.final_error_cm for r in routes if r.plan is not None])
            arm_err = np.array([np.linalg.norm(r.error_cm) for r in routes])
            motion = sum(r.motion_s for r in routes)
            self.echo(
                f"routes {len(routes)}, failed picks {rep.failed_picks}, "
                f"iterations mean {its.mean():.1f} ({its.min()}–{its.max()}), "
                f"solver error mean {solver_err.mean():.4f} cm, "
                f"arm error mean {arm_err.mean():.3f} cm, "
                f"motion {motion:.1f} s at {self.config.servo.rate_hz:g} Hz"
            )
        for s in rep.skipped:
            self.echo(f"not sorted: {s.object_id} ({s.class_name}): {s.reason}")
        if rep.fault:
            self.echo(f"stopped: {rep.fault}")
