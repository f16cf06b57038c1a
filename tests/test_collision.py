"""Plans that see the arm's body: one collision model, every route checked, detours, refusals."""

from __future__ import annotations

import signal
import sys
from collections.abc import Iterator
from functools import partial

import mujoco
import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT

from mearm.config import Config, SceneObject, load_config
from mearm.config.belt_config import belt_classes
from mearm.exceptions import ServoStallError, SimCollisionError
from mearm.hardware.bus import ArmCommand
from mearm.ik import IKTarget
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import M_PER_CM, TableContents, bin_shapes, wall_height_m
from mearm.kinematics.collision import TOUCH_CM, CollisionModel, _first_beyond
from mearm.sim.kinematic.servo_bus import SimArm
from mearm.sim.kinematic.world import World
from mearm.sim.table_collision import collision_model
from mearm.sim.twin.mjcf import twin_model
from mearm.sim.twin.twin_bus import TwinArm
from mearm.task.plan import Planner
from mearm.task.route import Route

TWINS = ["sim_mujoco", "sim_5dof_mujoco", "sim_mearm_v1_mujoco"]


def _config(name: str, *overrides: str) -> Config:
    return load_config(ROOT / "configs" / f"{name}.yaml", overrides=overrides)


# --------------------------------------------------------------------------- one source


@pytest.mark.parametrize("name", TWINS)
def test_the_collision_model_is_the_twins_body(name: str) -> None:
    """Every colliding arm shape of the collision model sits where MuJoCo puts the twin's
    geom of the same name, at random poses with the jaws open (one source for both)."""
    config = _config(name)
    m = twin_model(config)
    d = mujoco.MjData(m)
    model = ArmModel(config.arm)
    collision = collision_model(config, model)
    half = config.arm.tool.gripper.open_cm * 0.01 / 2
    rng = np.random.default_rng(7)
    names = [o.name for o in collision.geometry.geometryObjects][: collision._na]
    assert {"shoulder_servo", f"{config.arm.tool.gripper.name}_servo"} <= set(names)
    for _ in range(5):
        q = model.chain.full(rng.uniform(model.chain.actuated_lower, model.chain.actuated_upper))
        for j, joint in enumerate(model.chain.names):
            d.qpos[m.joint(joint).qposadr[0]] = q[j]
        for jaw in ("gripper_jaw_left", "gripper_jaw_right"):
            d.qpos[m.joint(jaw).qposadr[0]] = half
        mujoco.mj_kinematics(m, d)
        pin.updateGeometryPlacements(
            model.model, collision.data, collision.geometry, collision.gdata, q
        )
        for k, geom in enumerate(names):
            g = m.geom(geom)
            assert np.allclose(collision.gdata.oMg[k].translation, d.geom_xpos[g.id], atol=1e-9)
            R = d.geom_xmat[g.id].reshape(3, 3)
            assert np.allclose(collision.gdata.oMg[k].rotation, R, atol=1e-9)
            assert np.allclose(_half_size(collision.geometry.geometryObjects[k]), m.geom_size[g.id])


def _half_size(obj: pin.GeometryObject) -> np.ndarray:
    """A coal box's or cylinder's half-sizes, MuJoCo's way."""
    shape = obj.geometry
    if hasattr(shape, "halfSide"):
        return np.asarray(shape.halfSide)
    return np.array([shape.radius, shape.halfLength, 0.0])


def test_the_bins_are_the_twins_bins() -> None:
    config = _config("sim_mujoco")
    m = twin_model(config)
    table = TableContents.of(config.task, config.belt)
    for c in table.classes:
        for shape in bin_shapes(c, table.objects(c.name)):
            assert np.allclose(m.geom(shape.name).size, shape.size)


