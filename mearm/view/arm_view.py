"""The 3-D view of the rig in the browser: arm, table, bins, objects, camera frame, routes.

The arm is its model's URDF drawn by Pinocchio's ``MeshcatVisualizer``, every link and
both gripper jaws, whose joints open and close; the rest is plain meshcat geometry built
from the config: one bin per colour class and each object in its class's ``draw_rgb``
and size. Everything lives under ``/meshcat`` in the robot base frame (z up); meshcat
works in metres, so centimetres from the config are divided by 100 here and nowhere else.

Scene tree (below ``/meshcat``)::

    table                       a thin slab whose top is the plane z = 0
    bins/<class>/<part>         each class's open bin under its drop point: its floor
                                and walls, the collision model's and the twin's
    arm/visuals/<link>_<k>      the URDF's visuals (Pinocchio), jaws included
    objects/<id>                cylinders of their class's size at their table positions
                                (the detections; not drawn once the twin's bodies are)
    twin/objects/<id>           the physical twin's objects where its physics has them
    camera_frame                the last camera frame, lying where the calibration puts it
    target                      the current target
    paths/route<k>              the TCP path of each route, kept until clear_paths();
                                hidden and shown again by show_paths()
    collision/arm/<shape>       the collision model's arm shapes, and its bins' and
    collision/world/<shape>     objects' (show_collision(); see mearm.view.collision_drawing)
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable
from pathlib import Path
from types import TracebackType
from typing import Any

import meshcat
import meshcat.geometry as mg
import meshcat.transformations as tf
import numpy as np
import numpy.typing as npt

from mearm.config import ColorClass, Config
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import TableContents, frame_about
from mearm.kinematics.collision import CollisionModel
from mearm.view.browser import screenshot
from mearm.view.collision_drawing import CollisionDrawing
from mearm.view.errors import ViewError, ViewInputError
from mearm.view.frame_plane import FramePlane, PixelToTable, frame_plane
from mearm.view.layout import SceneLayout
from mearm.view.pinocchio_meshcat import meshcat_visualizer
from mearm.view.scene_meshes import (
    TABLE_RGB,
    TABLE_THICKNESS_CM,
    camera_frame_mesh,
    class_cylinder,
    draw_bin,
    draw_table,
)
from mearm.view.server import MeshcatServer
from mearm.view.urdf_arm import UrdfArm
from mearm.view.view_items import (
    PATH_RGB,
    HeldObject,
    TwinBody,
    ViewObject,
    color_value,
    finite_array,
    rgb_int,
    twin_body,
    view_object,
)
from mearm.view.viewpoint import M_PER_CM, ViewCamera

__all__ = [
    "BACKGROUND_BOTTOM",
    "BACKGROUND_TOP",
    "FRAME_LIFT_CM",
    "PATH_RGB",
    "TABLE_RGB",
    "TABLE_THICKNESS_CM",
    "TARGET_RADIUS_CM",
    "TARGET_RGB",
    "ArmView",
    "TwinBody",
    "ViewObject",
    "rgb_int",
]

log = logging.getLogger(__name__)

TARGET_RGB = 0xF2C500
BACKGROUND_TOP = [0.96, 0.97, 0.98]
BACKGROUND_BOTTOM = [0.80, 0.82, 0.85]
#: The camera frame floats this far above the table top so the two do not z-fight [cm].
FRAME_LIFT_CM = 0.05
TARGET_RADIUS_CM = 0.8


class ArmView:
    """The meshcat view of the rig, served on 127.0.0.1.

    Args:
        model: The arm; its URDF (links and jaws) is what is drawn.
        config: The rig and task: one bin per class (``task.classes``), objects drawn
            in their class's colour and size, the table sized to hold them.
        port: Web port; 0 takes any free one, ``None`` the first free one from 7000.
        camera: The fixed viewpoint (see :mod:`mearm.view.viewpoint`); default: one that
            frames the arm at home and everything on the table (:class:`SceneLayout`).

    Attributes:
        url: The address to open in a browser, ``http://127.0.0.1:<port>/static/``.
        viewer: The ``meshcat.Visualizer`` at ``/meshcat`` (base frame, metres), for
            anything else a caller wants to draw.
        layout: The table and the default viewpoint for this arm and config.
        camera: The viewpoint set.
        joints: The chain's joints drawn now, model units, (n,).
        opening_cm: The gripper opening drawn now [cm].

    Two sources draw the objects: :meth:`set_objects` (what the camera detected, as
    cylinders standing on the table) and :meth:`show_bodies` (the physical twin's
    bodies, anywhere in space). Once the twin's bodies are shown they are the objects
    drawn; detections are still recorded (:attr:`objects`) but no longer drawn, so one
    object is never drawn twice, nor where the physics no longer has it.

    Raises:
        ViewPortError: ``port`` is in use.
        ViewError: No free port from 7000 (``port=None``).
        ViewRunError: The server did not start, or did not answer (any method may
            raise it: the server did not reply within its timeout).
    """

    def __init__(
        self,
        model: ArmModel,
        config: Config,
        *,
        port: int | None = None,
        camera: ViewCamera | None = None,
    ):
        self.model = model
        self.config = config
        self.layout = SceneLayout.of(model, config)
        self.camera = camera if camera is not None else self.layout.camera
        self._classes = {c.name: c for c in config.task.classes}
        self._server = MeshcatServer(port=port)
        self._closed = False
        try:
            self._window = self._server.window()
            self.viewer = meshcat.Visualizer(window=self._window)
            self.url: str = self._server.web_url
            self._objects: dict[str, ViewObject] = {}
            self._bodies: dict[str, TwinBody] = {}
            self._held: tuple[str, str] | None = None  # (id, class) in the jaws (:meth:`hold`)
            self._held_drawn: dict[str, HeldObject] = {}
            self._twin_shown = False
            self._paths: list[str] = []
            self._paths_shown = True
            self._target_shown = False
            self._collision: CollisionDrawing | None = None  # drawn now
            self._collision_last: CollisionDrawing | None = None  # drawn last, to show again
            self.frame_plane: FramePlane | None = None
            self._setup_scene()
            self._urdf = UrdfArm(model)
            # imported here, and without what Pinocchio's other visualisers import
            # (pinocchio_meshcat): only a view pays for it, not every importer of this module
            visualizer = meshcat_visualizer().MeshcatVisualizer
            self._viz = visualizer(self._urdf.full, None, self._urdf.visual)
            self._viz.initViewer(viewer=self.viewer)
            self._viz.loadViewerModel(rootNodeName="arm")
            self.joints = model.home
            self.opening_cm = float(config.arm.tool.gripper.open_cm)
            self._viz.display(self._urdf.q(self.joints, self.opening_cm))
        except BaseException:
            self.close()
            raise
        log.info("meshcat view at %s", self.url)

    # ------------------------------------------------------------------ lifecycle

    @property
    def port(self) -> int:
        """The web port."""
        return self._server.port

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` was called."""
        return self._closed

    @property
    def browsers(self) -> int:
        """How many browsers are connected now."""
        return self._server.browsers

    def screenshot(
        self, out_png: str | Path, *, width_px: int = 1280, height_px: int = 800, **kwargs: Any
    ) -> Path:
        """Render the view as it is now in headless Chromium and save it as a PNG.

        Waits until the browser has drawn everything the server holds (see
        :func:`mearm.view.browser.screenshot`, which takes the other keyword arguments).

        Returns:
            The PNG's path.

        Raises:
            BrowserNotFoundError: No Chromium-family browser.
            ViewInputError: A size out of range, or ``out_png`` under a file.
            ViewError: The view is closed; ``out_png`` cannot take a file.
            ViewRunError: The browser failed or did not draw the scene in time; the
                storage failed writing the PNG.
        """
        self._check_open()
        expect = self._server.scene_counts()
        return screenshot(
            self.url, out_png, width_px=width_px, height_px=height_px, expect=expect, **kwargs
        )

    def close(self) -> None:
        """Stop the server; the view cannot be used afterwards. Safe to call twice."""
        if self._closed:
            return
        self._closed = True
        window = getattr(self, "_window", None)
        if window is not None:
            window.close()
        self._server.close()

    def __enter__(self) -> ArmView:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _check_open(self) -> None:
        if self._closed:
            raise ViewError(f"the view at {self.url} is closed")

    # ------------------------------------------------------------------ static scene

    def _setup_scene(self) -> None:
        vis = self.viewer
        vis["/Background"].set_property("top_color", BACKGROUND_TOP)
        vis["/Background"].set_property("bottom_color", BACKGROUND_BOTTOM)
        vis["/Grid"].set_property("visible", False)  # noqa: FBT003 - meshcat's (name, value)
        vis["/Axes"].set_property("visible", False)  # noqa: FBT003 - meshcat's (name, value)
        self.camera.apply(vis)

        draw_table(vis, self.layout)
        table = TableContents.of(self.config.task, self.config.belt)  # as the planner's
        for c in table.classes:
            draw_bin(vis, table, c)

    # ------------------------------------------------------------------ arm

    def show_joints(self, q: npt.ArrayLike, opening_cm: float | None = None) -> None:
        """Draw the arm at joints ``q`` (model units: rad, or m for a prismatic joint).

        Args:
            q: The full chain vector, (n,) in ``model.chain.names`` order; or, when the
                arm has passive joints, the actuated ones, (m,), completed by the
                coupling (``chain.full``).
            opening_cm: The gripper opening [cm]; ``None`` keeps the last one (the
                gripper's ``open_cm`` at first). Drawn within the jaws' limits.

        Raises:
            ViewInputError: Not n (or m) finite numbers, or a non-finite opening.
        """
        self._check_open()
        full = self._full_q(q)
        if opening_cm is not None:
            opening = finite_array(opening_cm, "opening_cm", "a finite opening [cm]")
            if opening.shape != ():
                raise ViewInputError("opening_cm", opening_cm, "a finite opening [cm]")
            self.opening_cm = float(opening)
        self._viz.display(self._urdf.q(full, self.opening_cm))
        self.joints = full.copy()
        if self._held is not None:
            self._draw_held()
        if self._collision is not None:
            self._draw_collision()

    def _full_q(self, q: npt.ArrayLike) -> np.ndarray:
        """The chain's full joint vector from ``q`` as :meth:`show_joints` takes it, (n,)."""
        chain = self.model.chain
        sizes = sorted({chain.n, chain.m})
        allowed = (
            f"{' or '.join(map(str, sizes))} finite joint values in model units "
            f"(joints: {', '.join(chain.names)})"
        )
        values = finite_array(q, "q", allowed)
        if values.shape == (chain.n,):
            return values
        if values.shape == (chain.m,):
            return np.asarray(chain.full(values), dtype=float)
        raise ViewInputError("q", q, allowed)

    # ------------------------------------------------------------------ collision model

    @property
    def collision(self) -> CollisionModel | None:
        """The collision model drawn now (:meth:`show_collision`), or ``None``."""
        return None if self._collision is None else self._collision.collision

    def show_collision(
        self,
        collision: CollisionModel | None = None,
        q: npt.ArrayLike | None = None,
        *,
        track_world: bool | None = None,
    ) -> None:
        """Draw a collision model's shapes, translucent, under ``collision/``; until hidden.

        Every shape of the model's world now is drawn (:mod:`mearm.view.collision_drawing`): the
        arm's plates, servos, hand and jaws and a held object in translucent magenta,
        each bin's floor and walls and each object on the table in translucent cyan, as
        the model has them (their true sizes: the clearance is not drawn). The table is
        not drawn: the model's is a half-space lowered by the clearance, so a distance
        to it less the clearance is the height above the table top (z = 0); the arm's
        distances to the bins and objects are compared against the clearance itself
        (``collision.clearance_m``). Posed by Pinocchio for the joints the arm is drawn
        at, the shapes follow the arm at each :meth:`show_joints` (and
        :meth:`show_bodies`) until :meth:`hide_collision`.

        Args:
            collision: The model (e.g. the planner's); ``None``: the one drawn last.
            q: The joints to draw the arm and the shapes at, as :meth:`show_joints` takes
                them; ``None``: the joints drawn now.
            track_world: Put the view's world into the model before each drawing: the
                objects of :meth:`set_objects` and the jaws' opening drawn
                (``collision.set_world``, nothing held). For a model of the view's own:
                never the planner's, whose checks it would change. ``None``: off for a
                new model, as before for the one drawn last. Without it the shapes are
                the model's world as its owner sets it (its jaws at its opening).

        Raises:
            ViewInputError: Not a CollisionModel of this view's arm, none drawn before
                (``collision=None``), bad joints or a ``track_world`` not a bool; nothing
                is changed then.
        """
        self._check_open()
        drawing = self._drawing_for(collision)
        if track_world is not None and not isinstance(track_world, bool):
            raise ViewInputError("track_world", track_world, "True, False or None")
        full = None if q is None else self._full_q(q)
        if self._collision is not None and self._collision is not drawing:
            self._collision.delete()
        if track_world is not None:
            drawing.track_world = track_world
        self._collision = self._collision_last = drawing
        if full is not None:
            self.show_joints(full)  # draws the shapes too
        else:
            self._draw_collision()

    def _drawing_for(self, collision: CollisionModel | None) -> CollisionDrawing:
        """The drawing of ``collision`` (the last one again if it is that one, or ``None``)."""
        chain = self.model.chain
        last = self._collision_last
        if collision is None:
            if last is None:
                raise ViewInputError(
                    "collision", None, "a CollisionModel (none was drawn before to show again)"
                )
            return last
        if not isinstance(collision, CollisionModel):
            raise ViewInputError(
                "collision", collision, "a mearm.kinematics.collision.CollisionModel"
            )
        if list(collision.model.chain.names) != list(chain.names):
            raise ViewInputError(
                "collision",
                f"a CollisionModel of joints {', '.join(collision.model.chain.names)}",
                f"a CollisionModel of this view's arm (joints: {', '.join(chain.names)})",
            )
        if last is not None and collision is last.collision:
            return last
        return CollisionDrawing(self.viewer, collision, track_world=False)

    def hide_collision(self) -> None:
        """Remove the collision model's shapes; :meth:`show_collision` draws them again."""
        self._check_open()
        if self._collision is not None:
            self._collision.delete()
            self._collision = None

    def _draw_collision(self) -> None:
        """Draw the collision model at the joints drawn (its world first, if tracked)."""
        drawing = self._collision
        if drawing is None:
            return
        if drawing.track_world:
            objects = [(o.id, o.class_name, o.x_cm, o.y_cm) for o in self._objects.values()]
            drawing.set_world(objects, self.opening_cm)
        drawing.update(self.joints)

    # ------------------------------------------------------------------ objects

    @property
    def objects(self) -> dict[str, ViewObject]:
        """The objects last set by :meth:`set_objects`, by id (drawn unless the twin is)."""
        return dict(self._objects)

    def set_objects(self, objects: Iterable[Any]) -> None:
        """Draw exactly these objects, and remove those no longer listed.

        New ids are added, moved or reclassed ones updated, missing ones deleted. Each is
        a cylinder of its class's ``diameter_cm`` and ``height_cm`` in its ``draw_rgb``.
        Once the twin's bodies are shown (:meth:`show_bodies`) the objects are only
        recorded, not drawn.

        Args:
            objects: ``(id, class_name, x_cm, y_cm)`` tuples (or objects with an ``id``,
                a ``class_name`` or ``color``, ``x_cm`` and ``y_cm``, e.g.
                :class:`mearm.sim.WorldObject`); the class one of ``task.classes``;
                position on the table [cm].

        Raises:
            ViewInputError: A malformed item, an unknown class or a repeated id; nothing
                is changed then.
        """
        self._check_open()
        wanted: dict[str, ViewObject] = {}
        for item in objects:
            obj = view_object(item, self._classes)
            if obj.id in wanted:
                raise ViewInputError("objects", obj.id, "each id at most once")
            wanted[obj.id] = obj
        if self._twin_shown:  # the twin's bodies are drawn instead (see show_bodies)
            self._objects = wanted
        else:
            self._sync_cylinders(
                self._objects,
                wanted,
                "objects",
                lambda obj, cls: tf.translation_matrix(
                    np.array([obj.x_cm, obj.y_cm, cls.height_cm / 2]) * M_PER_CM
                ),
            )
        if self._collision is not None and self._collision.track_world:
            self._draw_collision()

    @property
    def held(self) -> tuple[str, str] | None:
        """The object drawn in the jaws, ``(id, class)`` (:meth:`hold`), or ``None``."""
        return self._held

    def hold(self, held: tuple[str, str] | None) -> None:
        """Draw an object in the jaws, ``(id, class)``, moving with them; ``None``: none.

        For the rigs whose joints are drawn as commanded (the twin's bodies are drawn as
        measured, :meth:`show_bodies`, and this only records it): the object leaves the
        table's drawing and stands at the grip point, its axis along the tool's approach
        (where the collision model holds it), until the jaws let it go; the next
        :meth:`set_objects` draws it on the table again if the camera sees it there.

        Raises:
            ViewInputError: An unknown class; nothing is changed then.
        """
        self._check_open()
        if held is not None and held[1] not in self._classes:
            raise ViewInputError("held", held, f"a class of {sorted(self._classes)}")
        self._held = None if held is None else (str(held[0]), str(held[1]))
        if self._twin_shown:
            return
        if self._held is not None and self._held[0] in self._objects:
            self.viewer[f"objects/{self._held[0]}"].delete()  # off the table: in the jaws
            del self._objects[self._held[0]]
        self._draw_held()

    def _draw_held(self) -> None:
        """Draw the held object (:meth:`hold`) at the grip point of the joints drawn now."""
        wanted: dict[str, HeldObject] = {}
        if self._held is not None and not self._twin_shown:
            tcp_cm, R = self.model.tcp_pose(self.joints)
            approach = R @ self.model.approach_axis
            T = np.eye(4)
            T[:3, :3] = frame_about(approach)
            T[:3, 3] = (tcp_cm + approach * self.config.arm.tool.tcp_above_grip_cm) * M_PER_CM
            oid, class_name = self._held
            wanted[oid] = HeldObject(class_name, tuple(T.ravel().tolist()))
        self._sync_cylinders(
            self._held_drawn, wanted, "held", lambda h, _cls: np.reshape(h.pose, (4, 4))
        )

    @property
    def twin_shown(self) -> bool:
        """Whether the twin's bodies are drawn (:meth:`show_bodies` was called)."""
        return self._twin_shown

    @property
    def bodies(self) -> dict[str, TwinBody]:
        """The twin's objects drawn now, by id (empty until :meth:`show_bodies`)."""
        return dict(self._bodies)

    def show_bodies(self, q: npt.ArrayLike, opening_cm: float, objects: Iterable[Any]) -> None:
        """Draw the world as the physical twin has it: the arm, its jaws and every object.

        The objects are drawn under ``twin/objects/<id>``, exactly these (ids no longer
        listed are removed; only those that moved are sent again); the detections of
        :meth:`set_objects` are removed from the scene and no longer drawn.

        Args:
            q: The arm's joints, as :meth:`show_joints` takes them (measured ones).
            opening_cm: The jaws' opening [cm] (measured).
            objects: ``(id, class_name, position_cm, quat)`` tuples (or
                :class:`TwinBody`): the body's centre in the base frame [cm], (3,), and
                its orientation (w, x, y, z), (4,); its cylinder's axis is the body's z.

        Raises:
            ViewInputError: A malformed item, an unknown class, a repeated id, bad joints
                or opening; nothing is changed then.
        """
        self._check_open()
        wanted: dict[str, TwinBody] = {}
        for item in objects:
            body = twin_body(item, self._classes)
            if body.id in wanted:
                raise ViewInputError("objects", body.id, "each id at most once")
            wanted[body.id] = body
        self.show_joints(q, opening_cm)  # validates q and the opening before any change
        if not self._twin_shown:
            self.viewer["objects"].delete()  # the detections: the twin's bodies replace them
            self._sync_cylinders(self._held_drawn, {}, "held", lambda h, _cls: np.eye(4))
            self._twin_shown = True
        self._sync_cylinders(
            self._bodies,
            wanted,
            "twin/objects",
            lambda body, _cls: (
                tf.translation_matrix(np.array(body.position_cm) * M_PER_CM)
                @ tf.quaternion_matrix(body.quat)
            ),
        )

    def _sync_cylinders(
        self,
        drawn: dict[str, Any],
        wanted: dict[str, Any],
        prefix: str,
        pose_of: Callable[[Any, ColorClass], np.ndarray],
    ) -> None:
        """Draw ``wanted`` (id → item with ``class_name``) as cylinders under ``prefix``.

        What went is deleted and only what changed is (re)drawn; ``drawn`` is updated.
        ``pose_of(item, cls)`` is the cylinder's pose with its axis along z.
        """
        for obj_id in [i for i in drawn if i not in wanted]:
            self.viewer[f"{prefix}/{obj_id}"].delete()
            del drawn[obj_id]
        for obj_id, item in wanted.items():
            old = drawn.get(obj_id)
            if old == item:
                continue
            node = self.viewer[f"{prefix}/{obj_id}"]
            cls = self._classes[item.class_name]
            if old is None or old.class_name != item.class_name:
                node.set_object(*class_cylinder(cls))
            # three.js cylinders stand along y: turn them to stand along the pose's z
            node.set_transform(pose_of(item, cls) @ tf.rotation_matrix(math.pi / 2, [1, 0, 0]))
            drawn[obj_id] = item

    # ------------------------------------------------------------------ camera frame

    def set_camera_frame(self, frame_bgr: npt.ArrayLike, pixel_to_table: PixelToTable) -> None:
        """Lay the camera frame on the table where the calibration puts it.

        Args:
            frame_bgr: The frame, (H, W, 3) BGR or (H, W) grey, uint8.
            pixel_to_table: Maps (N, 2) pixels [px] to (N, 2) table points [cm], e.g.
                ``mearm.vision.Calibration.pixel_to_table``; see
                :func:`mearm.view.frame_plane.frame_plane`.

        Raises:
            ViewInputError: Not an 8-bit image, or a calibration that does not map the
                image to a convex quadrilateral.
        """
        self._check_open()
        plane = frame_plane(frame_bgr, pixel_to_table)
        node = self.viewer["camera_frame"]
        node.set_object(camera_frame_mesh(plane))
        cx, cy = plane.center_cm
        node.set_transform(tf.translation_matrix(np.array([cx, cy, FRAME_LIFT_CM]) * M_PER_CM))
        self.frame_plane = plane

    def clear_camera_frame(self) -> None:
        """Remove the camera frame."""
        self._check_open()
        self.viewer["camera_frame"].delete()
        self.frame_plane = None

    # ------------------------------------------------------------------ target, paths

    def set_target(self, target_cm: npt.ArrayLike | None) -> None:
        """Mark the current target with a small sphere, or remove the mark.

        Args:
            target_cm: (x, y, z) in the base frame [cm], (3,); ``None`` removes it.

        Raises:
            ViewInputError: Not 3 finite numbers.
        """
        self._check_open()
        node = self.viewer["target"]
        if target_cm is None:
            if self._target_shown:
                node.delete()
                self._target_shown = False
            return
        target = finite_array(target_cm, "target_cm", "3 finite numbers (x, y, z) [cm]")
        if target.shape != (3,):
            raise ViewInputError("target_cm", target_cm, "3 finite numbers (x, y, z) [cm]")
        if not self._target_shown:
            node.set_object(
                mg.Sphere(TARGET_RADIUS_CM * M_PER_CM), mg.MeshLambertMaterial(color=TARGET_RGB)
            )
            self._target_shown = True
        node.set_transform(tf.translation_matrix(target * M_PER_CM))

    @property
    def paths(self) -> list[str]:
        """Names of the route lines drawn, oldest first (``route1``, ``route2``, …)."""
        return list(self._paths)

    def add_path(self, ee_path_cm: npt.ArrayLike, color: str | int | None = None) -> str:
        """Draw a route's TCP path as a line; it stays until :meth:`clear_paths`.

        Args:
            ee_path_cm: TCP positions along the route, base frame [cm], (N, 3), N ≥ 2.
            color: ``"#RRGGBB"`` (e.g. a class's ``draw_rgb`` as hex) or an int
                0xRRGGBB; ``None``: :data:`PATH_RGB`.

        Returns:
            The line's name, ``route<k>``.

        Raises:
            ViewInputError: Not an (N, 3) array of finite numbers with N ≥ 2, or an
                unknown colour.
        """
        self._check_open()
        allowed = "an (N, 3) array of finite EE positions [cm] with N >= 2"
        points = finite_array(ee_path_cm, "ee_path_cm", allowed)
        if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] < 2:
            raise ViewInputError("ee_path_cm", f"array of shape {points.shape}", allowed)
        rgb = color_value(color)
        name = f"route{len(self._paths) + 1}"
        line = mg.Line(
            mg.PointsGeometry((points * M_PER_CM).T.astype(np.float32)),
            mg.LineBasicMaterial(color=rgb, linewidth=2.0),
        )
        self.viewer[f"paths/{name}"].set_object(line)
        self._paths.append(name)
        return name

    def clear_paths(self) -> None:
        """Remove every route line (hidden ones stay hidden: see :meth:`show_paths`)."""
        self._check_open()
        self.viewer["paths"].delete()
        self._paths.clear()
        if not self._paths_shown:
            self.viewer["paths"].set_property("visible", False)  # noqa: FBT003 - meshcat's (name, value)

    @property
    def paths_shown(self) -> bool:
        """Whether the route lines are shown (:meth:`show_paths`); they are at first."""
        return self._paths_shown

    def show_paths(self, *, visible: bool = True) -> None:
        """Show or hide every route line, those drawn later included.

        Hidden lines stay in the scene (:attr:`paths` still lists them; meshcat's
        ``visible`` property of ``paths``); :meth:`add_path` goes on adding lines.

        Args:
            visible: ``True`` shows them, ``False`` hides them.

        Raises:
            ViewInputError: ``visible`` is not a bool.
        """
        self._check_open()
        if not isinstance(visible, (bool, np.bool_)):
            raise ViewInputError("visible", visible, "True or False")
        self._paths_shown = bool(visible)
        self.viewer["paths"].set_property("visible", self._paths_shown)
