"""configs/sim_mearm_v1_mujoco.yaml: the MeArm v1, its claw pointing forward and level,
sorts its own scene in the physical twin."""

from __future__ import annotations

import pytest
from conftest import ROOT

from mearm.config import load_config

CONFIG = ROOT / "configs" / "sim_mearm_v1_mujoco.yaml"


def test_the_mearm_sorts_its_scene_physically(capsys, tmp_path):
    """Every object grasped, carried and resting in its class's bin in the physics; the run
    says so and exits 0."""
    from mearm.runlog import read_runlog
    from mearm.sim import twin_bus
    from mearm.sort import main

    n = len(load_config(CONFIG).task.scene)
    arms: list[twin_bus.TwinArm] = []
    real_init = twin_bus.TwinArm.__init__

    def spying_init(self, *args, **kwargs):
        real_init(self, *args, **kwargs)
        arms.append(self)

    log = tmp_path / "run.jsonl"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(twin_bus.TwinArm, "__init__", spying_init)
        code = main(["--config", str(CONFIG), "--quiet", "--log", str(log)])
    lines = capsys.readouterr().out.splitlines()
    assert code == 0 and lines[-1] == f"sorted {n} of {n} objects"
    twin = arms[-1]
    in_bins = twin.objects_in_bin()
    assert sorted(in_bins) == sorted(twin.object_ids)
    assert all(oid.rstrip("0123456789") == cls for oid, cls in in_bins.items())
    summary = read_runlog(log).trials[-1].summary
    assert summary is not None and sum(summary.sorted.values()) == n and summary.left == {}