def _random_worlds(
    collision: CollisionModel, config: Config, *, seed: int, worlds: int, most_objects: int
) -> Iterator[np.ndarray]:
    """``worlds`` random worlds set in ``collision`` one after the other, and a random pose
    in each: up to ``most_objects`` objects on the table, an opening of 2-6 cm, an object
    held in every fourth."""
    chain, rng = collision.model.chain, np.random.default_rng(seed)
    names = config.task.class_names
    for trial in range(worlds):
        objects = [
            (f"obj{k}", names[k % 3], *rng.uniform((-20.0, 25.0), (20.0, 60.0)))
            for k in range(int(rng.integers(0, most_objects + 1)))
        ]
        held = ("held1", names[trial % 3]) if trial % 4 == 0 else None
        collision.set_world(objects, opening_cm=rng.uniform(2.0, 6.0), held=held)
        yield chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper))


@pytest.mark.parametrize("name", ["sim", "sim_5dof", "sim_mearm_v1", "sim_shapes"])
def test_the_gap_is_the_nearest_of_every_pair_measured(name: str) -> None:
    """The check measures only the pairs that could be nearest (a pair is no nearer than
    its bound); its gap is the one measuring every pair finds, at random poses, tables and
    openings, with an object held or none, on every reference arm."""
    config = _config(name)
    collision = collision_model(config, ArmModel(config.arm))
    for q in _random_worlds(collision, config, seed=4102, worlds=60, most_objects=11):
        gap, part, obstacle = collision.gap(q)
        jaws = [k for col in collision._between_jaws(None) for k in collision._jaw_pairs[col]]
        active = np.flatnonzero(collision._active)
        bounds = collision._lower_bounds(collision._broad_phase(active))  # what it skips by
        distances = [
            pin.computeDistance(collision.geometry, collision.gdata, k).min_distance
            for k in active.tolist()
        ]
        assert np.all(bounds <= np.array(distances) + 1e-9)
        pairs = zip(distances, active.tolist(), strict=True)
        measured = sorted((d, k) for d, k in pairs if k not in jaws)
        nearest, k = measured[0]
        assert gap == pytest.approx(nearest - collision.clearance_m, abs=1e-6)
        if len(measured) == 1 or measured[1][0] - nearest > 1e-5:  # no near tie
            assert (part, obstacle) == collision._pair_names(k)


@pytest.mark.parametrize("name", ["sim", "sim_5dof", "sim_mearm_v1", "sim_shapes"])
def test_each_bins_nearest_part_is_the_one_measuring_every_pair_finds(name: str) -> None:
    """``bins_at`` measures a bin's pairs in the order of their bounds, not each one: every
    bin's nearest part and distance, and the bins' order, are what measuring every pair
    finds, at random poses, tables, openings and held objects, on every reference arm.
    (coal starts each distance from the pair's last answer and stops at its tolerance, a
    micrometre, so a pair measured again may differ by about that: distances to 10 µm,
    the part unless two are that near.)"""
    config = _config(name)
    collision = collision_model(config, ArmModel(config.arm))
    for q in _random_worlds(collision, config, seed=20261201, worlds=80, most_objects=7):
        got = collision.bins_at(q)
        every: dict[str, list[tuple[float, str]]] = {}
        for k, color, a in collision._bin_pairs:
            if collision._active[k]:
                d = pin.computeDistance(collision.geometry, collision.gdata, k).min_distance
                every.setdefault(color, []).append((d / M_PER_CM, collision._arm_names[a]))
        assert [c for c, _, _ in got] == list(every) and len(got) == len(config.task.classes)
        for (color, part, d), measured in zip(got, every.values(), strict=True):
            (nearest, its_part), *rest = sorted(measured)
            assert d == pytest.approx(nearest, abs=1e-3), color
            if not rest or rest[0][0] - nearest > 1e-3:
                assert part == its_part, color


def test_the_next_check_is_found_as_numpy_finds_it() -> None:
    """Where a path's sweeps first add up past the gap: the segment and the sum before it
    that NumPy's cumulative sum and search give, bit for bit (the walk stops there)."""
    rng = np.random.default_rng(4103)
    for _ in range(3000):
        sweep = np.abs(rng.normal(size=int(rng.integers(1, 12)))) * rng.uniform(0.0, 0.05)
        sweep[rng.random(len(sweep)) < 0.1] = 0.0
        t, g = float(rng.choice([0.0, rng.uniform()])), float(rng.uniform(0.0, 0.05))
        ahead = np.cumsum(sweep) - sweep[0] * t
        j = int(np.searchsorted(ahead, g, side="right"))
        got = _first_beyond(sweep.tolist(), float(sweep[0]) * t, g)
        assert got[0] == j
        if 0 < j < len(sweep):
            assert got[1] == ahead[j - 1]


