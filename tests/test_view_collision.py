"""The collision model in the view, and the route lines' toggle.

A real meshcat server (the scene a browser connecting now would receive, decoded) and,
for one render, real headless Chromium: the planner's collision shapes appear under
``/meshcat/collision`` when shown and are gone when hidden, each where Pinocchio puts it
for the joints drawn; a model the view keeps in step with its objects and jaws; the
sort's and the preview's ``--collision``.
"""

from __future__ import annotations

import os
import subprocess
import sys

import cv2
import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT, browser_or_skip
from viewscene import scene

from mearm.cli import run
from mearm.config import Config, load_config
from mearm.exceptions import ViewError, ViewInputError
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import bin_shapes, object_centre_m
from mearm.kinematics.collision import CollisionModel
from mearm.sim.table_collision import collision_model
from mearm.sort import main as sort_main
from mearm.tools import preview
from mearm.view import ArmView
from mearm.view.collision_drawing import COLLISION_ARM_RGB, COLLISION_OPACITY, COLLISION_WORLD_RGB

CONFIG = Config()
W, H = 960, 600  # screenshot size [px]


@pytest.fixture
def view(model: ArmModel):
    with ArmView(model, CONFIG, port=0) as v:
        yield v


@pytest.fixture
def collision(model: ArmModel) -> CollisionModel:
    return collision_model(CONFIG, model, clearance_cm=CONFIG.task.clearance_cm)


def drawn(view: ArmView, prefix: str) -> set[str]:
    """Names of the objects drawn directly under ``/meshcat/<prefix>/``."""
    head = f"/meshcat/{prefix}/"
    return {p[len(head) :] for p, n in scene(view).items() if p.startswith(head) and "object" in n}


def bin_names() -> set[str]:
    return {s.name for c in CONFIG.task.classes for s in bin_shapes(c, 0)}


def placements(collision: CollisionModel, q: np.ndarray) -> dict[str, np.ndarray]:
    """Each geometry object's pose by name, computed here by Pinocchio (oMg), (4, 4) [m]."""
    pm = collision.model.model
    g = collision.geometry
    gdata = pin.GeometryData(g)
    pin.updateGeometryPlacements(pm, pm.createData(), g, gdata, np.asarray(q, float))
    return {o.name: gdata.oMg[k].homogeneous for k, o in enumerate(g.geometryObjects)}


def assert_drawn_where_pinocchio_puts_them(view: ArmView, collision: CollisionModel, q) -> None:
    tree = scene(view)
    poses = placements(collision, q)
    shown = [p for p, n in tree.items() if p.startswith("/meshcat/collision/") and "object" in n]
    assert shown
    for path in shown:
        name = path.rsplit("/", 1)[1]
        np.testing.assert_allclose(tree[path]["transform"], poses[name], atol=1e-9, err_msg=name)


# --------------------------------------------------------------------------- on and off


def test_the_shapes_appear_when_on_and_go_when_off(view: ArmView, collision: CollisionModel):
    """Every arm shape, every bin wall and floor and the object on the table are drawn,
    translucent, the arm's in one colour and the rest in another; the table's half-space
    is not; hiding removes them all and showing again draws them again."""
    collision.set_world([("red1", "red", 0.0, 40.0)])
    assert view.collision is None
    view.show_collision(collision)
    assert view.collision is collision
    arm = drawn(view, "collision/arm")
    world = drawn(view, "collision/world")
    assert arm == {s.name for s in collision.arm_shapes}
    objects = {n for n in world if n.startswith("obj_")}
    assert world - objects == bin_names()
    assert len(objects) == 1
    assert "table" not in arm | world
    tree = scene(view)
    for group, rgb in (("arm", COLLISION_ARM_RGB), ("world", COLLISION_WORLD_RGB)):
        for name in drawn(view, f"collision/{group}"):
            material = tree[f"/meshcat/collision/{group}/{name}"]["object"]["materials"][0]
            assert material["color"] == rgb, name
            assert material["transparent"] and material["opacity"] == COLLISION_OPACITY
    assert_drawn_where_pinocchio_puts_them(view, collision, view.joints)

    view.hide_collision()
    assert view.collision is None
    assert drawn(view, "collision/arm") == set() and drawn(view, "collision/world") == set()
    view.show_joints(view.model.home)  # no shape comes back with the arm
    assert drawn(view, "collision/arm") == set()
    view.hide_collision()  # twice is fine

    view.show_collision()  # the one drawn last
    assert view.collision is collision
    assert drawn(view, "collision/arm") == arm and drawn(view, "collision/world") == world


