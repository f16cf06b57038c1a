"""A belt's sort run with its grips measured: how far each aim was from the nearest object.

Shared by the conveyor tests: the kinematic world's objects, or the twin's (those not in
a bin), are the truth each :class:`~mearm.task.conveyor.GripAim` is measured against.
"""

from __future__ import annotations

import math

from mearm.config import Config
from mearm.task.conveyor import ConveyorSorter, GripAim
from mearm.task.report import SortReport
from mearm.task.rig import open_rig


def sort_measuring_grips(config: Config) -> tuple[SortReport, list[float]]:
    """Run the conveyor sort; the report and, per grip, the aim's distance to the object [cm]."""
    errors: list[float] = []
    with open_rig(config) as rig:

        def measure(aim: GripAim) -> None:
            if rig.world is not None:
                truths = [(o.x_cm, o.y_cm) for o in rig.world.table_objects()]
            else:
                bus = rig.bus
                held = bus.objects_in_bin()
                truths = [
                    tuple(bus.object_pose(i).position_cm[:2])
                    for i in bus.object_ids
                    if i not in held
                ]
            errors.append(min(math.dist(aim.aim_cm, t) for t in truths))

        sorter = ConveyorSorter(
            config, rig.camera, rig.bus, model=rig.model, echo=None, in_bins=rig.in_bins,
            on_grip=measure,
        )  # fmt: skip
        return sorter.run(), errors
