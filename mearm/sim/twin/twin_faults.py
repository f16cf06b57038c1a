"""The faults ``twin.faults`` injects, applied to the twin as its simulated time passes.

Each strikes once, at its ``at_s`` of simulated time (:mod:`mearm.config.twin_faults_config`):

- ``limp_servo``: the joint's position actuator loses its gain and its damping term (the
  servo's amplifier is off: no torque, the joint hangs on its own friction and damping);
- ``knock_object``: the object is put at rest 1 m farther from the arm's base than it was,
  on the table plane, beyond the camera's view and the arm's reach;
- ``camera_black``: every frame from then on is black;
- ``camera_frozen``: every read from then on returns the last frame taken before
  ``at_s``, with that frame's time;
- ``camera_bump``: the camera moves by ``shift_cm`` and stays there.

The arm's faults strike inside the physics (:class:`~mearm.sim.twin.twin_bus.TwinArm`
runs up to the fault's time, applies it and runs on); the camera's when a frame is read
(:class:`~mearm.sim.twin.twin_camera.TwinCamera`). Nothing here tells the software: the
sort has to find each out from what it measures.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from mearm.config.twin_faults_config import KnockObject, LimpServo, TwinFault
from mearm.kinematics.bodies import object_name
from mearm.sim.errors import WorldError
from mearm.sim.twin.mjcf import M_PER_CM

log = logging.getLogger(__name__)

#: How far a knocked object ends up from where it was, away from the arm's base [m].
KNOCKED_AWAY_M = 1.0


@dataclass(frozen=True)
class CameraFaults:
    """What the camera's faults do to a frame read at some time.

    Attributes:
        black: The frame is black.
        frozen_at_s: The stream froze at this time (reads return the last frame before
            it), or ``None``.
        shift_m: How far the camera has moved [m], (3,).
    """

    black: bool
    frozen_at_s: float | None
    shift_m: np.ndarray


class FaultSchedule:
    """The twin's faults in time order, each applied once.

    Args:
        faults: ``config.twin.faults``.
        object_ids: The twin's objects (a ``knock_object`` must name one of them).

    Raises:
        WorldError: a ``knock_object`` names no object of the twin; the message lists them.
    """

    def __init__(self, faults: Sequence[TwinFault], object_ids: Sequence[str]):
        for i, f in enumerate(faults):
            if isinstance(f, KnockObject) and f.object not in object_ids:
                raise WorldError(
                    f"twin.faults.{i}.object: no object {f.object!r} in the twin; its "
                    f"objects: {', '.join(object_ids) or 'none'}"
                )
        self._arm = sorted(
            (f for f in faults if isinstance(f, LimpServo | KnockObject)), key=lambda f: f.at_s
        )
        self._camera = [f for f in faults if not isinstance(f, LimpServo | KnockObject)]
        self.struck: list[TwinFault] = []
        """The faults applied so far, in order."""

    def next_arm_fault_s(self) -> float | None:
        """When the next of the arm's faults strikes [s], or ``None``."""
        return self._arm[0].at_s if self._arm else None

    def strike_arm(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:
        """Apply the next of the arm's faults to the physics."""
        fault = self._arm.pop(0)
        if isinstance(fault, LimpServo):
            a = model.actuator(fault.joint)
            a.gainprm[:] = 0.0
            a.biasprm[:] = 0.0
        else:
            joint = model.joint(object_name(fault.object))
            adr, dof = int(joint.qposadr[0]), int(joint.dofadr[0])
            xy = data.qpos[adr : adr + 2]
            away = xy / max(float(np.linalg.norm(xy)), 1e-9)
            data.qpos[adr : adr + 2] = xy + KNOCKED_AWAY_M * away
            data.qvel[dof : dof + 6] = 0.0
            mujoco.mj_forward(model, data)
        log.warning("twin: fault %s at t = %.3f s", _describe(fault), data.time)
        self.struck.append(fault)

    def camera(self, time_s: float) -> CameraFaults:
        """What the camera's faults do to a frame read at ``time_s`` [s]."""
        shift = np.zeros(3)
        black, frozen = False, None
        for f in self._camera:
            if f.at_s > time_s:
                continue
            if not any(f is s for s in self.struck):
                log.warning("twin: fault %s at t = %.3f s", _describe(f), time_s)
                self.struck.append(f)
            if f.kind == "camera_black":
                black = True
            elif f.kind == "camera_frozen":
                frozen = f.at_s if frozen is None else min(frozen, f.at_s)
            else:
                shift += np.array(f.shift_cm) * M_PER_CM
        return CameraFaults(black, frozen, shift)

    def never_struck(self, end_s: float) -> list[str]:
        """Say, as a warning each, the faults that never struck in a run that ended at ``end_s``.

        A fault timed after the run's end (or a camera fault with no frame read after its
        time) changed nothing: a user testing the sort's fault handling must not take it
        for exercised. Called once the run is over (the twin's bus closing); the warnings
        go where the struck faults' go (this module's logger).

        Returns:
            One line per fault never struck, in the order of ``twin.faults``' times.
        """
        left = [*self._arm, *(f for f in self._camera if not any(f is s for s in self.struck))]
        lines = [
            f"twin: fault {_describe(f)} at_s = {f.at_s:g} s never struck: the run ended at "
            f"t = {end_s:.3f} s"
            + (
                "; no frame was read after it"
                if f.at_s <= end_s and not isinstance(f, LimpServo | KnockObject)
                else ""
            )
            for f in sorted(left, key=lambda f: f.at_s)
        ]
        for line in lines:
            log.warning("%s", line)
        return lines


def _describe(fault: TwinFault) -> str:
    fields = fault.model_dump(exclude={"kind", "at_s"})
    return fault.kind + "".join(f" {k}={v}" for k, v in fields.items())
