r"""The arm's body against the table, the bins and the objects: Pinocchio's collision layer.

:class:`CollisionModel` builds a ``pin.GeometryModel`` (coal shapes) from the same shapes
as the physical twin's MJCF (:mod:`mearm.kinematics.bodies`): the arm's plates, servos,
gripper mount and jaws on the joints they move with, and each bin's floor and walls and
each object seen on the universe. The table is the plane z = 0, checked in closed form
(the lowest point of each arm shape).

**What counts as touching.** A pose is clear when every arm shape keeps
``clearance_cm`` from every bin and object, and stays above the table (the jaws come down
to the table to close on an object, so the table gets no margin). The jaws' pads may touch
an object standing between them (the one they come down around and close on), and a
held object (``held``) rides in the jaws: it
is checked against the bins and the other objects, never against the jaws or the table it
is lifted from.

**A path is checked whole, without stepping over anything** (:meth:`first_contact`):
between consecutive poses the joints move on a straight line, and along it the check
advances by conservative advancement. At a pose with gap ``g`` to spare (the smallest
distance less the margin) no point of the arm can touch anything before the joints have
moved so far that some point could have travelled ``g``; the bound on how far a point can
travel is :math:`\sum_i R_i |\Delta q_i|`, with :math:`R_i` the farthest any shape beyond
joint i can be from its axis (a prismatic joint: 1 m per m). So the next check comes no
later than that, however thin the wall (a bin's is 3 mm); a gap under :data:`TOUCH_CM`
counts as touching. Far from everything one check covers a whole step of the path; close
to a wall the checks come as close together as the gap requires.

**A start within the clearance may be left** (MoveIt's handling of a start state in
collision, for the clearance): a measured pose can end nearer a wall or an object than
the clearance the plan kept (the jaws close on an object beside a bin's wall, and it is
held 0.1 cm from it). From there no path would pass the check, and nothing could move.
So each pair within the clearance at a path's first pose (the table never) is held to
where it started instead: the path may not bring it more than :data:`TOUCH_CM` closer
than that, only farther, and one that starts clear may not touch. A pair that starts
touching (an object fallen beside another: the circles around their footprints
overlap) may likewise only come apart, its distance (< 0: how far in) no more than
:data:`TOUCH_CM` below where it started. Every other pair keeps the clearance.

**The jaws opening** (:meth:`opening_contact`) move nothing but the jaws' pads, across:
a release's opening is checked at openings close enough that no pad can step over a wall
between two of them (each pad moves at most a wall's thickness and twice the clearance).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import NamedTuple

import coal
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from mearm import interrupts
from mearm.config.servo_models import SERVO_CATALOGUE, ServoSpec, servo_named
from mearm.kinematics.bodies import (
    BIN_WALL_M,
    M_PER_CM,
    Shape,
    TableContents,
    arm_bodies,
    bin_origin_m,
    bin_shapes,
    class_of,
    frame_about,
    object_centre_m,
    object_name,
    object_of,
    object_shape,
)
from mearm.kinematics.model import ArmModel

#: A gap smaller than this counts as touching [cm]: the advancement's floor.
TOUCH_CM = 0.005
TOUCH_M = TOUCH_CM * 0.01
#: The clearance kept from bins and objects when the config gives none [cm].
DEFAULT_CLEARANCE_CM = 0.3
#: How far coal's distance may fall below a pair's bound [m] before the broad phase of
#: :meth:`CollisionModel._gap` could miss the nearest pair: coal's GJK converges to 1e-6 m,
#: a hundredth of this.
BROAD_PHASE_SLACK_M = 1e-4


class _BroadPhase(NamedTuple):
    """The pairs a gap is looked for among, and what their lower bounds take, per pair."""

    pairs: np.ndarray  # pair indices, ascending
    centre_at: np.ndarray  # (pairs, 3) its arm shape's centre's place in the rows' (rows, 3)
    ob_centre: np.ndarray  # (pairs, 3) its obstacle's box: centre [m]
    ob_half: np.ndarray  # (pairs, 3) and half extents [m]
    radius: np.ndarray  # its arm shape's sphere's radius [m]
    table: np.ndarray  # the places (in ``pairs``) of the pairs with the table
    table_z_at: np.ndarray  # and their arm shapes' centres' heights' places


@dataclass(frozen=True)
class Contact:
    """Where a path first comes too close to something.

    Attributes:
        arm_part: The arm's shape (an MJCF geom name, e.g. ``gripper_jaw_left_pad``), or
            ``held <id>`` for the object in the jaws.
        obstacle: What it comes too close to: ``table``, a bin's wall or floor
            (``bin_red_wall_px``) or an object (``obj_red2``).
        distance_cm: Their distance there [cm] (≤ 0: they touch).
        q: The pose, model units, (n,).
        pose_index: The path's segment it lies on (from pose k to k + 1).
        start_cm: For a pair within the clearance at the path's start (touching, too),
            their distance there [cm] (the path came closer than that); ``None`` for any
            other pair.
    """

    arm_part: str
    obstacle: str
    distance_cm: float
    q: np.ndarray
    pose_index: int
    start_cm: float | None = None

    def describe(self, names: Sequence[str], scale: np.ndarray) -> str:
        """One line: the two bodies and the pose (joints in config units)."""
        joints = ", ".join(f"{n} {v / s:.1f}" for n, v, s in zip(names, self.q, scale, strict=True))
        if self.distance_cm <= TOUCH_CM:
            what = "touches"
        else:
            what = f"comes within {self.distance_cm:.2f} cm of"
        text = f"{self.arm_part} {what} {_plain(self.obstacle)}"
        if self.start_cm is not None:
            text += f" (closer than the {self.start_cm:.2f} cm it started at)"
        return f"{text} at ({joints})"


def _plain(name: str) -> str:
    oid = object_of(name)
    return name if oid is None else oid


def _coal(shape: Shape) -> coal.CollisionGeometry:
    if shape.kind == "box":
        return coal.Box(*(2 * np.asarray(shape.size)))
    return coal.Cylinder(shape.size[0], 2 * shape.size[1])


#: The rotation of a shape moved without turning (an object's place on the table).
_NO_TURN = np.eye(3)


def _se3(T: np.ndarray) -> pin.SE3:
    return pin.SE3(np.ascontiguousarray(T[:3, :3]), np.ascontiguousarray(T[:3, 3]))


def _translate(v: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, 3] = v
    return T


def joint_servo(name: str | None) -> ServoSpec:
    """The joints' servo the shapes are drawn with.

    The servo called ``name`` (the config's ``twin.joint_servo``), or with ``None`` the
    catalogue's largest: the twin picks one by load, and the largest box errs on the safe
    side for a plan.
    """
    if name is not None:
        return servo_named(name)
    return max(SERVO_CATALOGUE, key=lambda s: float(np.prod(s.size_m)))


class CollisionModel:
    """The arm and what lies on the table, as one Pinocchio geometry model.

    Args:
        table: The classes (their bins and objects) and how many objects each brings.
        model: The arm's kinematic model (its arm and tool; its Pinocchio model carries
            the geometry).
        gripper_servo: The gripper's servo (and each tool actuator's).
        clearance_cm: What every arm shape keeps from bins and objects [cm].
        servo: The joints' servo (default: :func:`joint_servo` of ``None``).
        bins: The classes whose bins stand on the table (default: every class's).

    Attributes:
        checks: Poses checked so far (the bench reads it).
    """

    def __init__(
        self,
        table: TableContents,
        model: ArmModel,
        *,
        gripper_servo: ServoSpec,
        clearance_cm: float = DEFAULT_CLEARANCE_CM,
        servo: ServoSpec | None = None,
        bins: Iterable[str] | None = None,
    ):
        self.table = table
        self.model = model
        self.clearance_m = clearance_cm * M_PER_CM
        pm = model.model
        self.data = pm.createData()
        # each joint's placement in ``self.data``: Pinocchio's references to them, which
        # read what the kinematics last wrote (looked up once, not at every check)
        self._placements = [self.data.oMi[j] for j in range(pm.njoints)]
        arm = model.arm
        joints = servo or joint_servo(None)
        self.bodies = arm_bodies(arm, joints, gripper_servo, acrylic_kg_m3=0)
        self._last = pm.njoints - 1
        self._joint_of: dict[str, int] = {"base_link": 0, "tcp": self._last}
        for name in model.chain.names:
            self._joint_of[f"link_{name}"] = pm.getJointId(name)
        self.arm_shapes = [s for s in self.bodies.shapes if s.collides]
        standing = table.class_names if bins is None else list(bins)
        self.bins = [
            (shape, _translate(bin_origin_m(table.class_named(name))) @ shape.pose)
            for name in standing
            for shape in bin_shapes(table.class_named(name), table.objects(name))
        ]
        T = self.bodies.tcp_in_last
        self._grip_in_last = T[:3, :3] @ (self.bodies.approach * self.bodies.grip_m) + T[:3, 3]
        self._prismatic = [bool(p) for p in model.chain.prismatic]
        self.checks = 0
        self._world = 0  # counts the worlds put in the model (a gap is kept for its world)
        self._last_key: tuple[object, ...] | None = None
        self._last_gap: tuple[float, str, str, float] = (math.inf, "", "", math.inf)
        self._last_frames: np.ndarray | None = None  # (:meth:`_frames` at that pose)
        self._walks: list[_Walk] = []  # (:meth:`first_contact`: the last few, newest last)
        self._frames_at: np.ndarray | None = None  # (:meth:`_frames`)
        self._objects: list[tuple[str, str, float, float]] = []
        self._opening_cm = arm.tool.gripper.open_cm
        self._reach_local = self._local_reach()
        self._reach_of_opening = {self._opening_cm: self._reach_local}  # read only
        self._held: tuple[str, str] | None = None
        self._table_below_cm = 0.0  # the table as checked, below the real one [cm]
        self._on_table: set[str] = set()  # shapes standing on the table: the arm's mount
        # object places per class: the scene's count and two more, grown when a look finds more
        self._capacity = {c: table.scene.get(c, 0) + 2 for c in table.class_names}
        # the arm's mount, standing on the table at home, is not checked against it
        pin.forwardKinematics(pm, self.data, model.home)
        placed = [
            self.data.oMi[self._joint_of.get(shape.body, self._last)] * _se3(self._in_joint(shape))
            for shape in self.arm_shapes
        ]
        low = np.array([M.translation[2] for M in placed]) - _lowest(
            np.array([M.rotation for M in placed]),
            np.array([_half_extents(shape) for shape in self.arm_shapes]),
            np.array([shape.kind == "cylinder" for shape in self.arm_shapes]),
        )
        self._on_table = {s.name for s, z in zip(self.arm_shapes, low, strict=True) if z <= TOUCH_M}
        self._build()

    # ----------------------------------------------------------------- the world

    def set_world(
        self,
        objects: Iterable[tuple[str, str, float, float]] | None = None,
        *,
        opening_cm: float | None = None,
        held: tuple[str, str] | None = None,
        table_below_cm: float = 0.0,
    ) -> None:
        """What the checks see from now on.

        The geometry model is built once with a place for every object the scene may
        hold and one held object per class; a new world moves the places and switches
        their pairs on and off (a rebuild only when a class has more objects than places).

        Args:
            objects: The objects on the table, ``(id, class, x_cm, y_cm)`` each (``None``
                keeps the last ones); not the one held.
            opening_cm: The jaws' opening [cm] (``None`` keeps it).
            held: The object in the jaws, ``(id, class)``, or ``None``.
            table_below_cm: How far below the real table the table is checked [cm], ≥ 0:
                the tool measured that much higher than its commanded pose (a pick lowered
                by a miss, :class:`mearm.task.claw_loop.GripDrops`); 0: the real table.
        """
        world = (
            self._objects if objects is None else list(objects),
            self._opening_cm if opening_cm is None else float(opening_cm),
            held,
            max(0.0, float(table_below_cm)),
        )
        if world == (self._objects, self._opening_cm, self._held, self._table_below_cm):
            return  # the same world (a simulator asks before every move)
        # a Ctrl-C in the middle would leave the model half in the new world, and the
        # checks after it would go on seeing that (the parking after it refused its way
        # home, blocked by the object it held: its place, switched off, still checked)
        with interrupts.signals_deferred():
            self._objects, opening, self._held, self._table_below_cm = world
            if opening != self._opening_cm:
                self._opening_cm = opening
                reach = self._reach_of_opening.get(opening)
                if reach is None:  # (a simulator switches between a few openings at every grip)
                    reach = self._reach_of_opening[opening] = self._local_reach()
                self._reach_local = reach
            counts: dict[str, int] = {}
            for _, color, _, _ in self._objects:
                counts[color] = counts.get(color, 0) + 1
            if any(n > self._capacity.get(c, 0) for c, n in counts.items()):
                for c, n in counts.items():
                    self._capacity[c] = max(self._capacity.get(c, 0), 2 * n)
                self._build()  # more objects of a class than places: a bigger model
            else:
                self._apply()

    def _in_joint(self, shape: Shape) -> np.ndarray:
        T = shape.pose
        if shape.jaw:
            slide = _translate(self.bodies.across * shape.jaw * self._opening_cm * M_PER_CM / 2)
            return self.bodies.tcp_in_last @ slide @ T
        if shape.body == "tcp":
            return self.bodies.tcp_in_last @ T
        return T

    def _held_shape(self, color: str) -> tuple[Shape, np.ndarray]:
        """An object of class ``color`` in the jaws, and its pose in the last joint's frame."""
        shape = object_shape(self.table.class_named(color), "held")
        a = self.bodies.approach
        T = np.eye(4)
        T[:3, :3] = frame_about(a)
        T[:3, 3] = a * self.bodies.grip_m
        return Shape(f"held {color}", "tcp", "cylinder", shape.size, T[:3, 3], T[:3, :3],
                     part="object"), self.bodies.tcp_in_last @ T  # fmt: skip

    def _build(self) -> None:
        """The geometry model: the arm, its jaws, a held object per class, the table's contents.

        The table is a half-space lowered by the clearance, so that one margin serves every
        pair: a distance to it less the clearance is the height above the table. Every
        arm shape pairs with every obstacle, but for the table the arm's mount standing on
        it and the held object lifted from it. Objects stand in places, ``capacity`` per
        class, that :meth:`_apply` moves and switches on and off.
        """
        g = pin.GeometryModel()
        arm: list[tuple[Shape, np.ndarray, int]] = []
        for shape in self.arm_shapes:
            joint = self._joint_of.get(shape.body, self._last)
            arm.append((shape, self._in_joint(shape), joint))
        na = len(arm)
        self._held_row: dict[str, int] = {}
        for color in self.table.class_names:
            self._held_row[color] = len(arm)
            shape, T = self._held_shape(color)
            arm.append((shape, T, self._last))
        for shape, T, joint in arm:
            g.addGeometryObject(pin.GeometryObject(shape.name, joint, _se3(T), _coal(shape)))
        obstacles: list[tuple[Shape | None, np.ndarray]] = [(None, np.eye(4))]  # the table
        obstacles += list(self.bins)
        slots: dict[str, list[int]] = {}
        for color, n in self._capacity.items():
            for k in range(n):
                slots.setdefault(color, []).append(len(obstacles))
                shape = object_shape(self.table.class_named(color), f"{color}_{k}")
                obstacles.append((shape, np.eye(4)))
        table = coal.Halfspace(np.array([0.0, 0.0, 1.0]), -self.clearance_m)
        for obstacle, T in obstacles:
            geometry = table if obstacle is None else _coal(obstacle)
            name = "table" if obstacle is None else obstacle.name
            g.addGeometryObject(pin.GeometryObject(name, 0, _se3(T), geometry))
        # every arm shape with every obstacle, in that order (row by row); with the table
        # neither a held object nor the arm's mount standing on it
        with_table = [i < na and arm[i][0].name not in self._on_table for i in range(len(arm))]
        pair = np.ones((len(arm), len(obstacles)), dtype=bool)
        pair[:, 0] = with_table
        every = np.zeros((len(arm) + len(obstacles),) * 2, dtype=bool)
        every[: len(arm), len(arm) :] = pair
        g.setCollisionPairs(every)  # the pairs (i, j), i < j, row by row
        rows, cols = np.nonzero(pair)  # (row-major: the same order)
        self.geometry = g
        self.gdata = pin.GeometryData(g)
        self._pairs = list(zip(rows.tolist(), cols.tolist(), strict=True))
        self._pair_rows, self._pair_cols = rows, cols
        self._active = np.ones(len(rows), dtype=bool)
        self._arm = arm
        self._na = na
        self._rows = len(arm)
        self._slots = slots
        self._obstacles = obstacles
        self._base_names = ["table", *(s.name for s, _ in obstacles[1:])]  # type: ignore[union-attr]
        # the pairs with a bin's part, and its class (:meth:`bins_at`): bins do not move
        self._bin_pairs = [
            (k, bin_class, a)
            for k, (a, b) in enumerate(self._pairs)
            if (bin_class := class_of(self._base_names[b])) is not None
        ]
        self._bins_for: _BroadPhase | None = None  # the world :meth:`_bins_on` was read in
        self._on_but_for: _BroadPhase | None = None  # and :meth:`_on_but`, its pairs off
        self._on_but_off: list[int] = []
        self._on_but_now: _BroadPhase
        self._bins_on_now: tuple[_BroadPhase, dict[str, tuple[_BroadPhase, slice]]]
        self._ob_centre = np.array([T[:3, 3] for _, T in obstacles]).reshape(-1, 3)
        jaw_rows = [i for i, (s, _, _) in enumerate(arm) if s.jaw]
        # per object place, the jaws' pairs with it (switched off while it is between them)
        pair_of = {pair: k for k, pair in enumerate(self._pairs)}
        self._jaw_pairs = {
            col: [pair_of[(i, col)] for i in jaw_rows]
            for cols_of in slots.values()
            for col in cols_of
        }
        self._tool = np.array(
            [s.body == "tcp" or bool(s.jaw) or s.part == "object" for s, _, _ in arm]
        )
        self._half = np.array([_half_extents(s) for s, _, _ in arm])
        self._is_cyl = np.array([s.kind == "cylinder" for s, _, _ in arm])
        # the broad phase (:meth:`_lower_bounds`): a sphere about each arm shape
        self._row_joint = np.array([joint for _, _, joint in arm])
        self._row_local = np.array([T[:3, 3] for _, T, _ in arm])  # in its joint's frame
        self._row_radius = np.array([s.radius_m for s, _, _ in arm])
        # each obstacle's box along the world's axes (an object's holds its cylinder, one
        # turned holds it turned), half extents; the table's row is never read
        self._ob_half = np.array(
            [np.zeros(3)] + [np.abs(T[:3, :3]) @ _half_extents(s) for s, T in obstacles if s]
        )
        self._base_arm_names = [s.name for s, _, _ in arm]
        # a new model: the jaws and the objects are put in it afresh
        self._placed_opening: float | None = None
        self._placed_objects: list[tuple[str, str, float, float]] | None = None
        self._apply()

    def _apply(self) -> None:
        """Put the world in the model: the objects in their places, the held one, the jaws.

        The jaws are placed again only for a new opening, and the objects only when they
        changed (a simulator's world changes the held object and the opening at every
        grip, the objects once a pick): what stays is as it was put.
        """
        self._world += 1
        g = self.geometry.geometryObjects
        if self._opening_cm != self._placed_opening:
            self._place_jaws(g)
        row_on = np.zeros(self._rows, dtype=bool)
        row_on[: self._na] = True
        self._arm_names = list(self._base_arm_names)
        if self._held is not None:
            oid, color = self._held
            row_on[self._held_row[color]] = True
            self._arm_names[self._held_row[color]] = f"held {oid}"
        table = np.array([0.0, 0.0, -self._table_below_cm * M_PER_CM])
        g[self._rows].placement = _se3(_translate(table))
        self._table_z = table[2] - self.clearance_m  # the half-space's top face [m]
        if self._objects != self._placed_objects:
            self._place_objects(g)
        col_on = np.zeros(len(self._obstacles), dtype=bool)
        col_on[: 1 + len(self.bins)] = True
        col_on[self._object_cols] = True
        self._row_on, self._col_on = row_on, col_on
        want = row_on[self._pair_rows] & col_on[self._pair_cols]
        for pair in np.flatnonzero(want != self._active).tolist():
            if want[pair]:
                self.gdata.activateCollisionPair(pair)
            else:
                self.gdata.deactivateCollisionPair(pair)
        self._active = want
        self._on = self._broad_phase(np.flatnonzero(want))

    def _place_jaws(self, g: pin.StdVec_GeometryObject) -> None:
        """The jaws' shapes where the opening puts them, and the tool's shapes as placed now."""
        for k, (shape, _, _) in enumerate(self._arm[: self._na]):
            if shape.jaw:
                T = self._in_joint(shape)
                g[k].placement = _se3(T)
                self._row_local[k] = T[:3, 3]
        tool = np.flatnonzero(self._tool[: self._na]).tolist()  # the tool as placed now
        half, cyl = self._half.tolist(), self._is_cyl.tolist()
        self._tool_shapes = [
            (g[k].parentJoint, g[k].placement, half[k], cyl[k], self._arm[k][0].name) for k in tool
        ]
        self._placed_opening = self._opening_cm

    def _place_objects(self, g: pin.StdVec_GeometryObject) -> None:
        """Each object on the table in a place of its class; their names and columns."""
        self._ob_names = list(self._base_names)
        used: dict[str, int] = {}
        cols = []
        for oid, color, x, y in self._objects:
            col = self._slots[color][used.get(color, 0)]
            used[color] = used.get(color, 0) + 1
            centre = object_centre_m(self.table.class_named(color), x, y)
            g[self._rows + col].placement = pin.SE3(_NO_TURN, centre)
            self._ob_centre[col] = centre
            self._ob_names[col] = object_name(oid)
            cols.append(col)
        self._object_cols = np.array(cols, dtype=int)
        self._objects_at = [
            (c, x, y) for c, (x, y) in zip(cols, self._ob_centre[cols, :2].tolist(), strict=True)
        ]
        self._place_of = {self._ob_names[c]: (c, x, y) for c, x, y in self._objects_at}
        self._placed_objects = list(self._objects)

    def _broad_phase(self, pairs: np.ndarray) -> _BroadPhase:
        """What :meth:`_lower_bounds` reads of ``pairs`` (ascending pair indices), per pair.

        Gathered once per world (the pairs switched on), and again only for a pose whose
        jaws straddle an object or that holds pairs to a floor of their own.
        """
        rows, cols = self._pair_rows[pairs], self._pair_cols[pairs]
        table = np.flatnonzero(cols == 0)
        return _BroadPhase(
            pairs,
            3 * rows[:, None] + np.arange(3),  # (row, axis) in the flattened (rows, 3)
            self._ob_centre[cols],
            self._ob_half[cols],
            self._row_radius[rows],
            table,
            3 * rows[table] + 2,
        )

    def _local_reach(self) -> np.ndarray:
        """How far each joint frame's shapes reach from its origin [m], (n + 2,).

        Frames 0 … n, and the tool's (n + 1, from the TCP: the jaws as open as the world
        holds them, a held object of the largest class) counted in the last joint's. A
        jaw's pad slides half the opening across the TCP; the jaws' servo's whole range
        would be no bound at all for a servo of fine units (0.1 µs a unit: kilometres).
        """
        far = np.zeros(self._last + 2)
        slide = self._opening_cm * M_PER_CM / 2
        tcp = np.linalg.norm(self.bodies.tcp_in_last[:3, 3])
        held = max(c.diameter_cm + c.height_cm for c in self.table.classes) * M_PER_CM
        for shape in self.arm_shapes:
            reach = float(np.linalg.norm(shape.pos)) + shape.radius_m
            if shape.body == "tcp" or shape.jaw:
                k, reach = self._last + 1, reach + (slide if shape.jaw else 0.0)
            else:
                k = self._joint_of[shape.body]
            far[k] = max(far[k], reach)
        far[self._last + 1] = max(far[self._last + 1], self.bodies.grip_m + held)
        far[self._last] = max(far[self._last], tcp + far[self._last + 1])
        return far

    # ----------------------------------------------------------------- checks

    def gap(self, q: npt.ArrayLike, *, target: str | None = None) -> tuple[float, str, str]:
        """The smallest gap at pose ``q`` less the clearance [m], and its two shapes.

        Args:
            q: The pose, model units, (n,).
            target: The object the jaws close on: their pads may touch it while it stands
                between them (``None``: any object between them).
        """
        g, a, b, _ = self._gap(q, target, {})
        return g, a, b

    def _gap(
        self, q: npt.ArrayLike, target: str | None, floors: Mapping[int, float]
    ) -> tuple[float, str, str, float]:
        """:meth:`gap` with some pairs held to a floor of their own, and the pair's distance.

        Args:
            q: The pose, model units, (n,).
            target: As for :meth:`gap`.
            floors: Per pair index, the distance it keeps instead of the clearance [m]
                (:meth:`first_contact`: a pair within it at the path's start).

        Returns:
            The smallest of each pair's distance less its floor (the clearance, or its own)
            [m], its two shapes, and their distance as a contact reports it [m] (the
            table's: the height above it).
        """
        pm = self.model.model
        q = np.asarray(q, dtype=float)
        pin.forwardKinematics(pm, self.data, q)
        self._frames_at = None
        key = (self._world, target, q.tobytes(), tuple(floors.items()))
        if key == self._last_key:  # a path's end is the next path's start
            self._frames_at = self._last_frames  # (the same pose's: the same numbers)
            return self._last_gap
        jaws = [k for col in self._between_jaws(target) for k in self._jaw_pairs[col]]
        own = [k for k in floors if self._active[k] and k not in jaws]
        pin.updateGeometryPlacements(pm, self.data, self.geometry, self.gdata)
        on = self._on
        if jaws or own:  # (the pairs with a floor of their own are measured one by one)
            on = self._on_but(jaws + own)
        found = (math.inf, "", "", math.inf)
        nearest = self._nearest_pair(on)
        if nearest is not None:
            found = self._gap_of(*nearest, self.clearance_m)
        for j in own:
            d = pin.computeDistance(self.geometry, self.gdata, j).min_distance
            found = min(found, self._gap_of(j, d, floors[j]))
        self._last_key, self._last_gap, self._last_frames = key, found, self._frames_at
        return found

    def _on_but(self, off: list[int]) -> _BroadPhase:
        """The broad phase of the pairs switched on but ``off`` (pair indices).

        Kept for the next call with the same ``off`` in the same world (:meth:`_bins_on`'s
        test): a path's checks with an object between the jaws, or with pairs held to a
        floor of their own, leave out the same pairs one pose after another.
        """
        if self._on_but_for is not self._on or self._on_but_off != off:
            keep = self._active.copy()
            keep[off] = False
            self._on_but_now = self._broad_phase(np.flatnonzero(keep))
            self._on_but_for, self._on_but_off = self._on, off
        return self._on_but_now

    def _nearest_pair(
        self, on: _BroadPhase, low: np.ndarray | None = None
    ) -> tuple[int, float] | None:
        """The nearest of the pairs ``on`` and their distance [m].

        What ``pin.computeDistances`` finds with only those pairs switched on (the lowest
        index of a tie included), without measuring each: a pair is no nearer than a sphere
        about its arm shape is to a box about its obstacle (:meth:`_lower_bounds`, or
        ``low``, those bounds worked out already). Pairs are measured in the order of that
        bound until it passes the nearest distance measured: some 20 of 300 pairs in the
        reference sort. ``None``: no pair is on. The few pairs near enough are sorted in
        Python (``sorted`` is stable: the order of ``np.argsort(kind="stable")``), and
        the bounds read one by one (``item``), not through arrays of two or three.
        """
        low = self._lower_bounds(on) if low is None else low
        best, best_k = math.inf, -1
        if not len(low):
            return None
        geometry, gdata, pairs = self.geometry, self.gdata, on.pairs
        first = int(low.argmin())  # the least bound (the first of a tie): the order's first
        if math.isnan(low.item(first)):  # a NaN bound (argmin finds it first): every pair, in order
            order = np.argsort(low, kind="stable").tolist()
        else:
            k = pairs.item(first)
            d = pin.computeDistance(geometry, gdata, k).min_distance
            if d < best:
                best, best_k = d, k
            # the order goes on with the bounds up to the nearest distance so far (the
            # loop stops at the first beyond it): those few sorted, not every pair
            near = (low <= best + BROAD_PHASE_SLACK_M).nonzero()[0].tolist()
            order = sorted(near, key=low.item)
            if order and order[0] == first:
                del order[0]
        for i in order:
            if low.item(i) > best + BROAD_PHASE_SLACK_M:
                break
            k = pairs.item(i)
            d = pin.computeDistance(geometry, gdata, k).min_distance
            if d < best or (d == best and k < best_k):
                best, best_k = d, k
        return None if best_k < 0 else (best_k, best)

    def _frames(self) -> np.ndarray:
        """Each joint frame's placement at the last pose's kinematics, (n + 1, 4, 4).

        Read from Pinocchio once per pose (each placement as one array) for the broad
        phase and the reach, which both take them: some 800 poses in the reference sort.
        Kept until the kinematics run again.
        """
        if self._frames_at is None:
            self._frames_at = np.array([M.homogeneous for M in self._placements])
        return self._frames_at

    def _lower_bounds(self, on: _BroadPhase) -> np.ndarray:
        """Each pair's distance at least, at the last pose's kinematics [m], (len(on.pairs),).

        The arm shape lies in a sphere about its centre (:attr:`Shape.radius_m`), the
        obstacle in a box along the world's axes: the distance from the sphere to the box;
        for the table, the sphere's height above the table's top face. Worked out for
        the pairs at once, each pair's own arithmetic (the bits of a table of every arm
        shape by every obstacle, picked per pair). The arm shapes' centres are spread to
        the pairs by ``take`` of their flat places (a copy, as fancy indexing's, at a fifth
        of its cost on the 17 rows by some 240 pairs). The product and the sum of squares
        stay NumPy's (``@``, ``einsum``): they sum as OpenBLAS and NumPy's SIMD loops do,
        which Python's arithmetic does not repeat bit for bit.
        """
        F = self._frames().take(self._row_joint, axis=0)  # each arm shape's joint frame
        centre = (F[:, :3, :3] @ self._row_local[:, :, None])[:, :, 0] + F[:, :3, 3]
        out = centre.take(on.centre_at)  # (pair, 3)
        out -= on.ob_centre
        np.abs(out, out=out)
        out -= on.ob_half
        np.maximum(out, 0.0, out=out)  # beyond the obstacle's box, per axis (in place)
        low = np.einsum("ij,ij->i", out, out)
        np.sqrt(low, out=low)
        low[on.table] = centre.take(on.table_z_at) - self._table_z  # the table
        low -= on.radius
        return low

    def _gap_of(
        self, pair: int, distance_m: float, floor_m: float
    ) -> tuple[float, str, str, float]:
        """A pair's gap over its floor, its shapes and its distance as a contact reports it."""
        a, b = self._pair_names(pair)
        # the table is lowered by the clearance: its distance less that is the height
        shown = distance_m - self.clearance_m if b == "table" else distance_m
        return float(distance_m - floor_m), a, b, float(shown)

    def _pair_names(self, pair: int) -> tuple[str, str]:
        """A pair's arm shape and obstacle, as the world names them now."""
        a, b = self._pairs[pair]
        return self._arm_names[a], self._ob_names[b]

    def _start_distances(self, q: npt.ArrayLike, target: str | None) -> dict[int, float]:
        """The pairs within the clearance at a path's first pose, and their distance there [m].

        Pairs closer than the clearance, touching ones too (their distance < 0: how far
        one is in the other), but the table never: the jaws come down to it, and it keeps
        no clearance (a pose below it is refused at the path's start, as any touch).
        Empty when the pose keeps the clearance.
        """
        g, _, _ = self.gap(q, target=target)
        if g >= TOUCH_M:
            return {}
        pm = self.model.model
        pin.updateGeometryPlacements(pm, self.data, self.geometry, self.gdata, np.asarray(q, float))
        self._frames_at = None
        jaws = [k for col in self._between_jaws(target) for k in self._jaw_pairs[col]]
        for k in jaws:
            self.gdata.deactivateCollisionPair(k)
        pin.computeDistances(self.geometry, self.gdata)  # every pair switched on
        for k in jaws:
            self.gdata.activateCollisionPair(k)
        results = self.gdata.distanceResults
        near = {}
        for k in np.flatnonzero(self._active).tolist():
            d = float(results[k].min_distance)
            if k in jaws or self._pair_cols[k] == 0 or d >= self.clearance_m + TOUCH_M:
                continue
            near[k] = d
        return near

    def touching(self, q: npt.ArrayLike) -> list[tuple[str, str, float]]:
        """The arm's shapes in touch with a bin or an object at pose ``q``, the table never.

        ``(arm part, obstacle, distance [cm])`` per pair closer than the clearance (touching
        ones too, their distance < 0: how far one is in the other), nearest first; the
        jaws' pads against an object standing between them are not counted (they hold
        it). Empty when ``q`` keeps the clearance.
        """
        near = self._start_distances(q, None)
        return sorted(
            ((*self._pair_names(k), d / M_PER_CM) for k, d in near.items()), key=lambda t: t[2]
        )

    def away_from(self, q: npt.ArrayLike, *, target: str | None = None) -> np.ndarray | None:
        """The way out, in the table plane, from what pose ``q`` is within the clearance of.

        The mean of the directions from each such pair's nearest point on the obstacle to
        the one on the arm (:meth:`_start_distances`), as a unit vector (2,); ``None`` when
        ``q`` keeps the clearance, or the pairs pull opposite ways. For a pair touching,
        against coal's normal (from the arm's shape to the obstacle): its points are then
        each one's deepest in the other, and point the other way.
        """
        near = self._start_distances(q, target)  # (it leaves the placements at q)
        way = np.zeros(2)
        for k, start in near.items():
            r = pin.computeDistance(self.geometry, self.gdata, k)
            if start < TOUCH_M:
                d = -np.asarray(r.normal)[:2]
            else:
                d = (np.asarray(r.getNearestPoint1()) - np.asarray(r.getNearestPoint2()))[:2]
            n = float(np.linalg.norm(d))
            if n > 0:
                way += d / n
        n = float(np.linalg.norm(way))
        return way / n if n > 1e-6 else None

    def bins_at(self, q: npt.ArrayLike) -> list[tuple[str, str, float]]:
        """Each standing bin's distance from the arm at pose ``q`` [cm], and the arm's part.

        ``(class, arm part, distance)`` per bin, nearest part first; the clearance is not
        taken off.
        """
        pm = self.model.model
        pin.updateGeometryPlacements(pm, self.data, self.geometry, self.gdata, np.asarray(q, float))
        self._frames_at = None
        every, bins = self._bins_on()
        low = self._lower_bounds(every) if len(every.pairs) else np.zeros(0)
        out = []
        for color, (on, at) in bins.items():
            nearest = self._nearest_pair(on, low[at])
            assert nearest is not None  # (a bin is listed only with a pair switched on)
            k, d = nearest
            out.append((color, self._arm_names[self._pair_rows[k]], d / M_PER_CM))
        return out

    def _bins_on(self) -> tuple[_BroadPhase, dict[str, tuple[_BroadPhase, slice]]]:
        """The bins' pairs switched on, and per bin (its class) its own and their place.

        Gathered once per world: :meth:`bins_at` works out the lower bounds of all of them
        at once, then measures each bin's nearest pair in the order of its pairs' bounds
        (a few of each bin's 70-90), not every one; the nearest is the same, a tie going
        to the lowest pair as before. The bins in the order their first pairs come.
        """
        if self._bins_for is not self._on:
            by_bin: dict[str, list[int]] = {}
            for k, color, _ in self._bin_pairs:
                if self._active[k]:
                    by_bin.setdefault(color, []).append(k)
            bins, start = {}, 0
            for color, ks in by_bin.items():
                bins[color] = (self._broad_phase(np.array(ks)), slice(start, start + len(ks)))
                start += len(ks)
            every = self._broad_phase(np.array([k for ks in by_bin.values() for k in ks], int))
            self._bins_on_now = (every, bins)
            self._bins_for = self._on
        return self._bins_on_now

    def _between_jaws(self, target: str | None) -> list[int]:
        """The object columns standing between the jaws at the last pose's kinematics.

        An object whose axis is within half the opening of the grip point, in the plane,
        is straddled or held by the jaws: their pads may touch it. ``target`` limits this
        to that object (``None``: any object). In Python numbers, a few objects at a time
        (the bits of ``np.linalg.norm``: a sum of two squares, its square root).
        """
        if target is None:
            places = self._objects_at
        else:
            place = self._place_of.get(object_name(target))
            places = [] if place is None else [place]
        if not places:
            return []
        M = self._placements[self._last]
        gx, gy, _ = (M.rotation @ self._grip_in_last + M.translation).tolist()
        reach = self._opening_cm * M_PER_CM / 2
        out = []
        for col, x, y in places:
            dx, dy = x - gx, y - gy
            if math.sqrt(dx * dx + dy * dy) <= reach:
                out.append(col)
        return out

    def clear_height_cm(self, q: npt.ArrayLike) -> float:
        """The TCP height where the tool clears every bin wall and object [cm].

        The tool (jaws, their servo, a held object) hangs below the TCP as at pose ``q``;
        its lowest point keeps the clearance above the highest top.
        """
        low = self._lowest_points(q)
        tcp = float(self.model.fk_cm(q)[2]) * M_PER_CM
        hang = max(0.0, tcp - float(np.min(low[self._tool & self._row_on])))
        tops = [0.0] + [
            float(self._ob_centre[j, 2] + _half_extents(s)[2])  # type: ignore[arg-type]
            for j, (s, _) in enumerate(self._obstacles)
            if j > 0 and self._col_on[j]
        ]
        return (max(tops) + self.clearance_m + hang) / M_PER_CM

    def clear_height_between_cm(
        self, q: npt.ArrayLike, to_cm: npt.ArrayLike, *, within_reach: bool = False
    ) -> float:
        """:meth:`clear_height_cm` over what lies under the way from pose ``q`` to ``to_cm``.

        The arm turns about its base on the way from the TCP at ``q`` to the point
        ``to_cm`` [cm], and every link sweeps the sector between the two azimuths about the
        base's axis, from the axis out (the shorter way round), not the TCP's line: the
        bin walls and object tops that count are those whose footprint comes within the
        clearance and the arm's half-width (its shapes' farthest reach sideways from the
        vertical plane through the base's axis and the TCP, at ``q``) of that sector; one
        the base's axis stands in counts too. A height to try: the path at it is still
        checked whole (:meth:`first_contact`). Where the TCP at ``q`` or ``to_cm`` is on
        the base's axis (no azimuth), as :meth:`clear_height_cm`.

        ``within_reach``: only what comes within the clearance of how far out from the
        base's axis the arm's shapes reach at ``q`` counts too (for a way that keeps the
        TCP where it is, straight up: the arm reaches about as far all the way). The
        paper's arm releasing a yellow over its bin 32 cm out (``sim_4colours``) reaches
        35 cm out; the green bin's walls, grown 20 cm tall for four 4 cm greens, stand
        45 cm out on the same azimuth and do not lie under that way.
        """
        low = self._lowest_points(q)  # (the kinematics at q, for the placements below)
        tcp = self.model.fk_cm(q) * M_PER_CM
        hang = max(0.0, float(tcp[2]) - float(np.min(low[self._tool & self._row_on])))
        bx, by = (float(v) for v in self.data.oMi[1].translation[:2])  # the base's axis
        ends = [(float(tcp[0]) - bx, float(tcp[1]) - by)]
        to = np.asarray(to_cm, dtype=float) * M_PER_CM
        ends.append((float(to[0]) - bx, float(to[1]) - by))
        if min(math.hypot(x, y) for x, y in ends) < 1e-4:
            return self.clear_height_cm(q)
        a0 = math.atan2(ends[0][1], ends[0][0])
        span = _wrapped(math.atan2(ends[1][1], ends[1][0]) - a0)
        lo, hi = min(0.0, span), max(0.0, span)  # the sector, relative to a0 [rad]
        # the arm's half-width: its shapes' farthest point sideways of its vertical plane
        norm = math.hypot(*ends[0])
        across = np.array([ends[0][1] / norm, -ends[0][0] / norm, 0.0])
        rows = np.flatnonzero(self._row_on).tolist()
        oMg = self.gdata.oMg
        R = np.array([oMg[k].rotation for k in rows])
        c = np.array([oMg[k].translation for k in rows]) - [bx, by, 0.0]
        wide = np.abs(c @ across) + _extent(R, self._half[rows], self._is_cyl[rows], across)
        pad = self.clearance_m + float(np.max(wide))
        out = math.inf
        if within_reach:  # each shape's centre's distance from the axis, and its half-diagonal
            out = self.clearance_m + float(
                np.max(np.hypot(c[:, 0], c[:, 1]) + np.linalg.norm(self._half[rows], axis=1))
            )
        tops = [0.0]
        for j in range(1, len(self._obstacles)):
            if not self._col_on[j]:
                continue
            (cx, cy, cz), (hx, hy, hz) = self._ob_centre[j], self._ob_half[j]
            # its footprint's nearest point to the base's axis, and the azimuths it spans
            # (its corners' about its centre's: under a half turn, the axis outside it)
            near = math.hypot(max(abs(cx - bx) - hx, 0.0), max(abs(cy - by) - hy, 0.0))
            if near > out:
                continue
            if near > pad:
                mid = math.atan2(cy - by, cx - bx)
                turns = [
                    _wrapped(math.atan2(cy + sy * hy - by, cx + sx * hx - bx) - mid)
                    for sx in (-1.0, 1.0)
                    for sy in (-1.0, 1.0)
                ]
                grow = math.asin(pad / near)
                at = _wrapped(mid - a0)
                first, last = at + min(turns) - grow, at + max(turns) + grow
                if not any(
                    first + k * 2 * math.pi <= hi and last + k * 2 * math.pi >= lo
                    for k in (-1, 0, 1)
                ):
                    continue
            tops.append(float(cz + hz))
        return (max(tops) + self.clearance_m + hang) / M_PER_CM

    def tool_lowest_cm(self, q: npt.ArrayLike) -> tuple[float, str]:
        """The tool's lowest point at pose ``q``: its height above the table [cm], its shape.

        The tool is the jaws (as open as the model holds them), their servo and the hand:
        only they are placed, and :func:`_lowest` worked in floats in the same order (the
        bits of :meth:`_lowest_points`' rows; a calibration asks ten thousand times).
        """
        pin.forwardKinematics(self.model.model, self.data, np.asarray(q, float))
        self._frames_at = None
        oMi = self.data.oMi
        best, name = math.inf, ""
        for joint, placement, (hx, hy, hz), cyl, shape in self._tool_shapes:
            M = oMi[joint] * placement
            r0, r1, r2 = M.rotation[2].tolist()  # the world z of the shape's axes
            down = (abs(r2) * hz + hx * math.sqrt(min(max(1.0 - r2 * r2, 0.0), 1.0)) if cyl
                    else abs(r0) * hx + abs(r1) * hy + abs(r2) * hz)  # fmt: skip
            low = float(M.translation[2]) - down
            if low < best:
                best, name = low, shape
        return best / M_PER_CM, name

    def _lowest_points(self, q: npt.ArrayLike) -> np.ndarray:
        """Each arm shape's lowest point's height at pose ``q`` [m], (rows,), held ones too."""
        pm = self.model.model
        pin.updateGeometryPlacements(pm, self.data, self.geometry, self.gdata, np.asarray(q, float))
        self._frames_at = None
        oMg = self.gdata.oMg
        R = np.array([oMg[k].rotation for k in range(self._rows)])
        c = np.array([oMg[k].translation for k in range(self._rows)])
        return c[:, 2] - _lowest(R, self._half, self._is_cyl)

    def _reach(self) -> np.ndarray:
        r"""R_i at the last pose's kinematics, (n,) [m per rad; 1 m per m for a prismatic joint].

        The farthest any shape beyond joint i can be from the joint's origin: over the
        joints j ≥ i, :math:`|o_j - o_i|` plus how far joint j's shapes reach from
        :math:`o_j` (the tool's from the TCP, the last joint's origin plus the TCP's offset).
        In Python numbers, the n (n + 1) / 2 separations of a few joints: the bits of
        ``np.linalg.norm`` (its sum of the three squares goes in order) and of ``np.max``
        (a NaN spreads), at a third of the cost of their arrays at each check.
        """
        n = self._last
        origins = self._frames()[1 : n + 1, :3, 3].tolist()
        local = self._reach_local[1 : n + 1].tolist()
        far = []
        for i, (xi, yi, zi) in enumerate(origins):
            most = 0.0
            for (xj, yj, zj), r in zip(origins[i:], local[i:], strict=True):
                dx, dy, dz = xj - xi, yj - yi, zj - zi
                v = math.sqrt(dx * dx + dy * dy + dz * dz) + r
                if v > most or v != v:
                    most = v
            far.append(1.0 if self._prismatic[i] else most)
        return np.array(far)

    def opening_contact(self, q: npt.ArrayLike, open_cm: float) -> Contact | None:
        """The first opening where the jaws, opening at pose ``q``, come too close to something.

        From the world's opening to ``open_cm``, what they held let go (a release: it
        falls); ``None``: they open clear. Checked at openings close enough that no pad
        steps over anything between two (the module docstring); the world is as it was
        afterwards. The contact's ``pose_index`` is the opening's step.
        """
        opening = self._opening_cm
        # each pad moves half the opening's step: no more than a wall and two clearances
        step_cm = 2.0 * (BIN_WALL_M + 2.0 * self.clearance_m) / M_PER_CM
        n = max(1, math.ceil((open_cm - opening) / step_cm))
        with self._let_go():
            for k in range(1, n + 1):
                self._open_to(opening + (open_cm - opening) * k / n)
                g, a, b, d = self._gap(q, None, {})
                self.checks += 1
                if g < TOUCH_M:
                    return Contact(a, b, d / M_PER_CM, np.asarray(q, float), k)
        return None

    def open_clear_height_cm(self, q: npt.ArrayLike, open_cm: float) -> float:
        """:meth:`clear_height_cm` with the jaws opened to ``open_cm`` and what they held let go.

        Where a release at pose ``q`` may be raised to, for the jaws to open clear of
        every bin wall and object top; the world is as it was afterwards.
        """
        with self._let_go():
            self._open_to(open_cm)
            return self.clear_height_cm(q)

    @contextmanager
    def released(self, open_cm: float) -> Iterator[None]:
        """The world with the jaws opened to ``open_cm`` and what they held let go, for a while.

        What a release leaves (:meth:`opening_contact` checks the opening itself): the way
        out of a bin from a release is planned in it before the place is sent
        (:meth:`Planner.plan_place <mearm.task.plan.Planner.plan_place>`); the world is as
        it was afterwards.
        """
        with self._let_go():
            self._open_to(open_cm)
            yield

    @contextmanager
    def _let_go(self) -> Iterator[None]:
        """The world without the held object for a while (:meth:`_open_to` opens the jaws)."""
        objects, opening, held, below = (
            self._objects, self._opening_cm, self._held, self._table_below_cm
        )  # fmt: skip
        try:
            yield
        finally:
            self.set_world(objects, opening_cm=opening, held=held, table_below_cm=below)

    def _open_to(self, opening_cm: float) -> None:
        """The jaws at ``opening_cm``, nothing held, the rest of the world kept."""
        self.set_world(opening_cm=opening_cm, table_below_cm=self._table_below_cm)

    def _walk_along(
        self, path: np.ndarray, world: tuple[int, str | None, float]
    ) -> tuple[_Walk | None, int]:
        """The kept walk (:class:`_Walk`) that shares the most segments with ``path``, and how many.

        ``(None, 0)`` where none starts at ``path``'s first pose in ``world``.
        """
        best: tuple[_Walk | None, int] = (None, 0)
        for walk in self._walks:
            if walk.world == world:
                same = _shared_segments(walk.path, path)
                if same >= 0 and (best[0] is None or same > best[1]):
                    best = (walk, same)
        return best

    def forget_paths(self) -> None:
        """Check the next path afresh, as if none had been checked (a bench's timing)."""
        self._walks = []

    def first_contact(
        self, q_path: npt.ArrayLike, *, target: str | None = None, allowance_m: float = 0.0
    ) -> Contact | None:
        r"""The first pose along ``q_path`` that comes too close to something, or ``None``.

        Between rows the joints move on a straight line; ``None``: the whole path is clear.
        A pair within the clearance at the first row, or touching there, may not come
        closer than it starts there (:meth:`_start_distances`, the module docstring);
        every other pair keeps the clearance.

        Conservative advancement (the module docstring): at a pose with gap ``g`` to
        spare, the next check comes where some point of the arm could first have moved
        ``g``, bounded by :math:`\sum_i (R_i + g) |\Delta q_i|` (:meth:`_reach`; while
        every point moves less than ``g``, none gets farther than that from an axis).
        A path that starts as one of the last few checked in the same world is walked as
        that one was over the segments the two share, its checks there taken, not made
        again (:class:`_Walk`): the result is the one a fresh walk finds.

        Args:
            q_path: The poses, model units, (k, n).
            target: The object the jaws close on at the path's end (they may touch it).
            allowance_m: How much nearer than the clearance (and each pair's floor) the
                path may come [m]. A path this check passed keeps the clearance between
                the poses it checked but :data:`TOUCH_M` more at them, so the same path
                sampled elsewhere (the commands' chords: :meth:`Executor.followed
                <mearm.task.execute.Executor.followed>`) may come within that band of
                it and be refused; with ``TOUCH_M`` it is held to the clearance itself.
        """
        path = np.atleast_2d(np.asarray(q_path, dtype=float))
        last = len(path) - 1
        step = np.diff(path, axis=0)  # each segment's joint motion, (last, n)
        seg = np.abs(step)  # and travel
        world = (self._world, target, allowance_m)
        walk, same = self._walk_along(path, world)
        if walk is None:
            start = self._start_distances(path[0], target)
            # such a pair may come no more than TOUCH_CM closer than it starts, nor touch
            # if it starts clear (the check refuses a distance under its floor + TOUCH_M)
            floors = {
                k: (d - TOUCH_M if d < TOUCH_M else max(d - TOUCH_M, TOUCH_M)) - TOUCH_M
                for k, d in start.items()
            }
            names = {self._pair_names(k): d / M_PER_CM for k, d in start.items()}
            walk = _Walk(world, path, floors, names)
            replay: list[tuple[int, float, float, np.ndarray]] = []
        else:  # its checks in the segments the two paths share, as that walk made them
            replay = walk.checks[
                : next((i for i, c in enumerate(walk.checks) if c[0] >= same), None)
            ]
            walk = _Walk(world, path, walk.floors, walk.start_cm)
        self._walks = [w for w in self._walks if w.world == world][-_WALKS_KEPT + 1 :] + [walk]
        floors, names = walk.floors, walk.start_cm
        k, t = 0, 0.0
        walk.checks.extend(replay)
        resume = bool(replay)  # (from the last check taken: the steps before it are known)
        while True:
            if resume:
                k, t, g, reach = replay[-1]
                resume = False
            else:
                q = path[k] + t * step[k] if k < last else path[last]
                g, a, b, d = self._gap(q, target, floors)
                g += allowance_m
                self.checks += 1
                if g < TOUCH_M:
                    return Contact(a, b, d / M_PER_CM, q, k, names.get((a, b)))
                if k == last:
                    return None
                reach = self._reach()
                walk.checks.append((k, t, g, reach))
            # how far a point may move before the next check is g [m]: walk the segments'
            # sweeps (per unit of each) until they add up to more
            sweep = (seg[k:] @ (reach + g)).tolist()
            j, ahead = _first_beyond(sweep, sweep[0] * t, g)
            if j >= len(sweep):
                k, t = last, 0.0
            elif j == 0:
                t += g / sweep[0]
            else:
                k, t = k + j, (g - ahead) / sweep[j]


#: How many of its last paths' checks :meth:`CollisionModel.first_contact` keeps, to walk
#: a new path's first segments as one of them did.
_WALKS_KEPT = 4


@dataclass
class _Walk:
    """One path's checks by :meth:`CollisionModel.first_contact`, for the paths after it.

    A path that starts as one checked before in the same world (a detour's way up from
    home, planned again for every pick a layout tries: :func:`mearm.task.scene.random_scene`)
    is walked as that one was where the two are the same: each check there is at the same
    pose, its gap and the step after it the same numbers, so it is taken, not computed.
    The first check whose step leaves the shared segments is where the new walk goes on.
    """

    world: tuple[int, str | None, float]  # the world's count, the target, the allowance
    path: np.ndarray  # the poses, (k, n)
    floors: dict[int, float]  # the start's pairs within the clearance, held to these [m]
    start_cm: dict[tuple[str, str], float]  # and their distance at the start, by name
    # each clear check's segment, the fraction of it, its gap [m] and reach (:meth:`_reach`)
    checks: list[tuple[int, float, float, np.ndarray]] = field(default_factory=list)


def _shared_segments(a: np.ndarray, b: np.ndarray) -> int:
    """How many segments two paths of poses share from their start (−1: not the first pose)."""
    n = min(len(a), len(b))
    differ = np.flatnonzero(np.any(a[:n] != b[:n], axis=1))  # (a NaN differs: walked afresh)
    return (int(differ[0]) if len(differ) else n) - 1


def _first_beyond(sweep: list[float], done: float, g: float) -> tuple[int, float]:
    """Where the running sum of ``sweep``, less ``done``, first passes ``g``.

    Returns that index ``j`` (``len(sweep)``: nowhere) and the sum less ``done`` before it
    (at ``j - 1``). The bits of ``np.cumsum(sweep) - done`` and ``np.searchsorted(..., g,
    side="right")`` (a cumulative sum adds in order), stopped at the answer: a path's check
    walks on from pose to pose, and the next check is mostly within a segment or two.
    """
    total, before = 0.0, 0.0
    for j, s in enumerate(sweep):
        total += s
        ahead = total - done
        if ahead > g or ahead != ahead:  # (a NaN sorts last, as in NumPy)
            return j, before
        before = ahead
    return len(sweep), before


def _extent(R: np.ndarray, half: np.ndarray, is_cyl: np.ndarray, n: np.ndarray) -> np.ndarray:
    """How far each shape reaches from its centre along the unit vector ``n`` [m], (k,).

    :func:`_lowest` along any direction: a box's corner, a cylinder's rim.
    """
    rn = np.einsum("j,kji->ki", n, R)  # ``n``'s component of each of the shape's axes
    box = np.sum(np.abs(rn) * half, axis=1)
    axial = np.abs(rn[:, 2]) * half[:, 2]
    rim = half[:, 0] * np.sqrt(np.clip(1.0 - rn[:, 2] ** 2, 0.0, 1.0))
    return np.where(is_cyl, axial + rim, box)


def _wrapped(angle: float) -> float:
    """``angle`` [rad] in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


def _half_extents(shape: Shape) -> np.ndarray:
    if shape.kind == "box":
        return np.asarray(shape.size, dtype=float)
    return np.array([shape.size[0], shape.size[0], shape.size[1]])


def _lowest(R: np.ndarray, half: np.ndarray, is_cyl: np.ndarray) -> np.ndarray:
    """How far each shape reaches below its centre [m], (k,): a box's corner, a cylinder's rim."""
    rz = R[:, 2, :]  # the world z of each of the shape's axes
    box = np.sum(np.abs(rz) * half, axis=1)
    axial = np.abs(rz[:, 2]) * half[:, 2]
    rim = half[:, 0] * np.sqrt(np.clip(1.0 - rz[:, 2] ** 2, 0.0, 1.0))
    return np.where(is_cyl, axial + rim, box)


__all__ = ["DEFAULT_CLEARANCE_CM", "TOUCH_CM", "CollisionModel", "Contact", "joint_servo"]
