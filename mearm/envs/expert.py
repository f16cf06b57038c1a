"""The reference expert: the sorter itself, stepped one environment step at a time.

The sorter (:class:`mearm.task.sorter.Sorter`) runs, unchanged, in a thread of the
environment's process against a :class:`StepBus`: a servo bus that hands each command to
the environment instead of sending it, and returns once the environment has stepped.
Every move of the sorter's stream, every step of a tool's hold and of a wait for the
servos to arrive becomes one proposed action; between two, the sorter looks (its own
640×480 camera, rendered from the same physics), plans and checks its routes as in
``mearm sort``. The two threads take strict turns (:class:`Handoff`), so an expert
episode is as deterministic as the physics.

The expert proposes; the environment's ``step`` executes whatever action it is given.
The sorter believes its own commands were executed: a policy that sends other actions
gets labels for where the expert thinks the arm is (it measures the joints and the
objects, but not its own command history).
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Mapping
from typing import Literal

import numpy as np

from mearm.config import Config
from mearm.hardware.bus import ServoBus
from mearm.hardware.command import ArmCommand
from mearm.sim.twin.twin_bus import ARRIVED_SHAFT_DEG, AT_REST_SHAFT_DEG, ObjectPose, TwinArm


class ExpertStopped(BaseException):
    """The environment reset or closed: the expert's sort ends where it is.

    A ``BaseException``, as ``KeyboardInterrupt`` is: the sorter's handlers of its own
    faults must not take it for one.
    """


Message = tuple[Literal["action"], ArmCommand] | tuple[Literal["done"], str]


class Handoff:
    """Two threads taking turns: the expert proposes a command, the environment steps."""

    def __init__(self) -> None:
        self._to_env: queue.Queue[Message] = queue.Queue(maxsize=1)
        self._to_expert: queue.Queue[bool] = queue.Queue(maxsize=1)

    def propose(self, command: ArmCommand) -> None:
        """(Expert) Offer the next command; return once the environment has stepped.

        Raises:
            ExpertStopped: the environment stopped the expert.
        """
        self._to_env.put(("action", command))
        if not self._to_expert.get():
            raise ExpertStopped

    def finish(self, outcome: str) -> None:
        """(Expert) The sort ended: say how."""
        self._to_env.put(("done", outcome))

    def next(self) -> Message:
        """(Environment) The expert's next command, or how its sort ended."""
        return self._to_env.get()

    def resume(self, *, stop: bool = False) -> None:
        """(Environment) Let the expert go on after a step (or end it, ``stop``)."""
        self._to_expert.put(not stop)


