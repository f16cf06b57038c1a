"""The view of the physical twin: the arm at its measured joints and jaws, the objects where
the MuJoCo physics has them (carried in the jaws, dropped into their bins).

Real MuJoCo and a real meshcat server: a sort of two objects on the twin, the view
recording what it draws at every push next to what the twin measures at that instant.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import pytest
from conftest import ROOT, browser_or_skip
from viewscene import scene

from mearm.config import Config, SceneObject, load_config
from mearm.exceptions import ViewInputError
from mearm.task.execute import Executor, twin_object_ids
from mearm.task.rig import open_rig
from mearm.task.sorter import Sorter
from mearm.view import ArmView, TwinBody

TWIN = load_config(ROOT / "configs" / "sim_mujoco.yaml")
#: Two of the paper's objects (its M3 and H2): red is sorted first, green waits on the table.
SCENE = [SceneObject(color="red", x=-0.40, y=42.01), SceneObject(color="green", x=-4.57, y=47.58)]
W, H = 800, 500  # screenshot size [px]


@dataclass
class Push:
    """One push to the view: what it drew, and what the twin measured then."""

    drawn_q: np.ndarray
    drawn_opening_cm: float
    drawn: dict[str, TwinBody]
    measured_q: np.ndarray
    measured_opening_cm: float
    measured: dict[str, tuple[np.ndarray, np.ndarray]]  # id -> (position_cm, quat)
    commanded_q: np.ndarray
    ee_cm: np.ndarray


class RecordingView(ArmView):
    """The real view; after each show_bodies it records its own state and the twin's."""

    def __init__(self, *args: Any, bus: Any, on_push: Any = None, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.bus = bus
        self.pushes: list[Push] = []
        self.on_push = on_push

    def show_bodies(self, q: Any, opening_cm: float, objects: Any) -> None:
        super().show_bodies(q, opening_cm, objects)
        bus, chain = self.bus, self.model.chain
        measured = {}
        for oid in twin_object_ids(bus) or ():
            pose = bus.object_pose(oid)
            measured[oid] = (pose.position_cm.copy(), pose.quat.copy())
        self.pushes.append(
            Push(
                self.joints.copy(),
                self.opening_cm,
                self.bodies,
                chain.from_named(bus.actual_joints),
                bus.opening_cm,
                measured,
                chain.from_named(bus.state.joints),
                bus.ee_cm.copy(),
            )
        )
        if self.on_push is not None:
            self.on_push(self, self.pushes[-1])


def sort_on_the_twin(on_push: Any = None) -> tuple[RecordingView, dict[str, Any], Any]:
    """Sort SCENE on the twin with a recording view; its state and the twin's at the end."""
    with open_rig(TWIN, SCENE) as rig:
        with RecordingView(rig.model, TWIN, bus=rig.bus, on_push=on_push) as view:
            report = Sorter(TWIN, rig.camera, rig.bus, model=rig.model, view=view, echo=None,
                            in_bins=rig.in_bins).run()  # fmt: skip
            final = {oid: rig.bus.object_pose(oid).position_cm.copy() for oid in ("red1", "green1")}
            end = {
                "report": report,
                "final": final,
                "in_bin": rig.bus.objects_in_bin(),
                "tree": scene(view),
                "bodies": view.bodies,
            }
    return view, end, rig


@pytest.fixture(scope="module")
def twin_sort():
    view, end, _ = sort_on_the_twin()
    return view.pushes, end


# --------------------------------------------------------------------------- the sort


@pytest.mark.heavy
def test_the_view_draws_what_the_twin_measures_at_every_push(twin_sort):
    """Each push draws the measured joints, jaws and every object's pose, exactly; it is
    pushed after every streamed move (dozens of pushes for two objects)."""
    pushes, end = twin_sort
    assert end["report"].outcome.sorted == {"red": 1, "green": 1, "blue": 0}
    assert len(pushes) > 30
    for p in pushes:
        np.testing.assert_allclose(p.drawn_q, p.measured_q, atol=1e-12)
        assert p.drawn_opening_cm == pytest.approx(p.measured_opening_cm, abs=1e-12)
        assert set(p.drawn) == {"red1", "green1"}
        for oid, (pos, quat) in p.measured.items():
            body = p.drawn[oid]
            assert body.class_name == oid.rstrip("0123456789")
            np.testing.assert_allclose(body.position_cm, pos, atol=1e-9)
            np.testing.assert_allclose(body.quat, quat / np.linalg.norm(quat), atol=1e-9)


def test_the_drawn_arm_is_the_measured_one_not_the_commanded_one(twin_sort):
    """The servos lag and play: the drawn joints differ from the commanded ones by more
    than a degree at times, while they equal the measured ones (previous test)."""
    pushes, _ = twin_sort
    lag = max(float(np.max(np.abs(p.drawn_q - p.commanded_q))) for p in pushes)
    assert np.degrees(lag) > 1.0, np.degrees(lag)


def test_the_jaws_are_drawn_closing_on_the_object_and_opening_again(twin_sort):
    pushes, _ = twin_sort
    gripper = TWIN.arm.tool.gripper
    openings = np.array([p.drawn_opening_cm for p in pushes])
    diameter = TWIN.task.class_named("red").diameter_cm
    # closed on the object: stopped by it, well short of the commanded closed_cm
    assert openings.min() == pytest.approx(diameter, abs=0.3)
    assert openings.min() > gripper.closed_cm + 0.5
    assert openings[-1] == pytest.approx(gripper.open_cm, abs=0.1)


def test_a_carried_object_is_drawn_above_the_table_in_the_jaws(twin_sort):
    """While carried, red1 is drawn well above the table, under the TCP where the jaws
    hang, and away from where it lay; green1 stays drawn where it lies meanwhile."""
    pushes, _ = twin_sort
    red = TWIN.task.class_named("red")
    start = np.array([SCENE[0].x, SCENE[0].y])
    carried = [p for p in pushes if p.drawn["red1"].position_cm[2] > red.height_cm + 3.0]
    assert len(carried) >= 3
    moved = [p for p in carried if np.linalg.norm(p.drawn["red1"].position_cm[:2] - start) > 5]
    assert moved, "red1 is never drawn carried away from its spot"
    for p in moved:
        xyz = np.array(p.drawn["red1"].position_cm)
        assert np.linalg.norm(xyz[:2] - p.ee_cm[:2]) < 1.0  # in the jaws, under the TCP
        assert p.ee_cm[2] - xyz[2] == pytest.approx(TWIN.arm.tool.tcp_above_grip_cm, abs=1.0)
        green = np.array(p.drawn["green1"].position_cm)
        np.testing.assert_allclose(green, [SCENE[1].x, SCENE[1].y, 0.5], atol=0.1)


def test_sorted_objects_are_drawn_in_their_bins(twin_sort):
    """After the sort both objects are drawn lying in their own bins, where the physics
    has them, in the meshcat scene itself; the detections are not drawn as well."""
    pushes, end = twin_sort
    assert end["in_bin"] == {"red1": "red", "green1": "green"}
    for oid, name in end["in_bin"].items():
        cls = TWIN.task.class_named(name)
        drawn = np.array(end["bodies"][oid].position_cm)
        assert cls.in_bin(drawn[0], drawn[1]), (oid, drawn)
        assert 0.0 < drawn[2] < 5.0  # inside the bin, not on the table plane
        np.testing.assert_allclose(drawn, end["final"][oid], atol=0.5)
        node = end["tree"][f"/meshcat/twin/objects/{oid}"]
        assert node["object"]["materials"][0]["color"] == (
            (cls.draw_rgb[0] << 16) | (cls.draw_rgb[1] << 8) | cls.draw_rgb[2]
        )
        np.testing.assert_allclose(node["transform"][:3, 3], drawn / 100, atol=1e-6)
    assert not [p for p, n in end["tree"].items() if p.startswith("/meshcat/objects/") and
                "object" in n]  # fmt: skip


# --------------------------------------------------------------------------- render


@pytest.mark.heavy
def test_the_render_shows_the_carried_object_in_the_air(tmp_path):
    """Chromium's render while red1 is carried between its spot and its bin (over the
    bare table, nothing else red behind it): red where its body is drawn, none left at
    the spot it was picked from."""
    browser = browser_or_skip()
    shot: dict[str, Any] = {}

    start = np.array([SCENE[0].x, SCENE[0].y])
    bin_xy = np.array(TWIN.task.class_named("red").bin_cm[:2])

    def at_the_top(view: ArmView, push: Push) -> None:
        xyz = np.array(push.drawn["red1"].position_cm)
        away = min(np.linalg.norm(xyz[:2] - start), np.linalg.norm(xyz[:2] - bin_xy))
        if not shot and xyz[2] > 4.0 and away > 7.0:
            shot["png"] = view.screenshot(tmp_path / "carry.png", width_px=W, height_px=H,
                                          browser=browser)  # fmt: skip
            shot["red"] = np.array(push.drawn["red1"].position_cm)
            shot["camera"] = view.camera

    sort_on_the_twin(at_the_top)
    assert shot, "red1 was never drawn carried between its spot and its bin"
    img = cv2.imread(str(shot["png"]))
    hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV)
    h, s, v = (hsv[..., i].astype(int) for i in range(3))
    red = ((h < 8) | (h > 172)) & (s > 120) & (v > 60)
    cam = shot["camera"]

    def red_near(point_cm: np.ndarray, r: int = 4) -> float:
        u, v = np.round(cam.project(point_cm, W, H)[0]).astype(int)
        return float(red[v - r : v + r + 1, u - r : u + r + 1].mean())

    assert red_near(shot["red"]) > 0.3, "no red where the carried object is drawn"
    assert red_near(np.array([SCENE[0].x, SCENE[0].y, 0.5])) == 0.0, "red left on its spot"


