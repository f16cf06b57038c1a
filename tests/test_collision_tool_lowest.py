"""The tool's lowest point, placing the tool's shapes alone, is the one every shape's
placement gives, bit for bit: any opening, held object and pose."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import ROOT

from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import M_PER_CM
from mearm.sim.table_collision import collision_model


def _every_shape(col, q: np.ndarray) -> tuple[float, str]:
    """The lowest tool point from every arm shape placed (the model's own rows)."""
    low = col._lowest_points(q)[: col._na]
    rows = np.flatnonzero(col._tool[: col._na])
    k = int(rows[np.argmin(low[rows])])
    return float(low[k]) / M_PER_CM, col._arm[k][0].name


@pytest.mark.parametrize("name", ["sim.yaml", "sim_mearm_v1.yaml", "sim_5dof.yaml"])
def test_the_tools_lowest_point_is_every_shapes_to_the_bit(name: str) -> None:
    """Poses over the whole joint box, three openings, a held object or none."""
    config = load_config(ROOT / "configs" / name)
    model = ArmModel(config.arm)
    col = collision_model(config, model)
    chain = model.chain
    rng = np.random.default_rng(29)
    held = (f"{config.task.classes[0].name}1", config.task.classes[0].name)
    names, heights = set(), set()
    for opening, hold in ((None, None), (1.0, held), (6.0, None)):
        col.set_world(opening_cm=opening, held=hold)
        for _ in range(150):
            q = chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper))
            got = col.tool_lowest_cm(q)
            assert got == _every_shape(col, q), q
            names.add(got[1])
            heights.add(got[0])
    assert len(heights) > 400  # every pose its own height
    if name == "sim_5dof.yaml":  # its wrist turns the tool: which shape is lowest changes
        assert len(names) >= 2, names