class StepBus(ServoBus):
    """The sorter's servo bus in an environment: each command becomes one step.

    Reads (the measured joints, the TCP, the objects) come from the twin; moves go
    through the :class:`Handoff`. A hold proposes the last command for as many steps as
    it lasts; a wait for arrival proposes it until every joint is within
    :data:`~mearm.sim.twin.twin_bus.ARRIVED_SHAFT_DEG` of its command or at rest.

    Args:
        config: The whole configuration.
        twin: The environment's twin (read only).
        handoff: Where commands go.
        step_s: The environment's step [s]: the sorter's stream period.
    """

    def __init__(self, config: Config, twin: TwinArm, handoff: Handoff, step_s: float):
        super().__init__(config.arm, config.servo, paced=False)
        self.twin = twin
        self._handoff = handoff
        self._step_s = step_s

    @property
    def period_s(self) -> float:
        """One environment step [s]."""
        return self._step_s

    # the world, as the twin measures it (the sorter's executor reads it)
    @property
    def ee_cm(self) -> np.ndarray:  # noqa: D102
        return self.twin.ee_cm

    @property
    def object_ids(self) -> tuple[str, ...]:  # noqa: D102
        return self.twin.object_ids

    @property
    def actual_joints(self) -> dict[str, float]:  # noqa: D102
        return self.twin.actual_joints

    @property
    def opening_cm(self) -> float:  # noqa: D102
        return self.twin.opening_cm

    def object_pose(self, object_id: str) -> ObjectPose:  # noqa: D102
        return self.twin.object_pose(object_id)

    def _steps(self, seconds: float) -> int:
        return max(1, int(np.ceil(seconds / self._step_s - 1e-9)))

    def _connect(self) -> None:
        """Nothing to open: the environment holds the twin."""

    def _send_move(self, command: ArmCommand, pulses_us: dict[int, int]) -> None:
        self._handoff.propose(command)

    def _hold(self, seconds: float) -> None:
        assert self.commanded is not None
        for _ in range(self._steps(seconds)):
            self._handoff.propose(self.commanded)

    def _await_arrival(self, timeout_s: float) -> float:
        command = self.commanded
        assert command is not None
        names = list(command.joints)
        goal = np.array([command.joints[n] for n in names])
        before = None
        waited = 0.0
        while waited < timeout_s:
            now = np.array([self.twin.actual_joints[n] for n in names])
            if np.all(np.abs(now - goal) <= ARRIVED_SHAFT_DEG):
                break
            if before is not None and np.all(np.abs(now - before) < AT_REST_SHAFT_DEG):
                break
            before = now
            self._handoff.propose(command)
            waited += self._step_s
        return waited

    def _stop(self) -> None:
        """Nothing to hold: the environment holds the last action."""

    def _close(self) -> None:
        """Nothing to release."""


class SorterExpert:
    """The sorter running in a thread, proposing the environment's next action.

    Args:
        config: The episode's configuration (its scene is the twin's).
        twin: The environment's twin, connected, after its first (home) command.
        step_s: The environment's step [s].
    """

    def __init__(self, config: Config, twin: TwinArm, step_s: float):
        self.handoff = Handoff()
        self.bus = StepBus(config, twin, self.handoff, step_s)
        self.config = config
        self.twin = twin
        #: How the sort ended (``None`` while it runs): ``sorted`` or the fault's reason.
        self.outcome: str | None = None
        self._thread = threading.Thread(target=self._run, name="mearm-expert", daemon=True)
        self._thread.start()
        self.proposal: ArmCommand | None = None
        self._take(self.handoff.next())

    def _in_bins(self) -> Mapping[str, int]:
        """How many objects of each class lie in its bin now (no physics is run here)."""
        return self.twin.in_bin_counts()

    def _run(self) -> None:
        from mearm.sim.twin.twin_camera import TwinCamera  # noqa: PLC0415  (GL: this thread's)
        from mearm.task.sorter import SortAborted, Sorter  # noqa: PLC0415

        camera = None
        outcome = "sorted"
        try:
            camera = TwinCamera(self.config, self.twin)
            sorter = Sorter(self.config, camera, self.bus, echo=None, in_bins=self._in_bins)
            report = sorter.run()
            left = report.outcome.left
            if left:
                outcome = "left " + ", ".join(f"{n} {why}" for why, n in left.items())
        except ExpertStopped:
            return
        except SortAborted as exc:
            outcome = f"aborted: {exc.reason}"
        except Exception as exc:  # the expert failed: the episode goes on without it
            outcome = f"{type(exc).__name__}: {exc}"
        finally:
            if camera is not None:
                camera.close()
        self.handoff.finish(outcome)

    def _take(self, message: Message) -> None:
        if message[0] == "action":
            self.proposal = message[1]
        else:
            self.proposal = None
            self.outcome = message[1]

    def advance(self) -> None:
        """The environment stepped: let the sorter go on to its next command."""
        if self.outcome is not None:
            return
        self.handoff.resume()
        self._take(self.handoff.next())

    def close(self) -> None:
        """End the sorter's thread (wherever it is) and wait for it."""
        if self.outcome is None and self._thread.is_alive():
            self.handoff.resume(stop=True)
        self._thread.join()
