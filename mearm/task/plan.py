"""Plan: where each route goes and the whole IK solve to it, before anything moves.

A route is sent to the servos only when its plan converged; otherwise it carries a
typed reason (outside the box, unreachable, a joint limit, stalled) and nothing moves.
"""

from __future__ import annotations

import numpy.typing as npt

from mearm.config import ColorClass, Config
from mearm.exceptions import TargetError
from mearm.ik import IKTarget, make_solver
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
        """Solve ``route`` from ``q_start`` (full joints, model units); set its plan or failure."""
        try:
            route.plan = self.solver.solve(q_start, route.target)
        except TargetError as exc:
            route.failure = exc.reason
            return route
        if not route.plan.converged:
            route.failure = (
                f"no plan: the solver {route.plan.status.replace('_', ' ')} "
                f"{route.plan.final_error_cm:.3f} cm from the target"
            )
        return route