def test_the_table_counts_the_scene_and_the_belt() -> None:
    """Each bin's walls hold every object of its class, the scene's and the belt's, and one more."""
    config = _config("sim_conveyor")
    table = TableContents.of(config.task, config.belt)
    brought = belt_classes(config.belt, config.task.classes)
    assert brought, "the conveyor's belt brings objects"
    for c in config.task.classes:
        n = sum(o.color == c.name for o in config.task.scene) + brought.count(c.name)
        assert table.objects(c.name) == n
        assert wall_height_m(c, n) >= (n + 1) * c.height_cm * M_PER_CM
    with pytest.raises(KeyError):
        table.class_named("purple")


# --------------------------------------------------------------------------- a bin wall


def _across_the_red_bin() -> tuple[Config, ArmModel, Planner, np.ndarray, IKTarget]:
    """The paper's twin arm (jaws down) at grip height just left of the red bin, and a pick
    target just right of it: the straight way runs through the bin's walls."""
    config = _config("sim_mujoco", "task.scene=[]")
    model = ArmModel(config.arm)
    planner = Planner(config, model, collision_model(config, model))
    red = config.task.class_named("red")
    x, y = red.bin_cm[0], red.bin_cm[1]
    out = red.bin_inner_width_cm / 2 + 5.0
    start = planner.solver.solve(planner.pick_target(red, x - out, y), model.home)
    assert start.converged
    return config, model, planner, start.q, planner.pick_target(red, x + out, y)


def test_a_route_across_a_bin_goes_up_over_and_down() -> None:
    config, model, planner, q0, target = _across_the_red_bin()
    direct = planner.solver.solve(target, q0)
    assert direct.converged
    assert planner.collision is not None
    contact = planner.collision.first_contact(direct.q_path)
    assert contact is not None and contact.obstacle.startswith("bin_red_")
    route = planner.plan(Route("", "red", "pick", 1, target), q0)
    assert route.planned and route.detour_cm is not None and route.plan is not None
    assert planner.collision.first_contact(route.plan.q_path) is None
    walls = max(float(s.size[2] * 2) for s in bin_shapes(config.task.class_named("red"), 0)) * 100
    assert route.detour_cm > walls
    z = route.plan.ee_path_cm[:, 2]
    assert z.max() >= route.detour_cm - 0.1  # it went up there
    assert np.linalg.norm(route.plan.ee_path_cm[-1] - target.position_cm) < 0.1


def test_the_kinematic_simulator_faults_on_the_wall_and_takes_the_detour() -> None:
    """The fast simulator sees what physics would: the straight way is a fault naming the
    wall, the planned detour arrives."""
    config, model, planner, q0, target = _across_the_red_bin()
    direct = planner.solver.solve(target, q0)
    route = planner.plan(Route("", "red", "pick", 1, target), q0)
    assert route.plan is not None

    def fresh() -> SimArm:
        arm = SimArm(config, World.from_config(config), model)
        arm.connect()
        arm.actual_joints = model.chain.named_actuated(q0)  # placed there, not moved
        return arm

    arm = fresh()
    with pytest.raises(SimCollisionError, match=r"(touches|comes within [0-9.]+ cm of) bin_red_"):
        for q in direct.q_path[1:]:
            arm.move(_command(config, model, q))
    arm = fresh()
    for q in route.plan.q_path[1:]:
        arm.move(_command(config, model, q))
    assert np.linalg.norm(arm.ee_cm - target.position_cm) < 0.5