def test_shapes_are_the_models_sizes(view: ArmView, collision: CollisionModel):
    """Boxes and cylinders drawn at the coal shapes' sizes; cylinders turned to stand
    along their shape's z, either way up (three.js draws them along y)."""
    collision.set_world([("blue1", "blue", 5.0, 45.0)])
    view.show_collision(collision)
    tree = scene(view)
    kinds = set()
    for obj in collision.geometry.geometryObjects:
        path = next((f"/meshcat/collision/{g}/{obj.name}" for g in ("arm", "world")
                     if f"/meshcat/collision/{g}/{obj.name}" in tree), None)  # fmt: skip
        if path is None or "object" not in tree[path]:
            continue
        drawn_obj = tree[path]["object"]
        geometry = drawn_obj["geometries"][0]
        kinds.add(geometry["type"])
        if geometry["type"] == "BoxGeometry":
            size = [geometry["width"], geometry["height"], geometry["depth"]]
            np.testing.assert_allclose(size, 2 * obj.geometry.halfSide, err_msg=obj.name)
        else:
            assert geometry["type"] == "CylinderGeometry", obj.name
            assert geometry["height"] == pytest.approx(2 * obj.geometry.halfLength)
            assert geometry["radiusTop"] == pytest.approx(obj.geometry.radius)
            matrix = np.array(drawn_obj["object"]["matrix"]).reshape(4, 4).T  # column-major
            np.testing.assert_allclose(np.abs(matrix[:3, 1]), [0, 0, 1], atol=1e-12)
    assert kinds == {"BoxGeometry", "CylinderGeometry"}


def test_the_shapes_follow_the_arm(view: ArmView, collision: CollisionModel, model: ArmModel):
    """For two poses every shape sits where Pinocchio's oMg puts it; the arm's move with
    it, the bins stay; show_collision(q) draws the arm there too; show_bodies moves them."""
    view.show_collision(collision)
    q1 = model.home
    assert_drawn_where_pinocchio_puts_them(view, collision, q1)
    before = scene(view)
    q2 = model.chain.full(np.radians([70.0, 60.0, -100.0]))
    view.show_joints(q2[model.chain.actuated_index])  # the actuated joints alone
    assert_drawn_where_pinocchio_puts_them(view, collision, q2)
    after = scene(view)
    mount = "/meshcat/collision/arm/gripper_mount"
    moved = after[mount]["transform"][:3, 3] - before[mount]["transform"][:3, 3]
    assert np.linalg.norm(moved) > 0.05
    wall = "/meshcat/collision/world/bin_red_wall_px"
    np.testing.assert_array_equal(after[wall]["transform"], before[wall]["transform"])

    q3 = q1.copy()
    q3[0] -= np.radians(30)
    view.hide_collision()
    view.show_collision(collision, q3)
    assert view.joints == pytest.approx(q3)
    assert_drawn_where_pinocchio_puts_them(view, collision, q3)

    view.show_bodies(q2, 2.0, [])  # the twin's measured joints
    assert_drawn_where_pinocchio_puts_them(view, collision, q2)


