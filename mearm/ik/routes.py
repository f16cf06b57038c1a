"""The paper's demo as a list of IK routes (SPEC §1, §4), and running a solver along them.

From home the arm picks every object of the first colour in turn, dropping each into its
bin, then the next colour: pick M1 at the pick height, place in the red bin, pick M2 from
there, … The arm never returns home in between, so each route starts where the last one
ended: 12 objects give 24 routes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from mearm.config import Color, Config
from mearm.ik.result import IKResult
from mearm.ik.solver import IKSolver

#: The paper's object names by colour (SPEC §4): merah, hijau, biru.
PAPER_LETTERS: dict[str, str] = {"red": "M", "green": "H", "blue": "B"}


@dataclass(frozen=True)
class DemoRoute:
    """One motion of the demo.

    Attributes:
        object_name: The paper's name of the object, e.g. ``"M1"``.
        color: Its colour.
        action: ``"pick"`` (to the object) or ``"place"`` (to the colour's bin).
        target_cm: The EE target (x, y, z) in the base frame [cm].
    """

    object_name: str
    color: Color
    action: Literal["pick", "place"]
    target_cm: tuple[float, float, float]


def demo_routes(config: Config) -> list[DemoRoute]:
    """The routes of ``config.task.scene`` in the task's colour order (24 for the paper).

    Objects of one colour keep their scene order; a pick targets the object at the pick
    height (SPEC §4: 12.76 cm), a place the colour's bin (SPEC Table 2).
    """
    z = config.robot.gripper.pick_height_cm
    routes: list[DemoRoute] = []
    for color in config.task.color_order:
        objects = [o for o in config.task.scene if o.color == color]
        bin_cm = tuple(float(v) for v in config.task.bins_cm[color])
        for i, obj in enumerate(objects, start=1):
            name = f"{PAPER_LETTERS[color]}{i}"
            routes.append(DemoRoute(name, color, "pick", (obj.x, obj.y, z)))
            routes.append(DemoRoute(name, color, "place", bin_cm))  # type: ignore[arg-type]
    return routes


def run_routes(
    solver: IKSolver, q_start_rad: npt.ArrayLike, routes: Sequence[DemoRoute]
) -> list[IKResult]:
    """Solve the routes in order, each from where the previous one ended.

    Args:
        solver: Any IK solver.
        q_start_rad: Where the first route starts (θ1..θ4) [rad], usually home.
        routes: The routes, e.g. :func:`demo_routes`.

    Returns:
        One :class:`IKResult` per route.
    """
    q = np.asarray(q_start_rad, dtype=float)
    results = []
    for route in routes:
        result = solver.solve(q, route.target_cm)
        results.append(result)
        q = result.q_rad
    return results