@pytest.mark.slow
def test_the_twin_stalls_on_the_wall_and_takes_the_detour() -> None:
    """In physics the straight way catches the jaws on the wall (a stall fault, naming the
    wall); the planned detour arrives."""
    config, model, planner, q0, target = _across_the_red_bin()
    twin = twin_model(config)
    direct = planner.solver.solve(target, q0)
    route = planner.plan(Route("", "red", "pick", 1, target), q0)
    assert route.plan is not None

    start = IKTarget(tuple(model.fk_cm(q0)), target.approach)
    to_start = planner.plan(Route("", "red", "pick", 1, start), model.home)
    assert to_start.planned and to_start.plan is not None

    def fresh() -> TwinArm:
        arm = TwinArm(config, twin)
        arm.connect()
        _stream_timed(arm, model, to_start.plan.q_path, config)
        arm.await_arrival(3.0)
        return arm

    arm = fresh()
    # the stall says what the arm pressed on, as only a simulator can
    with pytest.raises(ServoStallError, match=r"in the twin its \w+ presses on bin_red_wall_"):
        _stream_timed(arm, model, direct.q_path, config)
        arm.await_arrival(3.0)
    arm = fresh()
    _stream_timed(arm, model, route.plan.q_path, config)
    arm.await_arrival(3.0)
    assert np.linalg.norm(arm.ee_cm - target.position_cm) < 0.5


def _command(config: Config, model: ArmModel, q: np.ndarray) -> ArmCommand:
    tool = {a.name: a.home for a in config.arm.tool.actuators}
    return ArmCommand(model.chain.named_actuated(q), tool, False)


def _stream_timed(arm: TwinArm, model: ArmModel, q_path: np.ndarray, config: Config) -> None:
    """The path at the servos' speed limits, as the executor streams it."""
    from mearm.task.execute import Executor

    timed = Executor(config, arm, model, None).timed(q_path)
    for q in timed.q[1:]:
        arm.move(_command(config, model, q))


# --------------------------------------------------------------------------- refusals


def _blocking_pair(config: Config) -> list[SceneObject]:
    """Two objects each of which a jaw of the other's pick comes down on."""
    model = ArmModel(config.arm)
    collision = collision_model(config, model)
    g = config.arm.tool.gripper
    across = collision.bodies.across
    red = config.task.class_named("red")
    x, y = 0.0, 45.0
    planner = Planner(config, model)
    q = planner.solver.solve(planner.pick_target(red, x, y), model.home).q
    R = model.tcp_pose(q)[1]
    step = (R @ across)[:2]
    step = step / np.linalg.norm(step) * (g.open_cm / 2 + g.jaw_thickness_cm / 2)
    return [
        SceneObject(color="red", x=x, y=y),
        SceneObject(color="red", x=round(x + step[0], 2), y=round(y + step[1], 2)),
    ]


def test_a_pick_with_a_neighbour_under_a_jaw_is_refused_naming_both() -> None:
    config = _config("sim_mujoco", "task.scene=[]")
    scene = _blocking_pair(config)
    model = ArmModel(config.arm)
    collision = collision_model(config, model)
    planner = Planner(config, model, collision)
    red = config.task.class_named("red")
    collision.set_world([("red1", "red", scene[0].x, scene[0].y),
                         ("red2", "red", scene[1].x, scene[1].y)])  # fmt: skip
    route = planner.plan(
        Route("red1", "red", "pick", 1, planner.pick_target(red, scene[0].x, scene[0].y)),
        model.home,
        target="red1",
    )
    assert not route.planned and route.failure_kind == "collision"
    assert route.failure is not None
    assert "gripper_jaw_" in route.failure and "red2" in route.failure
    assert "shoulder" in route.failure  # the pose, joint by joint


def test_the_sort_sends_nothing_of_a_refused_pick(monkeypatch: pytest.MonkeyPatch) -> None:
    """Both picks of a blocking pair refused: each is left with the reason ``collision``,
    and the bus received nothing but the home pose (a spy on the real simulated bus)."""
    from mearm.task.rig import run_sort

    config = _config("sim_mujoco", "simulator=kinematic", "task.scene=[]")
    sent: list[dict[str, float]] = []
    real_move = SimArm.move

    def spy(self: SimArm, command: ArmCommand) -> None:
        sent.append(dict(command.joints))
        real_move(self, command)

    monkeypatch.setattr(SimArm, "move", spy)
    report = run_sort(config, scene=_blocking_pair(config), echo=None)
    assert report.outcome.left == {"collision": 2}
    home = config.arm.home()
    assert sent and all(all(abs(joints[n] - home[n]) < 1e-9 for n in joints) for joints in sent)
    assert all("red" in s.reason or "gripper" in s.reason for s in report.skipped)