# --------------------------------------------------------------------------- no twin


def test_without_the_twin_the_view_shows_the_commanded_joints():
    """The kinematic simulator measures no world: the view gets the commanded joints and
    the detections as before; no twin body is drawn."""
    config = Config()
    with open_rig(config, [SceneObject(color="red", x=-0.40, y=42.01)]) as rig:
        assert twin_object_ids(rig.bus) is None
        rig.bus.connect()
        with ArmView(rig.model, config) as view:
            ex = Executor(config, rig.bus, rig.model, view)
            q = rig.model.home.copy()
            q[0] += np.radians(10)
            q = rig.model.chain.full(rig.model.chain.actuated_of(q))
            ex.send(q, "travel", closed=False)
            np.testing.assert_allclose(view.joints, q)
            view.set_objects([("red1", "red", -0.4, 42.0)])
            assert not view.twin_shown and view.bodies == {}
            assert "/meshcat/objects/red1" in scene(view)


def test_twin_executor_pushes_at_most_every_nth_move_and_always_at_route_ends():
    with open_rig(TWIN, SCENE) as rig:
        rig.bus.connect()
        with RecordingView(rig.model, TWIN, bus=rig.bus) as view:
            ex = Executor(TWIN, rig.bus, rig.model, view, view_every=5)
            assert ex.twin_ids == ("red1", "green1")
            q = rig.model.home.copy()
            q[0] -= np.radians(60)  # 60° within the servos' speed and acceleration
            moves = len(ex.timed(ex.joint_path(q)).q) - 1
            assert moves > 5
            ex.move_joints(q, "travel", closed=False)
            # after every 5th move, and at the path's end
            assert len(view.pushes) == moves // 5 + (moves % 5 != 0)
            ex.set_tool("travel", closed=True)  # the tool: one move, the hold, then a push
            assert len(view.pushes) == moves // 5 + (moves % 5 != 0) + 1
            assert view.pushes[-1].drawn_opening_cm < TWIN.arm.tool.gripper.open_cm - 1.0
        with pytest.raises(ValueError, match="view_every"):
            Executor(TWIN, rig.bus, rig.model, None, view_every=0)


