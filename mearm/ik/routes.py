"""The demo as a list of IK routes (paper §1, §4), and running a solver along them.

From home the arm picks every object of the first class in turn, dropping each into its
bin, then the next class: pick the first object at its grip height, place it in the
class's bin, pick the second from there, … The arm never returns home in between, so
each route starts where the last one ended: the paper's 12 objects give 24 routes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from mearm.config import TaskConfig, Tool
from mearm.ik.result import IKResult
from mearm.ik.solver import IKSolver
from mearm.ik.target import IKTarget


@dataclass(frozen=True)
class DemoRoute:
    """One motion of the demo.

    Attributes:
        name: The object's name, its class and its rank in the class, e.g. ``"red1"``.
        class_name: Its class.
        action: ``"pick"`` (to the object) or ``"place"`` (to the class's bin).
        target: The TCP target, with the arm's pick approach (or none).
    """

    name: str
    class_name: str
    action: Literal["pick", "place"]
    target: IKTarget

    @property
    def target_cm(self) -> tuple[float, float, float]:
        """The TCP target position (x, y, z) in the base frame [cm]."""
        return self.target.position_cm


def demo_routes(tool: Tool, task: TaskConfig) -> list[DemoRoute]:
    """The routes of ``task.scene``, classes in ``task.classes`` order.

    Objects of one class keep their scene order. A pick puts the TCP at the object, at
    ``grip_z_cm + tool.tcp_above_grip_cm`` (the paper: 1.5 + 11.26 = 12.76 cm); a place
    at the class's bin; both with the approach ``tool.pick_approach``.

    Args:
        tool: The arm's tool (``config.arm.tool``).
        task: The classes and the scene (``config.task``).
    """
    approach = tool.pick_approach
    routes: list[DemoRoute] = []
    for cls in task.classes:
        z = cls.grip_z_cm + tool.tcp_above_grip_cm
        place = IKTarget(tuple(float(v) for v in cls.bin_cm), approach)  # type: ignore[arg-type]
        objects = [o for o in task.scene if o.color == cls.name]
        for i, obj in enumerate(objects, start=1):
            name = f"{cls.name}{i}"
            routes.append(DemoRoute(name, cls.name, "pick", IKTarget((obj.x, obj.y, z), approach)))
            routes.append(DemoRoute(name, cls.name, "place", place))
    return routes


def run_routes(
    solver: IKSolver, q_start: npt.ArrayLike, routes: Sequence[DemoRoute]
) -> list[IKResult]:
    """Solve the routes in order, each from where the previous one ended.

    Args:
        solver: Any IK solver.
        q_start: Where the first route starts, model units (n,) or (m,), usually home.
        routes: The routes, e.g. :func:`demo_routes`.

    Returns:
        One :class:`IKResult` per route.
    """
    q = np.asarray(q_start, dtype=float)
    results = []
    for route in routes:
        result = solver.solve(route.target, q)
        results.append(result)
        q = result.q
    return results
