r"""The arm model on Pinocchio: FK of the ``tcp`` frame, its Jacobians, the approach axis.

Built from the URDF the arm description generates. The gripper's jaw joints are locked
(Pinocchio's ``buildReducedModel``), so the model's joints are exactly the chain's, in
order, and ``q`` is the full joint vector in model units (rad, or m for a prismatic
joint; see :class:`~mearm.kinematics.chain.Chain`). Positions are in centimetres.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from mearm.config import ArmDescription
from mearm.config.base import short_repr
from mearm.kinematics.chain import Chain, require_description
from mearm.kinematics.errors import InvalidJointsError, JointLimitError, ModelError
from mearm.kinematics.per_arm import PerArm
from mearm.kinematics.urdf import TCP_FRAME, generate_urdf, jaw_joint_names

CM_PER_M = 100.0


def _pinocchio_model(arm: ArmDescription, urdf: str) -> pin.Model:
    """The Pinocchio model of a URDF of ``arm``, its jaws locked (the chain's joints only)."""
    try:
        full = pin.buildModelFromXML(urdf)
    except (RuntimeError, ValueError) as exc:
        raise ModelError(f"Pinocchio could not parse the URDF: {exc}") from None
    locked = [full.getJointId(n) for n in jaw_joint_names(arm) if full.existJointName(n)]
    return pin.buildReducedModel(full, locked, pin.neutral(full)) if locked else full


def _generate(arm: ArmDescription) -> tuple[str, pin.Model]:
    urdf = generate_urdf(arm)
    return urdf, _pinocchio_model(arm, urdf)


#: How far a loaded URDF's TCP may be from the description's at the same pose [cm]
#: (:meth:`ArmModel._check_geometry`): 10 µm, far below what a hobby arm repeats.
URDF_MATCH_CM = 1e-3

#: The generated URDF and its model, once per description: a run builds its arm model
#: three times (the start-up check, the rig, the simulated servos); each takes its own
#: data, and nothing changes a model once built.
_generated = PerArm(_generate)


class ArmModel:
    """Pinocchio model of an arm, built from its description's URDF.

    Args:
        arm: The arm description (``config.arm``).
        urdf_path: Load this URDF instead of generating one. Its chain joints must carry
            the description's names, in order, it must have a ``tcp`` frame, and put it
            where the description does (home, each joint at its limits: within
            :data:`URDF_MATCH_CM`).

    Attributes:
        arm: The description.
        chain: Joint order, units, limits and coupling.
        urdf: The URDF text.
        model: The Pinocchio model of the chain (jaws locked).
        data: Its data (for this object's own calls).
        tcp_frame_id: The ``tcp`` frame's id.
        approach_axis: The tool's approach axis in the tcp frame, unit, (3,).

    Raises:
        ModelError: ``arm`` is not an :class:`ArmDescription`, or the URDF cannot be
            read or does not match it.
    """

    def __init__(self, arm: ArmDescription, urdf_path: str | Path | None = None):
        require_description(arm, "ArmModel")
        self.arm = arm
        self.chain = Chain.from_description(arm)
        if urdf_path is None:
            self.urdf, self.model = _generated(arm)
        else:
            try:
                self.urdf = Path(urdf_path).read_text(encoding="utf-8")
            except OSError as exc:
                raise ModelError(f"cannot read URDF {urdf_path}: {exc}") from None
            self.model = _pinocchio_model(arm, self.urdf)
        names = tuple(self.model.names)[1:]
        if names != self.chain.names:
            raise ModelError(
                f"URDF joints are {list(names)}; the description has {list(self.chain.names)}"
            )
        if not self.model.existFrame(TCP_FRAME):
            raise ModelError(f"URDF has no '{TCP_FRAME}' frame")
        self.data = self.model.createData()
        self.tcp_frame_id = self.model.getFrameId(TCP_FRAME)
        axis = np.asarray(arm.tool.approach_axis, dtype=float)
        self.approach_axis = axis / np.linalg.norm(axis)
        if urdf_path is not None:
            self._check_geometry(urdf_path)

    def _check_geometry(self, urdf_path: str | Path) -> None:
        """A loaded URDF's TCP where the description's own URDF puts it, at a few poses.

        Joint names alone let a stale file through (an arm's lengths changed in its
        description, the URDF not written again): the limits and the servos would be the
        description's, the kinematics the file's. Home, each joint's limits in turn and
        their middle are compared: the same to :data:`URDF_MATCH_CM` in position and
        1e-6 in rotation.
        """
        own = ArmModel(self.arm)
        poses = [self.home, (self.lower + self.upper) / 2]
        for j in range(self.chain.n):
            for end in (self.lower, self.upper):
                q = self.home
                q[j] = end[j]
                poses.append(q)
        for q in poses:
            (p, R), (p0, R0) = self.tcp_pose(q), own.tcp_pose(q)
            apart = float(np.linalg.norm(p - p0))
            if apart > URDF_MATCH_CM or not np.allclose(R, R0, atol=1e-6):
                at = ", ".join(
                    f"{n} {v:g}"
                    for n, v in zip(self.chain.names, self.chain.to_config_units(q), strict=True)
                )
                where = lambda v: ", ".join(f"{x:.2f}" for x in v)  # noqa: E731
                raise ModelError(
                    f"URDF {urdf_path} is not the arm {self.arm.name!r} described: at ({at}) "
                    f"its TCP is at ({where(p)}) cm, the description's at ({where(p0)}) cm "
                    f"({apart:.3g} cm apart{'' if apart > URDF_MATCH_CM else ', turned'}); "
                    "write it again from the description (mearm urdf --config ... --output "
                    "FILE), or load the description's own (no urdf_path)"
                )

    # ----------------------------------------------------------------- shortcuts

    @property
    def lower(self) -> np.ndarray:
        """Lower joint limits, model units, (n,)."""
        return self.chain.lower

    @property
    def upper(self) -> np.ndarray:
        """Upper joint limits, model units, (n,)."""
        return self.chain.upper

    @property
    def home(self) -> np.ndarray:
        """Home pose, model units, (n,)."""
        return self.chain.home.copy()

    # ----------------------------------------------------------------- kinematics

    def joints(self, q: npt.ArrayLike) -> np.ndarray:
        """``q`` as the model's joint vector, (n,) float, model units.

        Raises:
            InvalidJointsError: not one value per joint of the chain (an actuated-only
                vector is made whole by ``chain.full``), not numbers, or not finite.
        """
        try:
            values = np.asarray(q, dtype=float)
        except (TypeError, ValueError):
            raise InvalidJointsError(
                [], f"joint values must be numbers, got {short_repr(q)}"
            ) from None
        if values.shape != (self.chain.n,):
            names = ", ".join(self.chain.names)
            raise InvalidJointsError(
                values.ravel().tolist(),
                f"expected {self.chain.n} values, one per joint ({names}) in model units "
                f"(rad, m), got shape {values.shape}"
                + (" (the actuated joints alone: chain.full(q))"
                   if values.shape == (self.chain.m,) else ""),
            )  # fmt: skip
        # the sum of the list: one test, cheaper than np.isfinite; its overflow is checked
        if not math.isfinite(sum(values.tolist())) and not np.isfinite(values).all():
            raise InvalidJointsError(values.tolist(), "joint values must be finite")
        return values

    def tcp_pose(self, q: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """TCP position [cm], (3,), and rotation, (3, 3), in the base frame.

        Raises:
            InvalidJointsError: ``q`` is not one finite value per joint (:meth:`joints`).
        """
        pin.framesForwardKinematics(self.model, self.data, self.joints(q))
        M = self.data.oMf[self.tcp_frame_id]
        return M.translation * CM_PER_M, M.rotation.copy()

    def fk_cm(self, q: npt.ArrayLike) -> np.ndarray:
        """TCP position in the base frame [cm], (3,)."""
        return self.tcp_pose(q)[0]

    def approach(self, q: npt.ArrayLike) -> np.ndarray:
        """The tool's approach axis in the base frame, unit, (3,)."""
        return self.tcp_pose(q)[1] @ self.approach_axis

    def fk_and_jacobian(self, q: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        r"""TCP position [cm], (3,), and position Jacobian, (3, n), in one pass.

        The Jacobian is in the base frame (``LOCAL_WORLD_ALIGNED``), :math:`\dot s = J
        \dot q` [cm per rad, or cm per m for a prismatic joint]: the paper's eq. 9.
        """
        J = pin.computeFrameJacobian(
            self.model, self.data, self.joints(q), self.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED
        )
        return self.data.oMf[self.tcp_frame_id].translation * CM_PER_M, J[:3] * CM_PER_M

    def jacobian(self, q: npt.ArrayLike) -> np.ndarray:
        """Position Jacobian over every joint, (3, n) (the paper mode's J)."""
        return self.fk_and_jacobian(q)[1]

    def coupled_jacobian(self, q: npt.ArrayLike) -> np.ndarray:
        r"""Jacobian over the actuated joints through the coupling, (3, m).

        .. math:: J_c = J \, C
        """
        return self.jacobian(q) @ self.chain.C

    def approach_jacobian(self, q: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        r"""Approach axis ``a`` (3,) and its Jacobian (3, n): :math:`\dot a = \omega \times a`.

        .. math:: J_a = -[a]_\times J_\omega
        """
        J6 = pin.computeFrameJacobian(
            self.model, self.data, self.joints(q), self.tcp_frame_id, pin.LOCAL_WORLD_ALIGNED
        )
        a = self.data.oMf[self.tcp_frame_id].rotation @ self.approach_axis
        return a, -pin.skew(a) @ J6[3:]

    # ----------------------------------------------------------------- limits

    def within_limits(self, q: npt.ArrayLike, tol: float = 1e-9) -> bool:
        """Whether every joint is within its limits (with a small tolerance)."""
        return self.chain.within_limits(q, tol)

    def check_limits(self, q: npt.ArrayLike, tol: float = 1e-9) -> None:
        """Raise :class:`JointLimitError` for the first joint outside its limits.

        Raises:
            JointLimitError: that joint, its value and its limits.
            InvalidJointsError: ``q`` is not one finite value per joint (:meth:`joints`).
        """
        values = self.joints(q)
        ch = self.chain
        for i, name in enumerate(ch.names):
            if not (ch.lower[i] - tol <= values[i] <= ch.upper[i] + tol):
                s = ch.scale[i]
                raise JointLimitError(
                    name, values[i] / s, ch.lower[i] / s, ch.upper[i] / s, unit=ch.unit(i)
                )