def test_an_external_model_is_drawn_as_its_owner_sets_it(view: ArmView, collision: CollisionModel):
    """Without track_world the view changes nothing in the model: its objects stay its
    owner's; what the owner sets (a rebuilt model, a held object) is drawn at the next
    pose."""
    view.show_collision(collision)
    view.set_objects([("red1", "red", 0.0, 40.0), ("green1", "green", 5.0, 45.0)])
    assert {n for n in drawn(view, "collision/world") if n.startswith("obj_")} == set()
    collision.set_world([(f"red{k}", "red", -12.0 + 4 * k, 38.0) for k in range(7)])
    view.show_joints(view.joints)
    objects = {n for n in drawn(view, "collision/world") if n.startswith("obj_")}
    assert len(objects) == 7
    assert_drawn_where_pinocchio_puts_them(view, collision, view.joints)
    collision.set_world([], held=("green1", "green"))  # an object in the jaws: the arm's
    view.show_joints(view.joints)
    assert drawn(view, "collision/world") == bin_names()
    held = drawn(view, "collision/arm") - {s.name for s in collision.arm_shapes}
    assert len(held) == 1 and held.pop().startswith("held ")
    assert_drawn_where_pinocchio_puts_them(view, collision, view.joints)
    collision.set_world([])
    view.show_joints(view.joints)
    assert drawn(view, "collision/arm") == {s.name for s in collision.arm_shapes}


def test_a_tracked_model_follows_the_views_objects_and_jaws(
    view: ArmView, collision: CollisionModel, model: ArmModel
):
    """With track_world the view puts its objects and its jaws' opening into the model:
    each object's shape stands where it is drawn, and the jaws' pads move apart by the
    opening."""
    view.show_collision(collision, track_world=True)
    placed = [("red1", "red", 0.0, 40.0), ("green1", "green", 5.0, 45.0)]
    view.set_objects(placed)
    tree = scene(view)
    objects = {n for n in drawn(view, "collision/world") if n.startswith("obj_")}
    assert len(objects) == 2
    centres = sorted(tuple(tree[f"/meshcat/collision/world/{n}"]["transform"][:3, 3])
                     for n in objects)  # fmt: skip
    task = CONFIG.task
    expected = sorted(tuple(object_centre_m(task.class_named(c), x, y)) for _, c, x, y in placed)
    np.testing.assert_allclose(centres, expected, atol=1e-12)

    gaps = {}
    for opening in (1.0, 3.0):
        view.show_joints(model.home, opening)
        tree = scene(view)
        left, right = (tree[f"/meshcat/collision/arm/gripper_jaw_{s}_pad"]["transform"][:3, 3]
                       for s in ("left", "right"))  # fmt: skip
        gaps[opening] = left - right
        assert_drawn_where_pinocchio_puts_them(view, collision, model.home)
    assert np.linalg.norm(gaps[3.0] - gaps[1.0]) == pytest.approx(0.02, abs=1e-9)

    view.set_objects([])
    assert {n for n in drawn(view, "collision/world") if n.startswith("obj_")} == set()


def test_collision_input_is_checked_and_nothing_changes(view: ArmView, collision, model):
    with pytest.raises(ViewInputError, match="none was drawn before"):
        view.show_collision()
    with pytest.raises(ViewInputError, match="collision = 'planner'.*CollisionModel"):
        view.show_collision("planner")  # type: ignore[arg-type]
    other = load_config(ROOT / "configs" / "sim_5dof.yaml")
    five = collision_model(other, ArmModel(other.arm))
    with pytest.raises(ViewInputError, match=r"this view's arm \(joints: base, shoulder"):
        view.show_collision(five)
    with pytest.raises(ViewInputError, match="q = "):
        view.show_collision(collision, [1.0, 2.0])
    with pytest.raises(ViewInputError, match="track_world = 'yes'"):
        view.show_collision(collision, track_world="yes")  # type: ignore[arg-type]
    assert view.collision is None
    assert drawn(view, "collision/arm") == set()
    assert view.joints == pytest.approx(model.home)


# --------------------------------------------------------------------------- route lines


