"""Objects in the twin roll against the table with rolling friction: a knocked cylinder stops.

Without it (the table's contacts condim 3) a cylinder a jaw tipped onto its side rolled on at
5 cm/s for 1.2 m and 2.5 m (5-DOF perspective twin, seeds 998005 and 998044).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from conftest import ROOT, rays_at_each_looks_height

from mearm.config import Config, load_config
from mearm.kinematics.bodies import object_name
from mearm.sim.twin.mjcf import M_PER_CM, twin_model
from mearm.sim.twin.twin_bus import TwinArm
from mearm.sim.twin.twin_geoms import OBJECT_ROLL_FRICTION


@pytest.fixture(scope="module")
def paper() -> tuple[Config, mujoco.MjModel]:
    config = load_config(ROOT / "configs" / "sim_mujoco.yaml")
    return config, twin_model(config)


def _at_home(m: mujoco.MjModel) -> mujoco.MjData:
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    return d


def _free(m: mujoco.MjModel, object_id: str) -> tuple[int, int]:
    """The object's free joint's qpos and qvel addresses."""
    joint = m.body(object_name(object_id)).jntadr[0]
    return int(m.jnt_qposadr[joint]), int(m.jnt_dofadr[joint])


def _roll(m: mujoco.MjModel, d: mujoco.MjData, object_id: str, v_m_s: float, t_s: float):
    """Lay a cylinder on its side where it stands, its axis along y, rolling along x at
    ``v_m_s`` without slipping; run ``t_s``. Returns how far it went [cm] and its speed [cm/s].
    """
    qadr, vadr = _free(m, object_id)
    radius = float(m.geom(object_name(object_id)).size[0])
    start = np.array([*d.qpos[qadr : qadr + 2], radius])
    quat = np.array([math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0])  # axis → −y
    d.qpos[qadr : qadr + 3] = start
    d.qpos[qadr + 3 : qadr + 7] = quat
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, quat)
    spin_world = np.array([0.0, v_m_s / radius, 0.0])  # v = ω × r at the contact: no slip
    d.qvel[vadr : vadr + 6] = [v_m_s, 0.0, 0.0, *(R.reshape(3, 3).T @ spin_world)]
    mujoco.mj_forward(m, d)
    mujoco.mj_step(m, d, nstep=round(t_s / m.opt.timestep))
    went_cm = float(np.linalg.norm(d.qpos[qadr : qadr + 2] - start[:2])) / M_PER_CM
    return went_cm, float(np.linalg.norm(d.qvel[vadr : vadr + 3])) / M_PER_CM


def test_a_cylinder_on_its_side_rolling_at_5_cm_s_stops_within_a_few_cm(paper):
    """A 1 cm-radius cylinder laid on its side and rolling at 5 cm/s (the speed of the
    tipped ones) away from the arm stops within 2.5 cm (0.1 mm of rolling resistance:
    v²·(3/2)·r / (2·b·g) = 1.9 cm); it rolled on at 5 cm/s."""
    config, m = paper
    d = _at_home(m)
    went_cm, speed_cm_s = _roll(m, d, "red1", -0.05, 5.0)
    assert speed_cm_s < 0.01, speed_cm_s
    assert 1.0 < went_cm < 2.5, went_cm


def test_a_faster_cylinder_rolls_farther_as_rolling_resistance_says(paper):
    """Rolling at 20 cm/s, the cylinder stops near v²·(3/2)·r / (2·b·g) = 31 cm: the
    resistance is the torque b·N, not a brake that stops every roll at once."""
    config, m = paper
    d = _at_home(m)
    radius_m = float(m.geom(object_name("red1")).size[0])
    expected_cm = 0.2**2 * 1.5 * radius_m / (2 * OBJECT_ROLL_FRICTION * 9.81) / M_PER_CM
    went_cm, speed_cm_s = _roll(m, d, "red1", -0.2, 8.0)
    assert speed_cm_s < 0.01, speed_cm_s
    assert went_cm == pytest.approx(expected_cm, rel=0.1)


def test_table_contacts_have_rolling_friction_and_no_torsional_friction(paper):
    """An object's contact with the table: condim 6, sliding 0.4, rolling 0.1 mm, torsional
    off (it kept an object rocking); the bins' and the objects' own contacts stay condim 3."""
    config, m = paper
    d = _at_home(m)
    table = m.geom("table").id
    objects = {m.geom(object_name(o)).id for o in TwinArm(config, m).object_ids}
    pairs = [(c, {int(c.geom1), int(c.geom2)}) for c in d.contact[: d.ncon]]
    with_table = [c for c, pair in pairs if table in pair and pair & objects]
    assert len(with_table) >= len(config.task.scene)
    for c in with_table:
        assert c.dim == 6
        assert c.friction[:2] == pytest.approx([0.4, 0.4])
        assert c.friction[2] <= 1e-5  # MuJoCo's least friction: none
        assert c.friction[3:] == pytest.approx([OBJECT_ROLL_FRICTION] * 2)
    assert all(m.geom_condim[g] == 3 for g in objects)
    bins = [g for g in range(m.ngeom) if m.geom(g).name.startswith("bin_")]
    assert bins and all(m.geom_condim[g] == 3 for g in bins)


def test_upright_objects_stand_still_on_the_table(paper):
    """Every scene object left standing for 3 s stays upright (< 0.5°) where it was put
    (< 0.01 cm): the rolling friction does not rock or creep a standing one."""
    config, m = paper
    d = _at_home(m)
    ids = TwinArm(config, m).object_ids
    start = {o: d.body(object_name(o)).xpos.copy() for o in ids}
    mujoco.mj_step(m, d, nstep=round(3.0 / m.opt.timestep))
    for o in ids:
        body = d.body(object_name(o))
        tilt_deg = math.degrees(math.acos(min(1.0, float(body.xmat[8]))))
        assert tilt_deg < 0.5, (o, tilt_deg)
        assert np.linalg.norm(body.xpos - start[o]) / M_PER_CM < 0.01, o


class _TipWatch:
    """Every 20 ms of the twin's time: where each object first lay tipped over (its axis
    more than 60° from the vertical), and where it first came to rest after that."""

    def __init__(self, bus: TwinArm):
        self.tipped: dict[str, np.ndarray] = {}
        self.rested: dict[str, np.ndarray] = {}
        self._due = 0.0

    @property
    def due_s(self) -> float:
        return self._due

    def sample(self, bus: TwinArm) -> None:
        for oid in bus.object_ids:
            pose = bus.object_pose(oid)
            if oid not in self.tipped:
                if bus.data.body(object_name(oid)).xmat[8] < 0.5:
                    self.tipped[oid] = pose.position_cm.copy()
            elif oid not in self.rested and pose.speed_cm_s < 0.1:
                self.rested[oid] = pose.position_cm.copy()
        self._due = bus.time_s + 0.02


@pytest.mark.heavy
def test_a_cylinder_a_jaw_tipped_over_stops_where_it_fell(monkeypatch):
    """The 5-DOF perspective twin, seed 50106: the sort tips red2 onto its side (under MuJoCo
    4.0.0 and 4.0.1 alike; seed 49934's red3 tipped under 4.0.1 only). It comes
    to rest within 5 cm of where it fell and stays within reach, at rest at the sort's end
    (a cylinder tipped so once rolled 1.2 m off across the table: seed 998005, traced while
    the planner took the bins' walls for those of the config's own 9 objects, not the 12
    the twin built them for). At least 11 of the 12 are sorted. (Seed 998015's blue1, under
    MuJoCo 4.0.0 and 4.0.1 alike, until 2026-12-07: since the places come down into the
    bins, and leave them, straight, the sort no longer tips it.)"""
    from mearm.maker.camera_calibration.at_start import for_config
    from mearm.task.rig import run_sort
    from mearm.task.scene import random_scene

    config = load_config(ROOT / "configs" / "sim_5dof_mujoco_perspective.yaml")
    watches: list[tuple[TwinArm, _TipWatch]] = []

    def watch(rig) -> None:
        bus = rig.bus
        assert isinstance(bus, TwinArm)
        bus.sampler = _TipWatch(bus)
        watches.append((bus, bus.sampler))

    rays_at_each_looks_height(monkeypatch)  # the scene as traced
    scene = random_scene(config, 12, seed=50106)
    report = run_sort(
        config, scene=scene, echo=None, calibrate_first=for_config(config), on_open=watch
    )
    bus, tips = watches[0]
    assert "red2" in tips.tipped, tips.tipped
    for oid, fell_cm in tips.tipped.items():
        assert oid in tips.rested, oid
        assert np.linalg.norm(tips.rested[oid][:2] - fell_cm[:2]) < 5.0, (oid, fell_cm)
        end = bus.object_pose(oid)
        assert end.speed_cm_s < 0.1, (oid, end)
        assert np.linalg.norm(end.position_cm[:2]) < 40.0, (oid, end)  # the arm's reach
    assert report.outcome.n_sorted >= 11
