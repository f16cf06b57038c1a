"""Typed configuration: one pydantic model tree, loaded from YAML.

The defaults of :class:`Config` *are* the simulated rig (``configs/sim.yaml`` writes them
out with comments); ``configs/lab.yaml`` is the paper's real rig. Every number's source in
the paper is given in the YAML files and in ``../shared/SPEC.md`` (cited as SPEC §n).

Loading is strict: unknown keys are rejected and each bad field is reported with its
dotted path, the value given and what is allowed (:class:`~mearm.exceptions.ConfigError`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import yaml
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from mearm.exceptions import ConfigError

if TYPE_CHECKING:
    from pydantic_core import ErrorDetails

Color = Literal["red", "green", "blue"]
COLORS: tuple[Color, ...] = ("red", "green", "blue")
JOINT_NAMES: tuple[str, ...] = ("joint1", "joint2", "joint3", "joint4")
ACTUATED_JOINTS: tuple[str, ...] = ("joint1", "joint2", "joint3")

Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --------------------------------------------------------------------------- robot


class DHRow(_Strict):
    """One standard Denavit–Hartenberg row, T = Rz(θ)·Tz(d)·Tx(a)·Rx(α) (SPEC §2, eq. 1)."""

    a_cm: Finite
    alpha_deg: Finite
    d_cm: Finite


class Range(_Strict):
    """A closed interval [min, max] with min < max."""

    min: Finite
    max: Finite

    @model_validator(mode="after")
    def _ordered(self) -> Range:
        if not self.min < self.max:
            raise ValueError(f"min ({self.min:g}) must be below max ({self.max:g})")
        return self

    def contains(self, value: float, tol: float = 0.0) -> bool:
        """Whether ``min - tol <= value <= max + tol``."""
        return self.min - tol <= value <= self.max + tol


class JointLimits(_Strict):
    """Limits of the three actuated joints [deg] (SPEC §3, Table 4 as the project reads it).

    Joint 4 has no servo: θ4 = −(θ2+θ3), so its limits follow from these.
    """

    joint1: Range = Range(min=20, max=160)
    joint2: Range = Range(min=30, max=135)
    joint3: Range = Range(min=-160, max=-20)

    def as_list(self) -> list[Range]:
        """Limits of joints 1–4 in order; joint 4's is derived from the coupling."""
        j2, j3 = self.joint2, self.joint3
        j4 = Range(min=-(j2.max + j3.max), max=-(j2.min + j3.min))
        return [self.joint1, j2, j3, j4]


class TargetBox(_Strict):
    """The end-effector target box in the base frame [cm] (SPEC §3, Table 3)."""

    x_cm: Range = Range(min=-40, max=40)
    y_cm: Range = Range(min=20, max=60)
    z_cm: Range = Range(min=10, max=60)


class GripperConfig(_Strict):
    """The gripper arm (joint 5, servo 4) and the gripper (SPEC §2, §4)."""

    a4_cm: Positive = 9.0
    a5_cm: Positive = 10.0
    travel_angle_deg: Finite = 30.0
    grip_angle_deg: Finite = -60.0
    home_angle_deg: Finite = 60.0
    pick_height_cm: Finite = 12.76
    """EE target height for a pick: 1.5 + |13·sin(−60°)| (the paper uses a5 = 13 here)."""
    gripper_arm_limits_deg: Range = Range(min=-90, max=90)