#: The MeArm v1 twin's table where blue1's pick is blocked by blue2 while the arm, over
#: the green bin, hides blue2 from the camera (seed 871011's objects, fewer of them; the
#: blues 1 cm nearer the green bin: the jaws rise straight up out of a bin after a place,
#: and the arm risen over it hides blue2 there).
HIDDEN_BLOCKER = [
    SceneObject(color="blue", x=11.36, y=13.39),
    SceneObject(color="red", x=-7.63, y=18.0),
    SceneObject(color="blue", x=8.75, y=15.32),
    SceneObject(color="green", x=2.27, y=18.04),
]


@pytest.mark.heavy
def test_a_pick_blocked_by_an_object_the_arm_hides_waits_for_it() -> None:
    """Looked at from over the green bin, blue1's pick is blocked by blue2, which the arm
    hides there: blue1 waits (it was left as ``collision``, as if nothing could clear its
    way), home sees blue2, and once blue2 is sorted blue1's pick is clear."""
    from mearm.task.pick_place import PickAndPlace
    from mearm.task.rig import run_sort

    config = _config("sim_mearm_v1_mujoco_perspective")
    refused: list[str] = []
    set_aside = PickAndPlace._planned_or_set_aside

    def spy(self: PickAndPlace, obj, failed):
        if failed.failure_kind == "collision":
            refused.append(obj.id)
        return set_aside(self, obj, failed)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(PickAndPlace, "_planned_or_set_aside", spy)
        report = run_sort(config, scene=HIDDEN_BLOCKER, echo=None)
    assert refused == ["blue1"]  # the case under test arose
    assert report.outcome.line() == "sorted 4 of 4 objects"
    picks = [r.object_id for r in report.routes if r.step == "pick" and r.success]
    assert picks.index("blue2") < picks.index("blue1")


# --------------------------------------------------------------------------- the check


def test_conservative_advancement_never_steps_over_a_wall() -> None:
    """Two poses on either side of a bin wall, checked as one segment: the contact is
    found, although neither end touches anything."""
    config, model, planner, q0, target = _across_the_red_bin()
    assert planner.collision is not None
    q1 = planner.solver.solve(target, q0).q
    c = planner.collision
    assert c.first_contact(np.array([q0])) is None
    assert c.first_contact(np.array([q1])) is None
    contact = c.first_contact(np.array([q0, q1]))
    assert contact is not None and contact.obstacle.startswith("bin_red_")
    assert contact.distance_cm <= config.task.clearance_cm + TOUCH_CM


def test_a_gripper_servo_of_fine_units_does_not_slow_the_check() -> None:
    """The check's step bound counts the jaws as open as the world holds them, not as far
    as their servo's range would reach: at 0.1 µs a unit that range is kilometres, and a
    path took hundreds of times the checks (a 3-object sort 0.7 → 7.9 s)."""
    counts = []
    for overrides in ((), ("arm.tool.gripper.servo.us_per_unit=0.1",)):
        config = _config("sim", *overrides)
        model = ArmModel(config.arm)
        c = collision_model(config, model)
        lo, hi = model.chain.actuated_lower, model.chain.actuated_upper
        # (at 0.3 of each range the jaws, hanging below the TCP, are in the table)
        path = np.array([model.chain.full(lo + f * (hi - lo)) for f in (0.4, 0.55, 0.7)])
        assert c.first_contact(path) is None
        counts.append(c.checks)
    assert counts[1] == counts[0] < 100, counts


# --------------------------------------------------------------------------- a start within


#: An object 0.1 cm from the green bin's +x wall, as the camera of the paper's twin sees it
#: (it stands 0.2 cm off the bin's corner and is seen 0.3 cm nearer): the jaws come down
#: clear of the wall, and close on an object held within the clearance of it.
BESIDE_THE_GREEN_BIN = SceneObject(color="green", x=-15.5, y=48.8)


