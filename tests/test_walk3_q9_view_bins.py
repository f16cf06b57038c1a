"""The view draws the bins the arm avoids: the planner's collision model's and the twin's.

For each reference config the bins' boxes in the scene a browser would receive (a real
meshcat server, decoded) are compared with the bins' shapes of the collision model the
planner builds (:func:`mearm.sim.table_collision.collision_model`) and with the bin geoms
of the MuJoCo twin's model: same parts, same sizes, same places, within 1e-9 m.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from conftest import REFERENCE_CONFIGS, ROOT
from viewscene import scene

from mearm.config import Config, load_config
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import class_of
from mearm.sim.table_collision import collision_model
from mearm.sim.twin.mjcf import twin_model
from mearm.view import ArmView

BIN_NODES = "/meshcat/bins/"


def view_bins(model: ArmModel, config: Config) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """The view's bin boxes: ``bin_<class>_<part>`` → (full size, 4x4 pose) [m]."""
    with ArmView(model, config, port=0) as view:
        tree = scene(view)
    out = {}
    for path, node in tree.items():
        if not path.startswith(BIN_NODES) or "object" not in node:
            continue
        geometry = node["object"]["geometries"][0]
        assert geometry["type"] == "BoxGeometry", path
        color, part = path[len(BIN_NODES) :].split("/")
        size = np.array([geometry["width"], geometry["height"], geometry["depth"]])
        out[f"bin_{color}_{part}"] = (size, node["transform"])
    return out


@pytest.fixture(scope="module", params=REFERENCE_CONFIGS)
def reference(request: pytest.FixtureRequest) -> tuple[Config, ArmModel]:
    config = load_config(ROOT / "configs" / request.param)
    return config, ArmModel(config.arm)


def test_the_views_bins_are_the_collision_models(reference):
    """Every bin part the planner checks is drawn, and nothing else, at its size and pose."""
    config, model = reference
    drawn = view_bins(model, config)
    checked = {
        shape.name: (2 * np.array(shape.size), pose)
        for shape, pose in collision_model(config, model).bins
    }
    assert set(drawn) == set(checked)
    for name, (size, pose) in checked.items():
        np.testing.assert_allclose(drawn[name][0], size, rtol=0, atol=1e-9, err_msg=name)
        np.testing.assert_allclose(drawn[name][1], pose, rtol=0, atol=1e-9, err_msg=name)


def test_the_views_bins_are_the_twins(reference):
    """The MuJoCo twin's bin geoms (axis-aligned boxes) are the view's bin boxes."""
    config, model = reference
    drawn = view_bins(model, config)
    twin = twin_model(config)
    data = mujoco.MjData(twin)
    mujoco.mj_kinematics(twin, data)
    geoms = {}
    for g in range(twin.ngeom):
        name = mujoco.mj_id2name(twin, mujoco.mjtObj.mjOBJ_GEOM, g)
        if name and class_of(name) is not None:
            assert twin.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX, name
            np.testing.assert_allclose(data.geom_xmat[g].reshape(3, 3), np.eye(3), atol=1e-12)
            geoms[name] = (2 * twin.geom_size[g], data.geom_xpos[g])
    assert geoms and set(drawn) == set(geoms)
    for name, (size, centre) in geoms.items():
        np.testing.assert_allclose(drawn[name][0], size, rtol=0, atol=1e-9, err_msg=name)
        np.testing.assert_allclose(drawn[name][1][:3, 3], centre, rtol=0, atol=1e-9, err_msg=name)
        np.testing.assert_allclose(drawn[name][1][:3, :3], np.eye(3), atol=1e-12, err_msg=name)
