"""Plan: where each route goes and the whole IK solve to it, before anything moves.

A route is sent to the servos only when its plan converged and every pose of it passed
the checks here (:attr:`Route.planned`); otherwise it carries a typed reason
(:attr:`Route.failure_kind`: ``outside_box``, ``unreachable``, ``limit``, ``stalled``,
``singular``; :attr:`Route.failure`: the line for people) and nothing of it moves.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from mearm.config import ColorClass, Config
from mearm.exceptions import JointLimitError, TargetError
from mearm.ik import IKFailure, IKResult, IKTarget, failure_of_error, make_solver
from mearm.kinematics import ArmModel
from mearm.task.route import Route

#: After a missed grip the TCP rises this much before the retry [cm].
RETRY_LIFT_CM = 5.0


class Planner:
    """Targets for picks, places, lifts and home, and the IK plan of each route.

    Args:
        config: The whole configuration (arm, tool, classes, controller).
        model: The arm model.
    """

    def __init__(self, config: Config, model: ArmModel):
        self.config = config
        self.model = model
        self.solver = make_solver(model, config.controller)
        tool = config.arm.tool
        self._approach = tool.pick_approach

    # ----------------------------------------------------------------- targets

    def pick_target(self, cls: ColorClass, x_cm: float, y_cm: float) -> IKTarget:
        """Above an object so the jaws close at its class's grip height."""
        z = cls.grip_z_cm + self.config.arm.tool.tcp_above_grip_cm
        return IKTarget((x_cm, y_cm, z), self._approach)

    def place_target(self, cls: ColorClass) -> IKTarget:
        """The class's bin."""
        return IKTarget(cls.bin_cm, self._approach)

    def lift_target(self, target: IKTarget) -> IKTarget:
        """``target`` raised by :data:`RETRY_LIFT_CM`."""
        x, y, z = (float(v) for v in target.position_cm)
        return IKTarget((x, y, z + RETRY_LIFT_CM), target.approach)

    def above_target(self, target: IKTarget, height_cm: float) -> IKTarget:
        """``target`` raised by ``height_cm``, same approach."""
        x, y, z = (float(v) for v in target.position_cm)
        return IKTarget((x, y, z + height_cm), target.approach)

    def home_target(self) -> IKTarget:
        """The TCP at the home pose (with its approach axis, for an arm that needs one)."""
        home = self.model.home
        x, y, z = (float(v) for v in self.model.fk_cm(home))
        if self._approach is None:
            return IKTarget((x, y, z))
        ax, ay, az = (float(v) for v in self.model.approach(home))
        return IKTarget((x, y, z), (ax, ay, az))

    # ----------------------------------------------------------------- plans

    def plan(self, route: Route, q_start: npt.ArrayLike) -> Route:
        """Solve ``route`` from ``q_start`` (full joints, model units); set its plan or failure.

        The whole solve runs first. A refused target or start (outside the box, out of
        reach, a joint limit), a solve that did not converge, or a plan with a pose
        outside the joint limits sets ``failure`` and ``failure_kind``, and the route is
        not :attr:`~Route.planned`: nothing of it may be sent.
        """
        try:
            result = self.solver.solve(q_start, route.target)
        except (TargetError, JointLimitError) as exc:
            return _fail(route, failure_of_error(exc))
        route.plan = result
        if not result.converged:
            failure = result.failure or IKFailure("stalled", f"the solver {result.status}")
            return _fail(route, IKFailure(failure.kind, f"no plan: {failure.message}"))
        problem = self._outside_limits(result)
        if problem is not None:
            return _fail(route, problem)
        return route

    def _outside_limits(self, plan: IKResult) -> IKFailure | None:
        """The first pose of ``plan`` outside the joint limits (or not finite), if any."""
        chain = self.model.chain
        q = plan.q_path
        tol = 1e-9
        inside = (q >= chain.lower - tol) & (q <= chain.upper + tol)  # NaN fails both
        if inside.all():
            return None
        k, i = (int(v) for v in np.argwhere(~inside)[0])
        s, unit = chain.scale[i], chain.unit(i)
        return IKFailure(
            "limit",
            f"plan rejected before sending: pose {k} of {len(q) - 1} puts {chain.names[i]} at "
            f"{q[k, i] / s:.4g} {unit}, outside its limits "
            f"[{chain.lower[i] / s:.4g}, {chain.upper[i] / s:.4g}] {unit}",
        )


def _fail(route: Route, failure: IKFailure) -> Route:
    route.failure_kind = failure.kind
    route.failure = failure.message
    return route