class RobotConfig(_Strict):
    """Arm geometry, limits and poses."""

    dh: list[DHRow] = Field(
        default_factory=lambda: [
            DHRow(a_cm=3.0, alpha_deg=90.0, d_cm=17.5),
            DHRow(a_cm=22.3, alpha_deg=0.0, d_cm=0.0),
            DHRow(a_cm=31.5, alpha_deg=0.0, d_cm=0.0),
            DHRow(a_cm=14.0, alpha_deg=0.0, d_cm=0.0),
        ],
        min_length=4,
        max_length=4,
    )
    joint_limits_deg: JointLimits = JointLimits()
    home_deg: tuple[Finite, Finite, Finite] = (120.0, 93.0, -132.0)
    target_box: TargetBox = TargetBox()
    gripper: GripperConfig = GripperConfig()

    @model_validator(mode="after")
    def _home_within_limits(self) -> RobotConfig:
        for name, value, rng in zip(
            ACTUATED_JOINTS, self.home_deg, self.joint_limits_deg.as_list(), strict=False
        ):
            if not rng.contains(value):
                raise ValueError(
                    f"home_deg: {name} = {value:g} is outside its limits [{rng.min:g}, {rng.max:g}]"
                )
        return self

    @property
    def home_joints_deg(self) -> tuple[float, float, float, float]:
        """Home pose (θ1, θ2, θ3, θ4) with θ4 from the coupling."""
        t1, t2, t3 = self.home_deg
        return (t1, t2, t3, -(t2 + t3))


# --------------------------------------------------------------------------- camera & vision


class CameraConfig(_Strict):
    """Where frames come from.

    ``device``: a USB camera through ``cv2.VideoCapture`` (``device_index``, or ``path``
    when set); ``file``/``folder``: saved frames replayed in order (``path``); ``sim``: the
    simulated table rendered from the world model (mearm.vision.camera).
    """

    kind: Literal["device", "file", "folder", "sim"] = "sim"
    device_index: int = Field(default=0, ge=0)
    path: str | None = None
    width_px: int = Field(default=640, gt=0)
    height_px: int = Field(default=480, gt=0)
    open_timeout_s: Positive = 5.0
    loop: bool = False
    # sim renderer (mearm.vision.render)
    noise_std: NonNegative = 2.0
    """Sensor noise, standard deviation in 8-bit levels."""
    brightness: Positive = 1.0
    """Overall light level, a factor on every pixel (1 = nominal)."""
    gradient: NonNegative = 0.15
    """Lighting gradient: ±this fraction of the light from one corner to the other."""
    table: Literal["wood", "grey"] = "wood"
    """Table surface the sim renders."""
    seed: int = 0
    """Seed of the texture and of the noise sequence (frame i uses seed + i)."""

    @model_validator(mode="after")
    def _path_for_replay(self) -> CameraConfig:
        if self.kind in ("file", "folder") and not self.path:
            raise ValueError(f"camera.kind '{self.kind}' needs camera.path")
        return self


class CalibrationConfig(_Strict):
    """Pixel → table homography, base frame, cm (SPEC §4).

    The default is the paper's measured rig: x = 0.0625·u − 20.5, y = 59.0 − 0.0625·v.
    """

    homography: tuple[
        tuple[Finite, Finite, Finite],
        tuple[Finite, Finite, Finite],
        tuple[Finite, Finite, Finite],
    ] = ((0.0625, 0.0, -20.5), (0.0, -0.0625, 59.0), (0.0, 0.0, 1.0))
    reprojection_error_cm: NonNegative | None = None

    @field_validator("homography")
    @classmethod
    def _invertible(cls, h: Any) -> Any:
        a, b, c = h
        det = (
            a[0] * (b[1] * c[2] - b[2] * c[1])
            - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
        )
        if abs(det) < 1e-12:
            raise ValueError("homography is singular (determinant 0): recalibrate")
        return h


class HueBand(_Strict):
    """A hue interval in degrees [0, 360); ``lo > hi`` wraps through 0 (red)."""

    lo_deg: Annotated[float, Field(ge=0, le=360)]
    hi_deg: Annotated[float, Field(ge=0, le=360)]


class VisionConfig(_Strict):
    """HSV colour segmentation (SPEC §4).

    ``preset`` chooses the bands and floors; any field set here overrides the preset's.
    """

    preset: Literal["default", "paper"] = "default"
    bands: dict[Color, list[HueBand]] | None = None
    saturation_min: Annotated[float, Field(ge=0, le=1)] | None = None
    value_min: Annotated[float, Field(ge=0, le=1)] | None = None
    median_kernel: int = Field(default=3, ge=1)
    min_area_px: int = Field(default=100, ge=1)
    object_diameter_cm: Positive = 2.0
    """Diameter of one object (SPEC §1); sets the expected area for the merged test."""
    merged_area_ratio: Annotated[float, Field(gt=1, allow_inf_nan=False)] = 1.6
    """A region larger than this times one object's expected area is flagged merged."""
    merged_elongation: Annotated[float, Field(gt=1, allow_inf_nan=False)] = 1.5
    """A region whose major/minor axis ratio exceeds this is flagged merged."""

    @field_validator("median_kernel")
    @classmethod
    def _odd(cls, k: int) -> int:
        if k % 2 == 0:
            raise ValueError(f"must be odd, got {k}")
        return k