def _held_beside_the_wall() -> tuple[Config, ArmModel, Planner, np.ndarray]:
    """The paper's twin arm holding a green object 0.1 cm from the green bin's +x wall."""
    config = _config("sim_mujoco", "task.scene=[]")
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    planner = Planner(config, model, collision)
    green = config.task.class_named("green")
    x = green.bin_cm[0] + green.bin_inner_width_cm / 2 + 0.3 + 0.1 + green.diameter_cm / 2
    y = green.bin_cm[1] + 3.0
    collision.set_world([("green1", "green", x, y)])
    pick = planner.plan(Route("green1", "green", "pick", 1, planner.pick_target(green, x, y)),
                        model.home, target="green1")  # fmt: skip
    assert pick.planned and pick.plan is not None
    collision.set_world([], opening_cm=green.diameter_cm, held=("green1", "green"))
    return config, model, planner, pick.plan.q


def test_a_start_within_the_clearance_may_be_left_but_never_closer() -> None:
    """Held 0.1 cm from the wall (inside the 0.3 cm clearance), the object may be lifted:
    a path that keeps that pair no closer passes the check. Toward the wall it is refused,
    naming the pair and the distance it started at; the table, and an object it does not
    start beside, keep their checks as strict as ever."""
    config, model, planner, q0 = _held_beside_the_wall()
    c = planner.collision
    assert c is not None
    g, part, obstacle = c.gap(q0)
    assert g < -0.1 * M_PER_CM and part == "held green1" and obstacle.startswith("bin_green_")
    assert c.first_contact(np.array([q0])) is None  # standing still is not coming closer
    x, y, z = model.fk_cm(q0)
    approach = planner.pick_target(config.task.class_named("green"), x, y).approach
    lift = planner.plan(Route("green1", "green", "lift", 1, planner.up_from(q0, z + 6.0, approach)),
                        q0)  # fmt: skip
    assert lift.planned and lift.plan is not None
    assert lift.plan.ee_path_cm[-1][2] > z + 5.9

    def path_to(dx: float, dy: float, dz: float) -> np.ndarray:
        moved = planner.solver.solve(IKTarget((x + dx, y + dy, z + dz), approach), q0)
        assert moved.converged
        return moved.q_path

    toward = c.first_contact(path_to(-0.1, 0.0, 0.0))
    assert toward is not None and toward.obstacle.startswith("bin_green_")
    assert toward.start_cm is not None and toward.distance_cm < toward.start_cm < 0.3
    assert "closer than the" in toward.describe(model.chain.names, model.chain.scale)
    down = c.first_contact(path_to(0.5, 0.0, -0.5))  # away from the wall, into the table
    assert down is not None and down.obstacle == "table" and down.start_cm is None
    # a blue just beyond the clearance on the side it moves away to: refused on the way
    bare = collision_model(config, model, clearance_cm=config.task.clearance_cm, bins=[])
    for bx in np.arange(x + 1.0, x + 6.0, 0.05):
        bare.set_world([("blue1", "blue", bx, y)], held=("green1", "green"))
        if bare.gap(q0)[0] >= TOUCH_CM * M_PER_CM:
            break
    else:
        pytest.fail("no place beside the held object keeps the blue out of the clearance")
    assert bare.gap(q0)[0] < 0.1 * M_PER_CM  # just beyond it
    c.set_world([("blue1", "blue", bx, y)], held=("green1", "green"))
    side = c.first_contact(path_to(1.0, 0.0, 0.0))
    assert side is not None and side.obstacle == "obj_blue1" and side.start_cm is None
    assert side.distance_cm <= config.task.clearance_cm + TOUCH_CM