def test_the_route_lines_hide_and_show(view: ArmView):
    """show_paths(visible=False) hides every line, those added or cleared later too; the lines
    stay in the scene; show_paths(visible=True) shows them again."""
    line = np.array([[-20.0, 35.0, 20.0], [-0.75, 53.72, 12.76]])
    view.add_path(line, "#c81e23")
    assert view.paths_shown
    view.show_paths(visible=False)
    view.add_path(line + 1.0)
    assert not view.paths_shown and view.paths == ["route1", "route2"]
    assert drawn(view, "paths") == {"route1", "route2"}
    assert scene(view)["/meshcat/paths"]["properties"]["visible"] is False
    view.clear_paths()
    view.add_path(line)
    assert scene(view)["/meshcat/paths"]["properties"]["visible"] is False
    view.show_paths(visible=True)
    assert view.paths_shown
    assert scene(view)["/meshcat/paths"]["properties"]["visible"] is True
    assert drawn(view, "paths") == {"route1"}
    view.show_paths()
    assert view.paths_shown


@pytest.mark.parametrize("bad", ["no", 0, None, 1.0])
def test_show_paths_takes_a_bool(view: ArmView, bad):
    with pytest.raises(ViewInputError, match="visible = .*: expected True or False"):
        view.show_paths(visible=bad)
    assert view.paths_shown


def test_a_closed_view_refuses_the_toggles(model: ArmModel, collision: CollisionModel):
    v = ArmView(model, CONFIG, port=0)
    v.close()
    for call in (lambda: v.show_collision(collision), v.hide_collision,
                 lambda: v.show_paths(visible=False)):  # fmt: skip
        with pytest.raises(ViewError, match="closed"):
            call()


# --------------------------------------------------------------------------- render


@pytest.mark.heavy
def test_the_render_shows_the_arms_shapes_in_translucent_magenta(
    model: ArmModel, collision: CollisionModel, tmp_path
):
    """In Chromium's render, with the URDF arm hidden, the centre of each arm shape is
    the collision magenta over the table or the sky."""
    browser = browser_or_skip()
    with ArmView(model, CONFIG, port=0) as v:
        v.show_collision(collision)
        v.viewer["arm/visuals"].set_property("visible", False)
        png = v.screenshot(tmp_path / "collision.png", width_px=W, height_px=H, browser=browser)
        cam = v.camera
    hsv = cv2.cvtColor(cv2.imread(str(png)), cv2.COLOR_BGR2HSV)
    poses = placements(collision, model.home)
    for shape in collision.arm_shapes:
        u, v = np.round(cam.project(poses[shape.name][:3, 3] * 100, W, H)[0]).astype(int)
        h, s, _ = hsv[v, u]
        assert 150 <= h <= 175 and s >= 80, f"{shape.name}: hsv {hsv[v, u]} at {(u, v)}"


# --------------------------------------------------------------------------- commands


def test_sort_collision_without_view_exits_2_with_one_line(capsys):
    with pytest.raises(SystemExit) as exit_:
        run(sort_main, ["--collision"])
    assert exit_.value.code == 2
    out, err = capsys.readouterr()
    assert err.strip().splitlines() == [
        "python -m mearm.sort: error: --collision draws the collision model in the view: "
        "use it with --view"
    ]


def test_preview_collision_with_bad_joints_exits_2_before_serving(capsys):
    with pytest.raises(SystemExit) as exit_:
        run(preview.main, ["--collision", "--joints", "hip=3"])
    assert exit_.value.code == 2
    out, err = capsys.readouterr()
    assert len(err.strip().splitlines()) == 1 and "unknown joint(s) 'hip'" in err
    assert out == ""


@pytest.mark.heavy
def test_sort_view_collision_draws_the_model_during_the_run(monkeypatch, tmp_path):
    """--view --collision: the view draws the arm's and bins' shapes and, at the first
    look, the object on the table (then, once sorted, none), posed as the arm is drawn."""
    looks: list[set[str]] = []
    set_objects = ArmView.set_objects

    def recording(self: ArmView, objects) -> None:
        set_objects(self, objects)
        names = drawn(self, "collision/world")
        looks.append({n for n in names if n.startswith("obj_")})
        assert names >= bin_names()
        assert drawn(self, "collision/arm") == {s.name for s in self.collision.arm_shapes}
        assert_drawn_where_pinocchio_puts_them(self, self.collision, self.joints)

    monkeypatch.setattr(ArmView, "set_objects", recording)
    scene_file = tmp_path / "one.yaml"
    scene_file.write_text("- {color: red, x: -0.40, y: 42.01}\n")
    code = sort_main(["--scene", str(scene_file), "--view", "--collision", "--quiet"])
    assert code == 0
    assert len(looks[0]) == 1 and looks[-1] == set()