# --------------------------------------------------------------------------- controller


class ControllerConfig(_Strict):
    """The IK solver: PD-PIJ (SPEC §3), or mink / the closed form as cross-checks.

    The gains must keep the linearised loop e_{t+1} = (1−kp−kd)·e_t + kd·e_{t−1} stable:
    kp > 0, 0 ≤ kd < 1 and kp + 2·kd < 2 (Jury's test on its characteristic polynomial).
    """

    solver: Literal["pdpij", "mink", "analytic"] = "pdpij"
    """Which solver :func:`mearm.ik.solve_ik` runs."""
    mode: Literal["paper", "coupled"] = "coupled"
    """paper: θ ∈ R⁴, 3×4 J, coupling re-imposed after each update; coupled: J·C."""
    kp: Positive = 0.1
    """Proportional gain [-]."""
    kd: NonNegative = 0.01
    """Derivative gain [-]."""
    tolerance_cm2: Positive = 1e-3
    """Stop when |e|² is below this [cm²] (SPEC §3, eq. 6)."""
    max_iterations: int = Field(default=1000, ge=1)
    """Give up (status ``max_iterations``) after this many updates."""
    singular_value_cutoff: Positive = 1e-6
    """Singular values at or below this times the largest are treated as zero in J⁺ [-]."""
    damping: NonNegative = 0.0
    """> 0 selects damped least squares, Jᵀ(J Jᵀ + λ² I)⁻¹, with this λ [cm/rad]."""
    safeguard: bool = True
    """Reject an update that would raise |e| and retry along the clamped exact step."""
    stall_iterations: int = Field(default=50, ge=1)
    """Status ``stalled`` when |e| fell by under a relative 1e-6 over this many updates."""
    qp_solver: str = "daqp"
    """qpsolvers backend of the mink cross-check."""

    @model_validator(mode="after")
    def _stable_gains(self) -> ControllerConfig:
        if self.kd >= 1:
            raise ValueError(f"kd = {self.kd:g} must be below 1 (the PD loop is unstable)")
        if self.kp + 2 * self.kd >= 2:
            raise ValueError(
                f"kp + 2·kd = {self.kp + 2 * self.kd:g} must be below 2 "
                "(the PD loop is unstable); the paper uses kp = 0.1, kd = 0.01"
            )
        return self

    def updated(self, **changes: Any) -> ControllerConfig:
        """A copy with ``changes`` applied and validated.

        Raises:
            ConfigError: a changed value is invalid; the message names it.
        """
        try:
            return ControllerConfig.model_validate({**self.model_dump(), **changes})
        except ValidationError as exc:
            problems = [_describe({**e, "loc": ("controller", *e["loc"])}) for e in exc.errors()]
            raise ConfigError(None, problems) from None


# --------------------------------------------------------------------------- servos


class ServoChannel(_Strict):
    r"""Mapping of one joint's DH angle to a servo pulse (hardware issue, SPEC §1).

    .. math:: p = p_0 + s \, k \, \theta

    with ``zero_us`` = p0 [µs], ``direction`` = s (±1), ``us_per_deg`` = k [µs/deg] and θ
    the DH angle [deg]. An angle whose pulse leaves [min_us, max_us] is refused, never
    clamped. The servo's own 0–180° scale (what ``Servo.write`` takes) spans
    [min_us, max_us], as after ``Servo.attach(pin, min_us, max_us)``.
    """

    channel: int = Field(ge=0, le=31)
    zero_us: Finite = 1500.0
    """Pulse at DH angle 0 [µs]; may lie outside [min_us, max_us]."""
    direction: Literal[1, -1] = 1
    us_per_deg: Positive = 10.0
    min_us: int = Field(default=600, ge=500, le=2500)
    """Lowest pulse this servo may get [µs] (the firmware and the SSC-32 allow 500–2500)."""
    max_us: int = Field(default=2400, ge=500, le=2500)
    """Highest pulse this servo may get [µs]."""

    @model_validator(mode="after")
    def _pulse_range(self) -> ServoChannel:
        if not self.min_us < self.max_us:
            raise ValueError(f"min_us ({self.min_us}) must be below max_us ({self.max_us})")
        return self