@pytest.mark.heavy
def test_an_object_held_beside_a_bin_wall_is_sorted() -> None:
    """The twin picks the object beside the green bin's wall; held, it is within the
    clearance of the wall (the lift starts there), and it is lifted and sorted, not put
    back as "bin unreachable"."""
    from mearm.task.rig import run_sort
    from mearm.task.sorter import Sorter

    config = _config("sim_mujoco")
    lifts: list[float] = []
    lift_and_place = Sorter._lift_and_plan_place

    def spy(self: Sorter, *args):  # the gap where the object is held, before the lift
        lifts.append(self.collision.gap(self.executor.q_now())[0] / M_PER_CM)
        return lift_and_place(self, *args)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(Sorter, "_lift_and_plan_place", spy)
        report = run_sort(config, scene=[BESIDE_THE_GREEN_BIN], echo=None)
    assert report.outcome.line() == "sorted 1 of 1 objects"
    assert lifts and min(lifts) < 0.0  # it did start within the clearance


@pytest.mark.heavy
def test_a_pick_with_no_way_out_is_left_naming_what_it_ended_beside() -> None:
    """Where no route leaves the pick's end without coming closer to the wall (every way
    up turned toward it, here), the object is put back and left as ``collision``, naming
    the wall the pick ended beside: the bin was never the problem."""
    from mearm.task.rig import run_sort

    config = _config("sim_mujoco")
    away_from = CollisionModel.away_from

    def toward(self: CollisionModel, q, *, target=None):
        way = away_from(self, q, target=target)
        return None if way is None else -way

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(CollisionModel, "away_from", toward)
        report = run_sort(config, scene=[BESIDE_THE_GREEN_BIN], echo=None)
    assert report.outcome.left == {"collision": 1}
    (skip,) = report.skipped
    assert skip.reason.startswith("the pick ended beside bin_green_"), skip.reason
    assert "within task.clearance_cm" in skip.reason and "bin unreachable" not in skip.reason


# --------------------------------------------------------------------------- a start in contact


def _held_into_a_cylinder() -> tuple[Config, ArmModel, Planner, np.ndarray, np.ndarray]:
    """The shapes twin's arm holding a red cube 0.22 cm into a red cylinder, as the
    planner sees them (each the circle around its footprint): the cube of seed 992004,
    which slipped from the jaws and fell beside the cylinder. Also the way from the
    cylinder to the cube in the table plane, (2,)."""
    config = _config("sim_shapes_mujoco", "task.scene=[]")
    model = ArmModel(config.arm)
    collision = collision_model(config, model, clearance_cm=config.task.clearance_cm)
    planner = Planner(config, model, collision)
    cube, cylinder = config.task.class_named("red_cube"), config.task.class_named("red_cylinder")
    x, y = 6.9, 50.1
    collision.set_world([("red_cube1", "red_cube", x, y)])
    pick = planner.plan(Route("red_cube1", "red_cube", "pick", 1, planner.pick_target(cube, x, y)),
                        model.home, target="red_cube1")  # fmt: skip
    assert pick.planned and pick.plan is not None
    out = np.array([0.8, -0.6])
    apart = cube.footprint_radius_cm + cylinder.footprint_radius_cm - 0.22
    cx, cy = np.array([x, y]) - apart * out
    collision.set_world([("red_cylinder2", "red_cylinder", cx, cy)], opening_cm=cube.diameter_cm,
                        held=("red_cube1", "red_cube"))  # fmt: skip
    return config, model, planner, pick.plan.q, out


