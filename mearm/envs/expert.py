"""The reference expert: the sorter itself, stepped one environment step at a time.

The sorter (:class:`mearm.task.sorter.Sorter`) runs, unchanged, in a thread of the
environment's process against a :class:`StepBus`: a servo bus that hands each command to
the environment instead of sending it, and returns once the environment has stepped.
Every move of the sorter's stream, every step of a tool's hold and of a wait for the
servos to arrive becomes one proposed action; between two, the sorter looks (its own
640×480 camera, rendered from the same physics), plans and checks its routes as in
``mearm sort``. The two threads take strict turns (:class:`Handoff`), so an expert
episode is as deterministic as the physics.

**Ending it anywhere.** The environment's side of a turn (a ``put``) runs with Ctrl-C
deferred (:func:`mearm.interrupts.signals_deferred`): a ``KeyboardInterrupt`` raised
between a queue's item and its wake-up call left the expert asleep beside its turn, and
the environment's close waited for it for good (``eval-policy --jobs 1``, 3 of 70
Ctrl-Cs). :meth:`SorterExpert.close` ends the thread wherever it waits (a stop for its
next turn, the proposal it holds taken, each queue's sleeper woken) and gives up after
:data:`CLOSE_TIMEOUT_S` on a thread that will not end (a daemon thread: the process
still exits); the environment's wait for a proposal ends if the thread has died.

The expert proposes; the environment's ``step`` executes whatever action it is given.
The sorter believes its own commands were executed: a policy that sends other actions
gets labels for where the expert thinks the arm is (it measures the joints and the
objects, but not its own command history).
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Mapping
from typing import Literal

import numpy as np

from mearm import interrupts
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

log = logging.getLogger(__name__)

#: How long :meth:`SorterExpert.close` waits for the expert's thread to end [s].
CLOSE_TIMEOUT_S = 10.0
#: How often the environment, waiting for a proposal, looks whether the thread died [s].
POLL_S = 0.5


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

    def next(self, expert: threading.Thread) -> Message:
        """(Environment) The expert's next command, or how its sort ended.

        ``expert``: its thread; one that ended without saying how (it died) ends the
        wait, as a sort that ended so.
        """
        while True:
            try:
                return self._to_env.get(timeout=POLL_S)
            except queue.Empty:
                if not expert.is_alive():
                    return ("done", "the expert's thread ended without a word")

    def resume(self, *, stop: bool = False) -> None:
        """(Environment) Let the expert go on after a step (or end it, ``stop``)."""
        with interrupts.signals_deferred():  # (its put and its wake-up call, together)
            self._to_expert.put(not stop)

    def stop_waiting(self) -> None:
        """(Environment) End the expert wherever it waits: its proposal taken, a stop given.

        Its proposal (or how it ended) is taken off the queue, so that a put it waits in
        returns; a stop is queued for its next turn, unless a turn it has not taken yet
        is there (it takes that, proposes, and the next call's stop ends it); and each
        queue's sleepers are woken, should one have slept through its item.
        """
        with interrupts.signals_deferred():
            try:
                self._to_env.get_nowait()
            except queue.Empty:
                pass
            try:
                self._to_expert.put_nowait(False)  # noqa: FBT003  (the queue's item: stop)
            except queue.Full:
                pass
            for q in (self._to_env, self._to_expert):
                with q.mutex:
                    q.not_empty.notify_all()
                    q.not_full.notify_all()


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
        self._take(self.handoff.next(self._thread))

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
        except KeyboardInterrupt:  # (a Ctrl-C the sorter raised here: the environment's)
            outcome = "aborted: interrupted (Ctrl-C)"
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
        self._take(self.handoff.next(self._thread))

    def close(self) -> None:
        """End the sorter's thread (wherever it is) and wait for it.

        At most :data:`CLOSE_TIMEOUT_S` (the module docstring).
        """
        deadline = time.monotonic() + CLOSE_TIMEOUT_S
        while self._thread.is_alive():
            if time.monotonic() > deadline:
                log.warning("the expert's thread did not end in %g s: left", CLOSE_TIMEOUT_S)
                return
            self.handoff.stop_waiting()
            self._thread.join(0.05)