class GripperServo(_Strict):
    """The gripper's open/close servo (MG996R in the paper), driven by two fixed pulses."""

    channel: int = Field(default=4, ge=0, le=31)
    open_us: int = Field(default=1000, ge=500, le=2500)
    closed_us: int = Field(default=1900, ge=500, le=2500)


class SimErrorModel(_Strict):
    """How the simulated servos miss their commands (SPEC §5).

    ``quantization``: ``microsecond`` — the integer-µs pulse the serial backends send;
    ``degree`` — a whole degree of the servo's 0–180° scale, as ``Servo.write`` does (one
    step is (max_us − min_us)/180 µs, 1 DH degree with the default mapping); ``none``.
    The realised angle is the quantised one plus ``offset_deg`` (static, per joint) plus
    Gaussian noise of ``noise_std_deg`` drawn per move and joint.
    """

    quantization: Literal["none", "degree", "microsecond"] = "microsecond"
    offset_deg: tuple[Finite, Finite, Finite] = (0.0, 0.0, 0.0)
    noise_std_deg: NonNegative = 0.0
    seed: int = 0


class ServoConfig(_Strict):
    """The servo link (SPEC §1: an Arduino Uno over USB serial) and the simulated arm."""

    backend: Literal["sim", "serial", "ssc32"] = "sim"
    port: str = "/dev/ttyACM0"
    """Serial device, or a pyserial URL (``socket://host:port``, ``rfc2217://…``)."""
    baud: int = Field(default=115200, gt=0)
    rate_hz: Positive = 50.0
    """Commands per second at most (the servo frame rate); lower if the baud rate demands."""
    ack_timeout_s: Positive = 0.5
    banner_timeout_s: Positive = 3.0
    retries: int = Field(default=3, ge=0)
    """Resends of a command that failed its checksum, after the first try."""
    joints: dict[str, ServoChannel] = Field(
        default_factory=lambda: {
            "joint1": ServoChannel(channel=0, zero_us=600.0),
            "joint2": ServoChannel(channel=1, zero_us=600.0),
            "joint3": ServoChannel(channel=2, zero_us=2400.0),
            "joint5": ServoChannel(channel=3, zero_us=1500.0),
        }
    )
    gripper: GripperServo = GripperServo()
    grip_tolerance_cm: Positive = 1.2
    """Sim: a pick succeeds if the EE is this close to the object in the plane and to
    the pick height in z (SPEC §5: picks under 1.2 cm error always succeeded)."""
    bin_radius_cm: Positive = 4.0
    """Sim: an object released within this distance (in the plane) of a bin falls into
    it; farther away it drops onto the table under the EE."""
    sim_realtime: bool = False
    """Sim: pace moves at ``rate_hz`` like the real link (default: as fast as it can)."""
    error_model: SimErrorModel = SimErrorModel()

    @field_validator("joints")
    @classmethod
    def _joint_names(cls, joints: dict[str, ServoChannel]) -> dict[str, ServoChannel]:
        expected = {"joint1", "joint2", "joint3", "joint5"}
        if set(joints) != expected:
            missing = sorted(expected - set(joints))
            extra = sorted(set(joints) - expected)
            raise ValueError(
                f"needs exactly {sorted(expected)}; missing {missing}, unknown {extra}"
            )
        return joints

    @model_validator(mode="after")
    def _distinct_channels(self) -> ServoConfig:
        used: dict[int, str] = {}
        owners = [(n, c.channel) for n, c in sorted(self.joints.items())]
        for name, channel in [*owners, ("gripper", self.gripper.channel)]:
            if channel in used:
                raise ValueError(f"{name} and {used[channel]} share servo channel {channel}")
            used[channel] = name
        return self


