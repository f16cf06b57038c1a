"""The whole configuration: the arm, the rig around it and the task."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

from pydantic import Field, ValidationInfo, field_validator, model_validator

from mearm.config.arm import ArmDescription, base_radius_m
from mearm.config.base import MAX_LENGTH_CM, Seed, Strict
from mearm.config.belt_config import (
    FOLLOW_SHARE,
    BeltConfig,
    arrival_draws,
    follow_limit_cm_s,
    overhang_cm,
)
from mearm.config.defaults import paper_arm
from mearm.config.sections import (
    CalibrationConfig,
    CameraConfig,
    ControllerConfig,
    SceneObject,
    ServoConfig,
    TaskConfig,
    VisionConfig,
)
from mearm.config.servo_models import SERVO_NAMES
from mearm.config.twin_camera_config import TwinCameraConfig
from mearm.config.twin_faults_config import TwinFault
from mearm.config.twin_lamp_config import TwinLampConfig

#: A projective calibration may shrink the far side of the frame, but no pixel's w (its
#: inverse depth) may be under this fraction of another's: 20:1 is a camera looking
#: almost along the table.
MIN_W_RATIO = 0.05


#: The validation context key under which the loader gives the config the user named
#: (``--config``'s value, as typed) and whether it is one mearm ships: ``(name, shipped)``.
CONFIG_GIVEN = "config_given"


def _recalibrate(info: ValidationInfo) -> str:
    """What to run to recalibrate the config being validated, naming it when known.

    A shipped config is not edited by ``calibrate-camera``: the user's own copy is.
    """
    import shlex  # noqa: PLC0415  (only a refusal's message quotes the name)

    given = (info.context or {}).get(CONFIG_GIVEN)
    command = "mearm calibrate-camera --config {} --image PICTURE --marker ID:X,Y ..."
    if given is None:
        return f"recalibrate at this size ({command.format('FILE')})"
    name, shipped = given
    if shipped:
        return (
            f"recalibrate at this size in a config of your own, as {name} is one mearm "
            f"ships (mearm init-config MINE.yaml, then {command.format('MINE.yaml')})"
        )
    return f"recalibrate at this size ({command.format(shlex.quote(name))})"


#: The room the open jaws keep each side of an object's widest at least [cm]: the arm and
#: the camera land them off by their errors. In the twin (simulated, 2026-12-07) the MeArm
#: v1's jaw came down on the rim of discs that left 0.35 and 0.4 cm (2.3 cm at seed 35028,
#: 2.2 cm at seed 38034, ``sim_mearm_v1_mujoco --random 5``), and with 0.5 cm (2.0 cm
#: discs) seeds 38034 and 38036–38038 sorted whole, as the paper arm's twin did 3.0 cm
#: reds at seeds 38041–38043 (``sim_mujoco --random 9``) (:meth:`Config._jaws_pass_every_yaw`).
JAW_ROOM_CM = 0.5


#: Largest ``twin.kit.spread`` [-]: at 5 the slowest sourced unit's scale (8.1 µs/°, 1.9
#: below the nominal 10) is still positive.
MAX_KIT_SPREAD = 5.0


class ServoKitConfig(Strict):
    """A kit of servos: each twin servo a unit drawn from the spread of real ones.

    The per-unit errors (zero offset, scale, backlash, dead band) and the sources of their
    ranges are in :mod:`mearm.sim.twin.servo_kit`. Unset (``twin.kit: null``), every servo
    is the datasheet's nominal one.
    """

    seed: Seed = 0
    """Seed of the draw: the same seed gives the same kit."""
    per_trial: bool = False
    """``true``: every trial of ``mearm experiment`` draws its own kit (its seed mixed with the
    trial's seed); ``false``: every trial keeps the kit of ``seed`` (one arm, as on a real
    rig)."""
    spread: float = Field(default=1.0, ge=0.0, le=MAX_KIT_SPREAD, allow_inf_nan=False)
    """Factor on the calibration errors (zero offset and scale deviation) of the sourced
    ranges: 1 draws them as published, 0 gives nominal calibrations (backlash and dead band
    are drawn from their ranges regardless)."""


#: The physical twin's physics time step [s] (:mod:`mearm.sim.twin.mjcf`): each command
#: runs the physics for its period in whole steps.
TWIN_TIMESTEP_S = 0.002


class TwinConfig(Strict):
    """The servo models the physical twin gives the arm (:mod:`mearm.config.servo_models`).

    Each name is a catalogue model whose datasheet facts (mass, stall torque, speed, dead
    band, size) and their source the catalogue holds.
    """

    joint_servo: str | None = None
    """Every actuated joint's servo; ``null``: the lightest catalogue servo that holds 3×
    the arm's worst gravity load."""
    gripper_servo: str = "SG90"
    """The gripper's servo."""
    camera: TwinCameraConfig | None = None
    """The twin's camera as a real perspective camera (pose, field of view, lens
    distortion: :class:`~mearm.config.twin_camera_config.TwinCameraConfig`); ``null``: straight
    down from 52 cm over the calibrated field, so that ``calibration.homography`` holds."""
    lamp: TwinLampConfig | None = None
    """A lamp lighting the table (where it stands, its cone and falloff, shadows, glossy
    objects: :class:`~mearm.config.twin_lamp_config.TwinLampConfig`); ``null``: an even
    light straight down and the sorter's frames drawn without shadows (the fast path)."""
    kit: ServoKitConfig | None = None
    """Draw each servo from a kit of real units (:class:`ServoKitConfig`, e.g.
    ``{seed: 7, per_trial: true}``); ``null``: every servo is the datasheet's nominal one."""
    friction_cone: Literal["pyramidal", "elliptic"] = "pyramidal"
    """MuJoCo's friction cone for every contact. ``pyramidal``: its faster approximation,
    under which an object the jaws hold by slanted faces (a triangular prism, a cube across
    its corners) creeps out of them on the way to its bin; ``elliptic``: the Coulomb cone
    itself, which holds such grips, at some 15–40 % more CPU a twin sort (docs/twin.md,
    "Friction cones")."""
    # copied for each model (why a default: SimErrorModel.offset_deg)
    faults: list[TwinFault] = Field(default=[], max_length=16)
    """Faults injected into the run, each at a simulated time
    (:mod:`mearm.config.twin_faults_config`: ``limp_servo``, ``knock_object``,
    ``camera_black``, ``camera_frozen``, ``camera_bump``); empty: nothing breaks."""

    @field_validator("joint_servo", "gripper_servo")
    @classmethod
    def _known(cls, name: str | None) -> str | None:
        if name is not None and name not in SERVO_NAMES:
            raise ValueError(f"no servo model {name!r}; known: {', '.join(SERVO_NAMES)}")
        return name


