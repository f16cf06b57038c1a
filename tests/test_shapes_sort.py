"""Classes by colour and shape: configs/sim_shapes*.yaml sort their scenes in both simulators."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from mearm import detect
from mearm.config import load_config
from mearm.task.rig import open_rig
from mearm.task.sorter import Sorter

ROOT = Path(__file__).resolve().parent.parent
KINEMATIC = ROOT / "configs" / "sim_shapes.yaml"
TWIN = ROOT / "configs" / "sim_shapes_mujoco.yaml"


def test_detect_reports_each_objects_shape_and_a_cubes_yaw(capsys) -> None:
    """mearm detect on the shapes config's camera: every object's class, shape and yaw."""
    config = load_config(KINEMATIC)
    with pytest.raises(SystemExit) as info:
        detect.run(detect.main, ["--config", str(KINEMATIC), "--camera", "--json"])
    assert info.value.code == 0
    records = json.loads(capsys.readouterr().out)
    assert len(records) == len(config.task.scene)
    for obj in config.task.scene:
        (r,) = [r for r in records if math.dist(r["cm"], (obj.x, obj.y)) < 0.3]
        cls = config.task.class_named(obj.color)
        assert (r["color"], r["shape"], r["cut"]) == (obj.color, cls.shape, False)
        if cls.shape == "cube":
            assert abs((r["yaw_deg"] - obj.yaw_deg + 45.0) % 90.0 - 45.0) < 2.0
        else:
            assert r["yaw_deg"] is None


def _sorted_into_their_bins(scene_size: int | None) -> None:
    config = load_config(KINEMATIC)
    assert {c.shape for c in config.task.classes} == {"cube", "cylinder", "prism"}
    scene = config.task.scene[:: len(config.task.scene) // scene_size] if scene_size else None
    with open_rig(config, scene) as rig:
        report = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None).run()
        assert report.complete
        objects = rig.world.objects
    assert len(objects) == (scene_size or len(config.task.scene))
    assert all(o.bin == o.color for o in objects), [(o.id, o.bin) for o in objects]


def test_a_cube_a_cylinder_and_a_prism_go_to_their_own_bins() -> None:
    """The kinematic simulator, one object of each class: each ends in its class's bin."""
    _sorted_into_their_bins(3)


@pytest.mark.slow
def test_red_cubes_and_red_cylinders_go_to_their_own_bins_kinematic() -> None:
    """The kinematic simulator, the config's scene: every object ends in its class's bin."""
    _sorted_into_their_bins(None)


@pytest.mark.slow
def test_red_cubes_and_red_cylinders_go_to_their_own_bins_in_the_twin() -> None:
    """The physical twin: every cube (at yaws 0–70°) and cylinder rests in its class's bin."""
    from mearm.sim.twin import twin_bus

    config = load_config(TWIN)
    with open_rig(config) as rig:
        sorter = Sorter(config, rig.camera, rig.bus, model=rig.model, echo=None,
                        in_bins=rig.in_bins)  # fmt: skip
        report = sorter.run()
        twins = [v for v in vars(rig.bus).values() if isinstance(v, twin_bus.TwinArm)]
        twin = twins[0] if twins else rig.bus
        in_bins = twin.objects_in_bin()
    assert report.complete
    assert sorted(in_bins) == sorted(twin.object_ids) and len(in_bins) == 8
    assert all(oid.rstrip("0123456789") == cls for oid, cls in in_bins.items())