def test_a_start_in_contact_may_be_left_but_never_pressed_further_in() -> None:
    """Held 0.22 cm into a cylinder, the cube may be lifted straight up and moved away
    from it: that pair may only come apart. Pushed further in it is refused, naming the
    pair and the distance it started at, and the table keeps its check."""
    config, model, planner, q0, out = _held_into_a_cylinder()
    c = planner.collision
    assert c is not None
    g, part, obstacle = c.gap(q0)
    start_cm = g / M_PER_CM + config.task.clearance_cm
    assert part == "held red_cube1" and obstacle == "obj_red_cylinder2"
    assert -0.25 < start_cm < -0.19
    assert c.first_contact(np.array([q0])) is None  # standing still is not coming closer
    way = c.away_from(q0)
    assert way is not None and float(way @ out) > 0.9  # (the lift's target moves that way)
    x, y, z = model.fk_cm(q0)
    approach = planner.pick_target(config.task.class_named("red_cube"), x, y).approach
    up = planner.up_from(q0, z + 6.0, approach)
    lift = planner.plan(Route("red_cube1", "red_cube", "lift", 1, up), q0)
    assert lift.planned and lift.plan is not None, lift.failure
    assert lift.plan.ee_path_cm[-1][2] > z + 5.9

    def path_to(dx: float, dy: float, dz: float) -> np.ndarray:
        moved = planner.solver.solve(IKTarget((x + dx, y + dy, z + dz), approach), q0)
        assert moved.converged
        return moved.q_path

    assert c.first_contact(path_to(*(0.5 * out), 0.5)) is None  # away, and up
    further = c.first_contact(path_to(*(-0.1 * out), 0.0))
    assert further is not None and further.obstacle == "obj_red_cylinder2"
    assert further.start_cm is not None and further.distance_cm < further.start_cm < 0.0
    assert "closer than the" in further.describe(model.chain.names, model.chain.scale)
    down = c.first_contact(path_to(*(0.5 * out), -0.5))  # away from the cylinder, into the table
    assert down is not None and down.obstacle == "table" and down.start_cm is None


def _ctrl_c_at(call, line: int) -> bool:
    """``call()`` with Ctrl-C (a real SIGINT) sent before its ``line``-th line run in
    mearm's code, as one lands between any two lines; whether it stopped ``call``."""
    count = 0

    def local(frame, event, arg):  # noqa: ANN001, ANN202
        nonlocal count
        if event == "line":
            count += 1
            if count == line:
                signal.raise_signal(signal.SIGINT)
        return local

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.settrace(lambda frame, event, arg: local if "mearm" in frame.f_code.co_filename else None)
    try:
        call()
    except KeyboardInterrupt:
        return True
    finally:
        sys.settrace(None)
        signal.signal(signal.SIGINT, previous)
    return False


@pytest.mark.parametrize("grows", [False, True], ids=["moved", "rebuilt"])
def test_a_ctrl_c_never_leaves_the_model_between_two_worlds(grows: bool) -> None:
    """A Ctrl-C between any two lines of putting a new world in the model (objects moved,
    the jaws, the one held; or a model rebuilt for more objects than places) leaves the
    checks seeing the world before or the new one whole. The parking after a Ctrl-C just
    as the sort set the world of a lifted object checked its way home in half of it (the
    object's place switched off, still checked: "gripper_jaw_left_pad comes within 0.11
    cm of red_0"), and refused it (``make soak``)."""
    config = _config("sim")
    model = ArmModel(config.arm)
    names = config.task.class_names
    first = [("a", names[0], 0.0, 35.0), ("b", names[1], 8.0, 40.0)]
    n = 7 if grows else 3  # sim's table holds 4 reds: places for 6, and 7 rebuild it
    second = [(f"o{k}", names[0], -15.0 + 3.0 * k, 30.0 + 2.0 * k) for k in range(n)]
    world = {"opening_cm": 3.0, "held": ("a", names[0]), "table_below_cm": 0.4}
    rng = np.random.default_rng(4104)
    chain = model.chain
    poses = [chain.full(rng.uniform(chain.actuated_lower, chain.actuated_upper)) for _ in range(8)]

    def seen(collision: CollisionModel) -> list[object]:
        c = collision.first_contact([model.home, *poses])
        return [collision.gap(q) for q in poses] + [c and (c.arm_part, c.obstacle, c.distance_cm)]

    before = collision_model(config, model)
    before.set_world(first, opening_cm=5.0)
    after = collision_model(config, model)
    after.set_world(second, **world)
    worlds = [seen(before), seen(after)]
    assert worlds[0] != worlds[1]
    line, cut = 1, True
    while cut:
        collision = collision_model(config, model)
        collision.set_world(first, opening_cm=5.0)
        cut = _ctrl_c_at(partial(collision.set_world, second, **world), line)
        assert seen(collision) in worlds, f"Ctrl-C before line {line}"
        line += 37 if grows else 2  # (each line of a rebuild takes long to test)
    assert line > 20  # (the world took that many lines to put in)