class Config(Strict):
    """The whole configuration. Its defaults are the simulated rig with the paper's arm."""

    arm: ArmDescription = Field(default_factory=paper_arm)
    """The arm: written out, or a reference arm by name and what differs on this one
    (``use: mearm_v1``: "Building on a config, naming an arm", above)."""
    camera: CameraConfig = CameraConfig()
    calibration: CalibrationConfig = CalibrationConfig()
    vision: VisionConfig = VisionConfig()
    controller: ControllerConfig = ControllerConfig()
    servo: ServoConfig = ServoConfig()
    task: TaskConfig = TaskConfig()
    twin: TwinConfig = TwinConfig()
    """The physical twin's servo models (used when ``simulator`` is ``mujoco``)."""
    belt: BeltConfig | None = None
    """A conveyor belt that brings objects past the arm (:mod:`mearm.config.belt_config`);
    ``null``: none, the objects lie where ``task.scene`` puts them."""
    simulator: Literal["kinematic", "mujoco"] = "kinematic"
    """What simulates the rig when ``servo.backend`` and ``camera.kind`` are ``sim``:
    ``kinematic`` (a grasp succeeds within ``servo.grip_tolerance_cm``; drawn camera) or
    ``mujoco`` (the physical twin: servos, contacts and friction decide; rendered camera)."""

    @property
    def simulated_table(self) -> bool:
        """Whether the camera or the servos are simulated, so a table of objects is laid out."""
        return self.camera.kind == "sim" or self.servo.backend == "sim"

    def with_scene(self, scene: Sequence[SceneObject]) -> Config:
        """This config with ``task.scene`` replaced: the table a sort lays out instead.

        Everything built from the config then sees that table: the twin's bin walls, grown
        to hold its objects stacked, and the planner's model of them alike.
        """
        return self.model_copy(update={"task": self.task.model_copy(update={"scene": list(scene)})})

    @model_validator(mode="after")
    def _twin_simulates_both(self) -> Config:
        if self.simulator == "mujoco" and (
            self.servo.backend != "sim" or self.camera.kind != "sim"
        ):
            raise ValueError(
                "@simulator: 'mujoco' simulates the servos and the camera together: it needs "
                f"servo.backend: sim and camera.kind: sim (got {self.servo.backend!r}, "
                f"{self.camera.kind!r})"
            )
        return self

    @model_validator(mode="after")
    def _twin_steps_every_command(self) -> Config:
        """The physical twin runs each command's period in whole physics steps: at least one.

        A period under a step rounds to none at 1000 Hz (half a 2 ms step): the physics
        never ran, the arm stayed at home, and the sort stopped at its first route on a
        joint that "did not arrive within 2.00 s".
        """
        most_hz = 1.0 / TWIN_TIMESTEP_S
        if self.simulator == "mujoco" and self.servo.rate_hz > most_hz:
            raise ValueError(
                f"@servo.rate_hz: {self.servo.rate_hz:g} Hz is more often than the physical "
                f"twin (simulator: mujoco) steps its physics, every {TWIN_TIMESTEP_S * 1e3:g} "
                f"ms: at most {most_hz:g} Hz"
            )
        return self

    @model_validator(mode="after")
    def _jaws_pass_every_yaw(self) -> Config:
        """The open jaws must come down around every object, a cube or a prism at any yaw.

        A cylinder's diameter must pass between them, with :data:`JAW_ROOM_CM` to spare
        each side: the arm lands them off by its own error and the camera's, and in the
        twin a jaw came down on the rim of objects that left less (a 3.96 cm disc in the
        paper arm's 4 cm jaws was carried, jammed, to another class's bin with the place
        said released, ``sim_mujoco_lamp --random 8 --seed 35082``; a 2.44 cm disc in the
        MeArm v1's 3 cm stalled its shoulder, ``sim_mearm_v1_mujoco --random 5 --seed
        35028``, as 2.3 and 2.2 cm ones did; simulated). Only an arm with a wrist roll turns
        its jaws to a cube's faces (:meth:`mearm.task.plan.Planner.turn_jaws`), and a turn
        past its limits or into something is refused; otherwise the jaws close along a
        direction fixed to the wrist and a cube may lie across them at 45°: its diagonal
        must pass between them on every arm. Closing then turns it onto its faces (the
        twin shows it).
        """
        g = self.arm.tool.gripper
        room = JAW_ROOM_CM
        for c in self.task.classes:
            shape = c.object_shape
            widest = shape.widest_cm(c.diameter_cm)
            if widest + 2.0 * room <= g.open_cm:
                continue
            disc = shape.footprint == "disc"
            across = {"disc": "across", "square": "across its diagonal"}.get(
                shape.footprint, "across a side"
            )
            yaw = "" if disc else " at any yaw (they turn to its faces only where a wrist roll can)"
            said = f"@task.classes.{c.name}.diameter_cm: a {c.diameter_cm:g} cm {shape.name} is "
            if widest >= g.open_cm:
                raise ValueError(
                    f"{said}{widest:.3g} cm {across}, not less than the open jaws' "
                    f"{g.open_cm:g} cm (arm.tool.gripper.open_cm): the open jaws must pass "
                    f"it{yaw}; use smaller objects or a wider-opening gripper"
                )
            raise ValueError(
                f"{said}{widest:.3g} cm {across}, which leaves the open jaws' {g.open_cm:g} "
                f"cm (arm.tool.gripper.open_cm) {(g.open_cm - widest) / 2:.2g} cm each side, "
                f"less than {room:g} cm: the open jaws must pass it{yaw} with that to spare, "
                "as the arm and the camera land them off by their errors; use objects at "
                f"most {g.open_cm - 2.0 * room:.3g} cm {across} or a wider-opening gripper"
            )
        return self

    @model_validator(mode="after")
    def _approach_in_box(self) -> Config:
        """Every pick's point above the object (``task.approach_height_cm``) lies in the box.

        The sort plans each pick via that point and refuses a target outside
        ``arm.target_box``; found here, it is one line at load, not every object left. A
        pick height itself outside the box is left to the consistency check
        (:mod:`mearm.task.check`), which names the pick's own fields.
        """
        height = self.task.approach_height_cm
        if height is None:
            return self
        box = self.arm.target_box.z_cm
        tcp_cm = self.arm.tool.tcp_above_grip_cm
        above: dict[float, list[str]] = {}  # pick height → the classes picked there
        for c in self.task.classes:
            z = c.grip_z_cm + tcp_cm
            if box.contains(z) and not box.contains(z + height):
                above.setdefault(z, []).append(c.name)
        if not above:
            return self
        top = max(above)
        most = math.floor((box.max - top) * 100) / 100  # shown to 0.01 cm, never too high
        raise ValueError(
            f"@task.approach_height_cm: {height:g} cm above the picks of "
            f"{', '.join(above[top])} (at z = {top:.2f} cm) puts the TCP at z = "
            f"{top + height:.2f} cm, above arm.target_box.z_cm [{box.min:g}, {box.max:g}]: at "
            f"most {most:.2f} cm (pick height = grip height + "
            "arm.tool.tcp_above_grip_cm)"
        )

    @model_validator(mode="after")
    def _bins_below_release(self) -> Config:
        """A bin given its height must stand below where the arm releases its objects.

        Released at ``bin_cm`` z, an object's bottom is ``bin_cm`` z less
        ``arm.tool.tcp_above_grip_cm`` and its grip height above the table; walls above
        that would meet it on the way in, on a real rig as in the twin. (Walls grown for
        the objects they hold are checked with the table: :func:`mearm.task.check_scene`.)
        """
        tcp_cm = self.arm.tool.tcp_above_grip_cm
        for c in self.task.classes:
            if c.bin_height_cm is None:
                continue
            bottom = c.bin_cm[2] - tcp_cm - c.grip_z_cm
            if bottom < c.bin_height_cm:
                most = math.floor(bottom * 100) / 100  # shown to 0.01 cm, never too high
                fix = f"at most {most:g} cm, or raise bin_cm z" if most > 0 else "raise bin_cm z"
                raise ValueError(
                    f"@task.classes.{c.name}.bin_height_cm: {c.bin_height_cm:g} cm walls reach "
                    f"above the bottom of an object released at bin_cm z = {c.bin_cm[2]:g} cm "
                    f"({bottom:.3g} cm above the table): {fix}"
                )
        return self

    @model_validator(mode="after")
    def _belt_clear_of_base(self) -> Config:
        """The belt must pass beside the arm's base plate, not over it.

        Checked before the speed bound (:meth:`_belt_followable`, run after this one): a
        belt whose middle line passes near the base axis leaves the arm no speed to follow
        it, and that bound (``at most 0 cm/s``) would not say what is wrong.
        """
        belt = self.belt
        if belt is None:
            return self
        base_cm = base_radius_m(self.arm) * 100.0  # the plate every model draws [cm]
        least = base_cm + belt.width_cm / 2
        if belt.nearest_cm() < least:
            raise ValueError(
                f"@belt.start_cm: the belt crosses the arm's base: its middle line passes "
                f"{belt.nearest_cm():.3g} cm from the base axis, and with its "
                f"{belt.width_cm:g} cm width it covers the base plate ({base_cm:.3g} cm "
                f"radius); the middle line must pass at least {least:.3g} cm from the base "
                "axis: move it (belt.start_cm, belt.heading_deg)"
            )
        return self

    @model_validator(mode="after")
    def _belt_followable(self) -> Config:
        """The arm must keep up with what the belt carries (:func:`follow_limit_cm_s`)."""
        belt = self.belt
        if belt is None:
            return self
        first = self.arm.actuated_joints()[0]
        sweep_deg_s = first.servo.max_speed() if first.type == "revolute" and first.servo else 0.0
        limit = follow_limit_cm_s(sweep_deg_s, belt)
        if belt.speed_cm_s > limit:
            raise ValueError(
                f"@belt.speed_cm_s: {belt.speed_cm_s:g} cm/s is faster than the arm can follow: "
                f"at most {limit:.3g} cm/s ({FOLLOW_SHARE:g} x the TCP's sweep by its first "
                f"joint, {first.name}, at {sweep_deg_s:.3g} deg/s, {belt.nearest_cm():.3g} cm "
                "from the base axis); slow the belt or move it further out"
            )
        return self

    @model_validator(mode="after")
    def _arrivals_on_belt(self) -> Config:
        """Every object the belt brings lands wholly on it (:func:`overhang_cm`).

        The offset is the belt's (``belt.arrivals.lateral_cm``), the objects' sizes are
        the classes' (``task.classes``): only the whole config sees both.
        """
        belt = self.belt
        if belt is None:
            return self
        over, largest = overhang_cm(belt, self.task.classes)
        if over <= 0:
            return self
        lateral, radius = belt.arrivals.lateral_cm, largest.footprint_radius_cm
        half = belt.width_cm / 2
        most = math.floor((half - radius) * 100) / 100  # shown to 0.01 cm, never too much
        allowed = (
            f"at most {most:g} cm"
            if most >= 0
            else f"none: its {largest.name} objects ({2 * radius:.4g} cm across) are wider "
            "than the belt"
        )
        raise ValueError(
            f"@belt.arrivals.lateral_cm: {lateral:g} cm would land objects off the belt: "
            f"that offset plus the footprint radius of the largest object of task.classes "
            f"({largest.name}, {radius:.4g} cm) is {lateral + radius:.4g} cm, beyond half "
            f"the belt's width (width_cm {belt.width_cm:g} cm), {half:g} cm: {allowed}"
        )

    @model_validator(mode="after")
    def _belt_holds_an_object(self) -> Config:
        """The belt is at least as long as its largest object is across.

        An object lands its footprint's radius down from the belt's upstream end: on a
        belt shorter than it, past the end, on the table (``belt.length_cm`` 0.5 put
        every object there, reported "never seen").
        """
        belt = self.belt
        if belt is None or not self.task.classes:
            return self
        largest = max(self.task.classes, key=lambda c: c.footprint_radius_cm)
        across = 2 * largest.footprint_radius_cm
        if belt.length_cm < across:
            raise ValueError(
                f"@belt.length_cm: {belt.length_cm:g} cm is shorter than the largest object "
                f"of task.classes ({largest.name}, {across:.4g} cm across), which would land "
                f"past the belt's end: at least {math.ceil(across * 100) / 100:g} cm"
            )
        return self

    @model_validator(mode="after")
    def _arrivals_apart(self) -> Config:
        """No object the belt brings lands on one it brought before (:func:`arrival_draws`).

        Each lands its footprint's radius down from the upstream end, at its drawn offset
        across; one brought earlier has ridden ``speed_cm_s`` times the gap on since, if
        nothing picked it. Closer than their footprints' radii, the two would lie on one
        another: on a still belt (``speed_cm_s`` 0) a second arrival landed on the first,
        the camera saw one region, and a sort waited for ever on what it left.
        """
        belt = self.belt
        if belt is None or belt.arrivals.count < 2 or not self.task.classes:
            return self
        radius = {c.name: c.footprint_radius_cm for c in self.task.classes}
        reach = 4 * max(radius.values())  # past this, an earlier arrival is clear of it
        v = belt.speed_cm_s
        draws = arrival_draws(belt, self.task.classes)
        for i, (name, t, across, _) in enumerate(draws):
            for j in range(i - 1, -1, -1):
                other, t_j, across_j, _ = draws[j]
                ridden = v * (t - t_j)
                if ridden > reach:
                    break
                along = radius[other] + ridden - radius[name]
                need = radius[name] + radius[other]
                if math.hypot(along, across - across_j) < need - 1e-9:
                    gap = belt.arrivals.min_gap_s
                    return self._landed_on(i, j, name, other, t, t_j, ridden, need, gap)
        return self

    def _landed_on(
        self, i: int, j: int, name: str, other: str, t: float, t_j: float, ridden: float,
        need: float, gap: float,
    ) -> Config:  # fmt: skip
        """The refusal of :meth:`_arrivals_apart`: arrival ``i`` lands on arrival ``j``."""
        assert self.belt is not None
        v = self.belt.speed_cm_s
        if v > 0:
            # an arrival lands its radius down the belt, one before it has ridden v * gap on
            # from its own: clear of each other at any offset once v * gap is the widest across
            widest = 2 * max(c.footprint_radius_cm for c in self.task.classes)
            least = math.ceil(widest / v * 100) / 100
            # the gaps are drawn in [min_gap_s, max_gap_s]: a min_gap_s past max_gap_s is
            # refused in turn (a 0.5 cm/s belt with gaps of 3.33-3.54 s was told "at least
            # 5.34 s", and then "max_gap_s: 3.54 s is below min_gap_s")
            top = self.belt.arrivals.max_gap_s
            both = f" (and max_gap_s, now {top:g} s, at least as much)" if least > top else ""
            fix = (
                f"belt.arrivals.min_gap_s at least {least:g} s{both}, a faster belt "
                "(belt.speed_cm_s), or another belt.arrivals.seed"
            )
        else:
            fix = (
                "a still belt lands them on one spot: run it (belt.speed_cm_s), or bring one "
                "object (belt.arrivals.count 1)"
            )
        raise ValueError(
            f"@belt.arrivals: arrival {i + 1} ({name}, at {t:.3g} s) lands on arrival {j + 1} "
            f"({other}, at {t_j:.3g} s), which the belt at {v:g} cm/s has carried {ridden:.3g} "
            f"cm on since: their footprints need {need:.3g} cm between centres (min_gap_s "
            f"{gap:g} s): {fix}"
        )

    @model_validator(mode="after")
    def _belt_or_table(self) -> Config:
        """A belt's sort picks only what the belt brings: objects on the table stay there."""
        if self.belt is not None and self.task.scene:
            raise ValueError(
                f"@task.scene: {len(self.task.scene)} object(s) on the table, but a config "
                "with a belt sorts only what the belt brings (belt.arrivals): set task.scene: []"
            )
        return self

    @model_validator(mode="after")
    def _names_known(self) -> Config:
        actuated = [j.name for j in self.arm.actuated_joints()]
        for name in self.servo.error_model.offset_deg:
            if name not in actuated:
                raise ValueError(
                    f"@servo.error_model.offset_deg.{name}: not an actuated joint "
                    f"(actuated: {', '.join(actuated)})"
                )
        for i, fault in enumerate(self.twin.faults):
            if fault.kind == "limp_servo" and fault.joint not in actuated:
                raise ValueError(
                    f"@twin.faults.{i}.joint: {fault.joint!r} is not an actuated joint "
                    f"(actuated: {', '.join(actuated)})"
                )
        return self

    @model_validator(mode="after")
    def _calibration_fits_frame_size(self, info: ValidationInfo) -> Config:
        """The camera's frames must be the size the homography was fitted at.

        A homography maps pixels of one frame size: at another, every pixel lands on the
        wrong table point (a camera switched from 640 × 480 to 1280 × 960 sees each object
        twice as far out). Not checked when the size is unknown
        (``calibration.image_size_px: null``). The refusal's recalibration names the
        config the user gave, when the loader says it (:data:`CONFIG_GIVEN`).
        """
        fitted = self.calibration.image_size_px
        frame = (self.camera.width_px, self.camera.height_px)
        if fitted is None or tuple(fitted) == frame:
            return self
        key = "width_px" if fitted[0] != frame[0] else "height_px"
        raise ValueError(
            f"@camera.{key}: the camera gives {frame[0]}x{frame[1]} px frames "
            f"(camera.width_px, camera.height_px) but calibration.homography was fitted to "
            f"{fitted[0]}x{fitted[1]} px ones (calibration.image_size_px), and at another "
            f"size it maps every pixel to the wrong table point: {_recalibrate(info)}, or "
            f"set camera.width_px={fitted[0]} and camera.height_px={fitted[1]} back"
        )

    @model_validator(mode="after")
    def _calibration_covers_frame(self) -> Config:
        """Every pixel of the frame must map to a point on the table.

        The map w·(x, y, 1) = H·(u, v, 1) has a horizon where w = 0; it must lie outside
        the frame, and the frame's corners must land within ±MAX_LENGTH_CM.
        """
        H = self.calibration.homography
        w_px, h_px = self.camera.width_px, self.camera.height_px
        corners = ((0, 0), (w_px, 0), (w_px, h_px), (0, h_px))
        ws = [H[2][0] * u + H[2][1] * v + H[2][2] for u, v in corners]
        size = f"{w_px}x{h_px} px frame (camera.width_px, camera.height_px)"
        if not (all(w > 0 for w in ws) or all(w < 0 for w in ws)) or min(map(abs, ws)) < (
            MIN_W_RATIO * max(map(abs, ws))
        ):
            raise ValueError(
                f"@calibration.homography: its horizon (w = 0) crosses or nears the {size}: "
                "the third row must keep h31·u + h32·v + h33 of one sign (within 20:1) over "
                "the frame; recalibrate with tools/calibrate_camera.py"
            )
        for (u, v), w in zip(corners, ws, strict=True):
            x = (H[0][0] * u + H[0][1] * v + H[0][2]) / w
            y = (H[1][0] * u + H[1][1] * v + H[1][2]) / w
            if not (abs(x) <= MAX_LENGTH_CM and abs(y) <= MAX_LENGTH_CM):
                raise ValueError(
                    f"@calibration.homography: the corner ({u}, {v}) px of the {size} maps "
                    f"to ({x:.4g}, {y:.4g}) cm, beyond ±{MAX_LENGTH_CM:g} cm: recalibrate"
                )
        return self