# --------------------------------------------------------------------------- the view alone


def test_show_bodies_refuses_bad_input_and_changes_nothing(model):
    config = Config()
    with ArmView(model, config) as view:
        view.set_objects([("red1", "red", 0.0, 40.0)])
        good = ("red1", "red", [0.0, 40.0, 0.5], [1.0, 0.0, 0.0, 0.0])
        for objects, match in [
            ([("red1", "purple", [0, 40, 0.5], [1, 0, 0, 0])], "purple"),
            ([("red/1", "red", [0, 40, 0.5], [1, 0, 0, 0])], "without '/'"),
            ([("red1", "red", [0, 40], [1, 0, 0, 0])], "3 finite numbers"),
            ([("red1", "red", [0, 40, np.nan], [1, 0, 0, 0])], "3 finite numbers"),
            ([("red1", "red", [0, 40, 0.5], [0, 0, 0, 0])], "quaternion"),
            ([good, good], "each id at most once"),
            (["red1"], "position_cm"),
        ]:
            with pytest.raises(ViewInputError, match=re.escape(match)):
                view.show_bodies(model.home, 4.0, objects)
        with pytest.raises(ViewInputError):
            view.show_bodies([np.nan] * model.chain.n, 4.0, [good])
        assert not view.twin_shown and view.bodies == {}
        assert "/meshcat/objects/red1" in scene(view)

        # a tilted body, its quaternion normalised; the detections no longer drawn
        half = np.radians(30)
        tilted = ("red1", "red", [1.0, 40.0, 3.0], [2 * np.cos(half), 2 * np.sin(half), 0, 0])
        view.show_bodies(model.home, 2.5, [tilted])
        assert view.twin_shown and view.opening_cm == 2.5
        body = view.bodies["red1"]
        np.testing.assert_allclose(body.quat, [np.cos(half), np.sin(half), 0, 0])
        tree = scene(view)
        assert "object" not in tree.get("/meshcat/objects/red1", {})
        pose = tree["/meshcat/twin/objects/red1"]["transform"]
        np.testing.assert_allclose(pose[:3, 3], [0.01, 0.40, 0.03])
        # the cylinder (three.js y) stands along the body's z, tilted 60° about x
        np.testing.assert_allclose(pose[:3, 1], [0, -np.sin(2 * half), np.cos(2 * half)],
                                   atol=1e-12)  # fmt: skip

        # detections are still recorded, not drawn; a body no longer listed goes
        view.set_objects([("green1", "green", 5.0, 45.0)])
        assert set(view.objects) == {"green1"}
        view.show_bodies(model.home, 2.5, [TwinBody("blue1", "blue", (0, 50, 0.5), (1, 0, 0, 0))])
        tree = scene(view)
        assert set(view.bodies) == {"blue1"}
        assert "object" not in tree.get("/meshcat/twin/objects/red1", {})
        assert "object" not in tree.get("/meshcat/objects/green1", {})