# --------------------------------------------------------------------------- task


class SceneObject(_Strict):
    """One object on the (simulated) table, base frame [cm]."""

    color: Color
    x: Finite
    y: Finite


def _paper_layout() -> list[SceneObject]:
    # SPEC §4, the paper's demo layout (M = red, H = green, B = blue).
    rows: list[tuple[Color, float, float]] = [
        ("red", -10.99, 49.70), ("red", -0.75, 53.72), ("red", -0.40, 42.01),
        ("red", 8.08, 46.71), ("green", -8.31, 53.81), ("green", -4.57, 47.58),
        ("green", 5.15, 53.38), ("green", 11.74, 42.88), ("blue", -10.08, 44.03),
        ("blue", 2.03, 48.57), ("blue", 6.93, 41.11), ("blue", 12.15, 51.86),
    ]  # fmt: skip
    return [SceneObject(color=c, x=x, y=y) for c, x, y in rows]


def _default_bins() -> dict[Color, tuple[float, float, float]]:
    return {
        "red": (-20.0, 35.0, 20.0),
        "green": (-20.0, 45.0, 20.0),
        "blue": (-20.0, 55.0, 20.0),
    }


class TaskConfig(_Strict):
    """The sorting task (SPEC §1, Table 2)."""

    color_order: list[Color] = Field(default_factory=lambda: list(COLORS), min_length=1)
    bins_cm: dict[Color, tuple[Finite, Finite, Finite]] = Field(default_factory=_default_bins)
    pick_retries: int = Field(default=2, ge=0)
    scene: list[SceneObject] = Field(default_factory=_paper_layout)

    @field_validator("color_order")
    @classmethod
    def _unique(cls, order: list[Color]) -> list[Color]:
        if len(set(order)) != len(order):
            raise ValueError(f"colours repeat in {order}")
        return order


# --------------------------------------------------------------------------- root


class Config(_Strict):
    """The whole configuration. Its defaults are the simulated rig."""

    robot: RobotConfig = RobotConfig()
    camera: CameraConfig = CameraConfig()
    calibration: CalibrationConfig = CalibrationConfig()
    vision: VisionConfig = VisionConfig()
    controller: ControllerConfig = ControllerConfig()
    servo: ServoConfig = ServoConfig()
    task: TaskConfig = TaskConfig()

    @model_validator(mode="after")
    def _bins_for_colors(self) -> Config:
        missing = [c for c in self.task.color_order if c not in self.task.bins_cm]
        if missing:
            raise ValueError(f"task.bins_cm has no bin for {missing}")
        return self


def _describe(err: ErrorDetails) -> str:
    loc = ".".join(str(p) for p in err["loc"]) or "(top level)"
    kind = err["type"]
    if kind == "extra_forbidden":
        return f"{loc}: unknown key (check the spelling; see configs/sim.yaml for every key)"
    if kind == "missing":
        return f"{loc}: required but missing"
    msg = err["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    value = err.get("input")
    shown = "" if isinstance(value, dict) else f" (got {value!r})"
    return f"{loc}: {msg}{shown}"


def config_from_dict(data: Any, *, source: str | None = None) -> Config:
    """Validate a mapping into a :class:`Config`.

    Raises:
        ConfigError: one line per bad field.
    """
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError(source, [f"top level must be a mapping, got {type(data).__name__}"])
    try:
        return Config.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(source, [_describe(e) for e in exc.errors()]) from None


def load_config(path: str | Path | None = None) -> Config:
    """Read a YAML config file; ``None`` gives the embedded default (the simulated rig).

    Raises:
        ConfigError: the file is missing, unreadable, not YAML, or has bad fields.
    """
    if path is None:
        return Config()
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(str(p), ["file not found"]) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(str(p), [f"cannot read: {exc}"]) from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(str(p), [f"malformed YAML at {where}{problem}"]) from None
    return config_from_dict(data, source=str(p))