def test_preview_collision_draws_the_model_at_the_joints(monkeypatch, tmp_path, capsys):
    """mearm preview --collision: the shapes at the named joints in the picture's scene."""
    seen: dict[str, object] = {}

    def fake_screenshot(self: ArmView, out_png, **kwargs):
        seen["arm"] = drawn(self, "collision/arm")
        seen["world"] = drawn(self, "collision/world")
        seen["joints"] = self.joints.copy()
        assert_drawn_where_pinocchio_puts_them(self, self.collision, self.joints)
        return out_png

    monkeypatch.setattr(ArmView, "screenshot", fake_screenshot)
    args = ["--joints", "base=90,shoulder=60,elbow=-100", "--collision", "--port", "0"]
    assert preview.main([*args, "--screenshot", str(tmp_path / "arm.png")]) == 0
    model = ArmModel(CONFIG.arm)
    assert seen["joints"] == pytest.approx(
        model.chain.from_named({"base": 90.0, "shoulder": 60.0, "elbow": -100.0})
    )
    assert "gripper_jaw_left_pad" in seen["arm"]  # type: ignore[operator]
    assert seen["world"] == bin_names()


def test_the_kinematic_sorts_view_draws_the_jaws_as_commanded(monkeypatch, tmp_path):
    """On the kinematic rig the view drew the jaws open all the way, the object carried
    included: the executor gave it the joints, never the opening. Now each pose it shows
    comes with the opening sent with it: closed while carrying, open otherwise."""
    openings: list[float] = []
    show_joints = ArmView.show_joints

    def recording(self: ArmView, q, opening_cm=None) -> None:
        show_joints(self, q, opening_cm)
        openings.append(self.opening_cm)

    monkeypatch.setattr(ArmView, "show_joints", recording)
    scene_file = tmp_path / "one.yaml"
    scene_file.write_text("- {color: red, x: -0.40, y: 42.01}\n")
    assert sort_main(["--scene", str(scene_file), "--view", "--quiet"]) == 0
    gripper = Config().arm.tool.gripper
    assert set(openings) == {gripper.open_cm, gripper.closed_cm}, sorted(set(openings))


@pytest.mark.heavy
def test_a_view_of_the_collision_shapes_imports_no_trimesh_and_leaves_it_importable():
    """``pinocchio.visualize`` imports all its visualisers; its viser one imported trimesh
    (SciPy, networkx: 0.8–1.0 s of CPU) at every view's start, then found viser missing.
    A view of the arm and its collision shapes now leaves those three unimported, draws
    the shapes, and ``import trimesh`` still works afterwards (yourdfpy needs it)."""
    code = (
        "import sys\n"
        "from viewscene import scene\n"
        "from mearm.config import Config\n"
        "from mearm.kinematics import ArmModel\n"
        "from mearm.sim.table_collision import collision_model\n"
        "from mearm.view import ArmView\n"
        "config = Config()\n"
        "model = ArmModel(config.arm)\n"
        "with ArmView(model, config, port=0) as v:\n"
        "    v.show_collision(collision_model(config, model, clearance_cm=0.5))\n"
        "    print(sum(p.startswith('/meshcat/collision/arm/') for p in scene(v)) > 0)\n"
        "print(sorted(m for m in ('trimesh', 'scipy', 'networkx') if m in sys.modules))\n"
        "import trimesh\n"
        "print(trimesh.__name__)\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "tests"), str(ROOT)])}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env, timeout=300
    )
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.splitlines() == ["True", "[]", "trimesh"], out.stdout
