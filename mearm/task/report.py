"""Report: what a sort did, per route and per class, to the screen and the run log."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from mearm.config import Config
from mearm.kinematics import Chain
from mearm.task.route import Route
from mearm.task.timing import MotionTime

if TYPE_CHECKING:
    from mearm.runlog.writer import RunLog  # a log is written only when asked for

#: Why an object was left unsorted: each kind and the words the summary line uses.
LEFT_REASONS: dict[str, str] = {
    "unreachable": "out of reach",
    "outside_box": "outside the target box",
    "limit": "beyond a joint limit",
    "stalled": "IK stalled",
    "singular": "at a singularity",
    "collision": "no route clear of collisions",
    "merged": "touching another object",
    "cut": "cut by the image border",
    "pick_failed": "pick failed",
    "bin_unreachable": "bin out of reach",
    "never_cleared": "table never cleared",
    "off_table": "no longer in the work area",
    "missed_belt": "missed on the belt",
    "not_confirmed": "not confirmed in its bin",
    "fault": "stopped by a fault",
    "interrupted": "interrupted",
    "unseen": "never seen by the camera",
}


@dataclass
class Skip:
    """An object left on the table, and why.

    Attributes:
        object_id: The object.
        class_name: Its class.
        reason: One line for people.
        target_cm: The target that could not be reached, if any.
        kind: The reason's kind, a key of :data:`LEFT_REASONS`.
    """

    object_id: str
    class_name: str
    reason: str
    target_cm: tuple[float, float, float] | None = None
    kind: str = "unreachable"


@dataclass
class Outcome:
    """How many objects the sort saw and sorted, per class, and why the rest were left.

    An object counts as sorted only when its place was confirmed: by the world in
    simulation (the object lies in its class's bin), by the camera on a real rig (it is
    no longer on the table).

    Attributes:
        seen: Objects seen on the table, per class (classes in sort order).
        sorted: Objects sorted, per class.
        left: Objects not sorted, per reason kind (:data:`LEFT_REASONS`).
        in_bins: In simulation, the objects the world has in their class's bin at the
            end, per class, whether the sort saw them or not (it may take an object seen
            first where the arm hid the table for one carried off before); empty on a
            real rig.
        unseen: In simulation, objects on the table the camera never saw, per class
            (also in ``left`` as ``unseen``); empty on a real rig, which cannot know them.
        astray: In the physical twin, where the objects of a class left not confirmed in
            its bin are (``red3 is on the table at (8.1, 15.2) cm``), per class; empty
            elsewhere.
        not_objects: In simulation, how many more of a class the camera followed than
            the world laid out, per class (taken off ``seen`` and ``left``: a region split
            in two, each half followed); empty elsewhere.
    """

    seen: dict[str, int] = field(default_factory=dict)
    sorted: dict[str, int] = field(default_factory=dict)
    left: dict[str, int] = field(default_factory=dict)
    in_bins: dict[str, int] = field(default_factory=dict)
    unseen: dict[str, int] = field(default_factory=dict)
    astray: dict[str, list[str]] = field(default_factory=dict)
    not_objects: dict[str, int] = field(default_factory=dict)

    @property
    def n_objects(self) -> int:
        """Objects seen, and in simulation those never seen (M)."""
        return sum(self.seen.values()) + sum(self.unseen.values())

    def objects(self) -> dict[str, int]:
        """Objects per class: those seen and, in simulation, those never seen."""
        out = dict(self.seen)
        for name, n in self.unseen.items():
            out[name] = out.get(name, 0) + n
        return out

    @property
    def n_sorted(self) -> int:
        """Objects sorted (N)."""
        return sum(self.sorted.values())

    @property
    def complete(self) -> bool:
        """Whether every object seen (and in simulation, every object) was sorted."""
        return self.n_sorted == self.n_objects

    def line(self, *, simulated: bool = False) -> str:
        """``sorted N of M objects (k out of reach, …)``: the run's last line.

        Args:
            simulated: The objects were simulated (``(simulated)``, or ``(simulated; k out
                of reach, …)``): a simulated figure is labelled so, as the sort prints it.
        """
        text = f"sorted {self.n_sorted} of {self.n_objects} objects"
        notes = ", ".join(f"{n} {LEFT_REASONS.get(k, k)}" for k, n in self.left.items() if n)
        if simulated:
            notes = f"simulated; {notes}" if notes else "simulated"
        return f"{text} ({notes})" if notes else text


@dataclass
class SortReport:
    """What a sort run did.

    Attributes:
        routes: Every pick and place route, in order.
        skipped: Objects left on the table, with the reason.
        fault: Why the run stopped early, or ``None``.
        outcome: Objects seen, sorted and left (set when the run ends).
        motion: The whole run's commanded motion (set when the run ends), or ``None``.
        simulated: Whether the objects were simulated (a world judged the places).
    """

    routes: list[Route] = field(default_factory=list)
    skipped: list[Skip] = field(default_factory=list)
    fault: str | None = None
    outcome: Outcome = field(default_factory=Outcome)
    motion: MotionTime | None = None
    simulated: bool = False

    @property
    def complete(self) -> bool:
        """Whether the run ended without a fault and with every object seen sorted."""
        return self.fault is None and self.outcome.complete

    def line(self) -> str:
        """The run's last line: how it ended.

        The outcome's count (:meth:`Outcome.line`), labelled simulated in simulation. A
        run that sorted every object and then stopped on a fault (the arm could not park,
        Ctrl-C on the way home) adds the fault's first clause, ``; then stopped: not
        parked: …``: its count alone would read as a success. A fault that left objects
        is in the count already (``k stopped by a fault``).
        """
        text = self.outcome.line(simulated=self.simulated)
        if self.fault is not None and self.outcome.complete:
            text += f"; then stopped: {self.fault.split('; ')[0]}"
        return text

    def sorted_per_class(self) -> dict[str, int]:
        """Place routes that succeeded, per class (unconfirmed: see :attr:`outcome`)."""
        out: dict[str, int] = {}
        for r in self.routes:
            if r.step == "place" and r.success:
                out[r.class_name] = out.get(r.class_name, 0) + 1
        return out

    @property
    def failed_picks(self) -> int:
        """Pick routes whose grip failed (not those a fault left unconfirmed)."""
        return sum(1 for r in self.routes if r.step == "pick" and r.confirmed and not r.success)

    @property
    def failed_places(self) -> int:
        """Place routes that did not put their object in its bin (lost on the way, landed off)."""
        return sum(1 for r in self.routes if r.step == "place" and r.confirmed and not r.success)


class Reporter:
    """Writes routes, skips, faults and the summary to the screen and the run log.

    Args:
        config: The whole configuration.
        chain: The arm's joints (names, units) for the log.
        log: The run log, or ``None``.
        echo: Called with each line (``None``: silent).
        trial: Trial number for the log.
        simulated: The objects are simulated: the last line says so.
        twin_faults: In the physical twin, the injected faults that have struck so far,
            each as ``twin.faults`` gives it; the summary record keeps them (``None``: no
            twin).
    """

    def __init__(
        self,
        config: Config,
        chain: Chain,
        log: RunLog | None,
        echo: Callable[[str], None] | None,
        trial: int | None,
        *,
        simulated: bool = False,
        twin_faults: Callable[[], list[dict[str, Any]]] | None = None,
    ):
        self.config = config
        self.twin_faults = twin_faults
        self.chain = chain
        self.log = log
        self.echo = echo or (lambda _line: None)
        self.trial = trial
        self.report = SortReport(simulated=simulated)

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
                method=plan.method,
                initial_error_cm=float(plan.initial_error_cm),
                final_error_cm=float(plan.final_error_cm),
                ee_cm=route.ee_cm.tolist(),
                error_cm=route.error_cm.tolist(),
                grip_ee_cm=_finite(route.grip_ee_cm),
                success=bool(route.success),
                confirmed=bool(route.confirmed),
                why_failed=route.why_failed,
                **({"note": route.note} if route.note else {}),  # (a log keeps no null)
                elapsed_s=route.elapsed_s,
                motion_s=route.motion_s,
            )
        x, y, z = target
        mark = "ok" if route.success else "FAILED" if route.confirmed else "unconfirmed"
        why = f": {route.why_failed or route.note}" if route.why_failed or route.note else ""
        self.echo(
            f"{route.step:<5} {route.object_id:<9} target ({x:6.2f}, {y:6.2f}, {z:6.2f}) cm  "
            f"{plan.iterations:4d} it  solver {plan.final_error_cm:.4f} cm  "
            f"arm {float(np.linalg.norm(route.error_cm)):.3f} cm  {mark:<6} "
            f"{route.elapsed_s * 1e3:7.1f} ms{why}"
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

    def summary(self, *, ok: bool, outcome: Outcome, motion: MotionTime | None = None) -> None:
        """Close the trial in the log and print the per-class table and the figures.

        The last line printed is :meth:`SortReport.line`. The ``motion`` line printed and the
        log's ``motion_s`` are the same figure.

        Args:
            ok: Whether the run ran its course: no fault stopped it (one of the twin's
                injected faults may have struck unnoticed: the log's ``twin_faults``).
            outcome: The objects seen, sorted and left.
            motion: The whole run's commanded motion (every route, home moves and tool
                settings: :class:`~mearm.task.timing.MotionTime`); ``None``: the logged
                routes' streamed motion only.
        """
        rep = self.report
        rep.outcome = outcome
        rep.motion = motion
        routes = [r for r in rep.routes if r.plan is not None]
        # one figure for the screen and the log: the whole run's motion, home moves, tool
        # settings and the parking after a fault or Ctrl-C included (the logged routes'
        # own sum leaves them out)
        motion_s = sum(r.motion_s for r in routes) if motion is None else motion.total_s
        if self.log is not None:
            # a twin's fault that struck is kept even where the sort never noticed it
            # (ok then: the run ran its course); the stderr warning alone left no trace
            struck = [] if self.twin_faults is None else self.twin_faults()
            self.log.summary(
                trial=self.trial,
                ok=ok,
                sorted=dict(outcome.sorted),
                objects=outcome.objects(),
                left=dict(outcome.left),
                motion_s=float(motion_s),
                **({"twin_faults": struck} if struck else {}),
            )
        width = max(7, *(len(c.name) + 1 for c in self.config.task.classes))
        self.echo("")
        self.echo(f"{'class':<{width}}   seen  sorted  left")
        objects = outcome.objects()
        for cls in self.config.task.classes:
            n_seen = outcome.seen.get(cls.name, 0)
            n_sorted = outcome.sorted.get(cls.name, 0)
            n_left = objects.get(cls.name, 0) - n_sorted
            self.echo(f"{cls.name:<{width}} {n_seen:6d}  {n_sorted:6d}  {n_left:4d}")
        if routes:
            its = np.array([r.plan.iterations for r in routes if r.plan is not None])
            solver_err = np.array([r.plan.final_error_cm for r in routes if r.plan is not None])
            arm_err = np.array([np.linalg.norm(r.error_cm) for r in routes])
            # a failed place (rare: only a simulator that knows its objects finds one) is
            # counted beside the failed picks; a run without one prints the line it always did
            places = f", failed places {rep.failed_places}" if rep.failed_places else ""
            self.echo(
                f"routes {len(routes)}, failed picks {rep.failed_picks}{places}, "
                f"iterations mean {its.mean():.1f} ({its.min()}–{its.max()}), "
                f"solver error mean {solver_err.mean():.4f} cm, "
                f"arm error mean {arm_err.mean():.3f} cm"
            )
        if motion is not None and (routes or motion_s > 0):
            self.echo(motion.line())
        elif routes:
            rate = self.config.servo.rate_hz
            self.echo(f"motion {motion_s:.1f} s (these routes, streamed at {rate:g} Hz)")
        for s in rep.skipped:
            self.echo(f"not sorted: {s.object_id} ({s.class_name}): {s.reason}")
        for name, n in outcome.not_objects.items():  # the lines above name them too
            seen = outcome.seen.get(name, 0)
            were = "was" if n == 1 else "were"
            self.echo(
                f"not objects ({name}): the camera followed {seen + n} where the world laid "
                f"out {seen}; {n} of them, among the lines above, {were} no object (a "
                "region split in two: is the camera where its calibration puts it?)"
            )
        for name, where in outcome.astray.items():
            if where:  # (the twin's ids: the sort numbers its own as it sees them)
                self.echo(f"not confirmed in its bin ({name}): in the twin {'; '.join(where)}")
        if rep.fault:
            self.echo(f"stopped: {rep.fault}")
        self.echo(rep.line())


def summary_without_table(lines: Sequence[str], classes: int) -> list[str]:
    """What ``mearm sort --quiet`` prints of the lines a run echoed: its summary, no table.

    The summary starts after the blank line :meth:`Reporter.summary` opens it with; its
    per-class table (a heading and one row for each of ``classes`` classes) is left out,
    so what remains is the route statistics, the motion time, the objects left and why,
    a fault, and the last line, :meth:`SortReport.line`. Lines that hold no summary are
    returned as they are.
    """
    if "" not in lines:
        return list(lines)
    start = len(lines) - lines[::-1].index("")  # after the last blank line
    return list(lines[start + 1 + classes :])


def _finite(cm: np.ndarray | None) -> list[float] | None:
    """A measured position as the log keeps it, or ``None`` where it was not measured."""
    if cm is None or not np.all(np.isfinite(cm)):
        return None
    return [float(v) for v in cm]
