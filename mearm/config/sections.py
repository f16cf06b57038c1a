"""The rig around the arm: camera, calibration, vision, controller, servo link, task."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    Field,
    ValidationError,
    ValidatorFunctionWrapHandler,
    field_serializer,
    field_validator,
    model_validator,
)

from mearm.config.base import (
    MAX_ANGLE_DEG,
    MAX_LENGTH_CM,
    RULES,
    SPELLINGS,
    Angle,
    Length,
    Name,
    NonNegativeLength,
    PathText,
    Seed,
    Strict,
    describe_error,
)
from mearm.config.classes import ColorClass, class_named, hues_shared
from mearm.config.defaults import PAPER_LAYOUT, default_classes
from mearm.config.errors import SerialPortError
from mearm.config.polygon import why_flat
from mearm.config.port import check_port
from mearm.errors import ConfigError

#: Largest camera frame side [px].
MAX_FRAME_SIDE_PX = 4096
#: Largest camera frame [px]: 4K UHD (3840×2160), the largest USB camera frame. The
#: simulated camera needs ~80 bytes a pixel, 0.7 GB at this size.
MAX_FRAME_PIXELS = 3840 * 2160
#: Smallest camera frame side [px].
MIN_FRAME_SIDE_PX = 16
#: The paper's frame [width, height] px (a Logitech C310 at 640 × 480), which the built-in
#: homography was fitted to.
PAPER_FRAME_PX = (640, 480)
#: OpenCV reads a device number from 100 up as a capture backend plus an index.
MAX_DEVICE_INDEX = 99
#: Largest wait for a device or a board [s].
MAX_TIMEOUT_S = 600.0
#: Largest median filter [px] (OpenCV's 8-bit median takes at most 31 … and a 31 px median
#: already wipes out a 2 cm object at the paper's 16 px/cm).
MAX_MEDIAN_KERNEL = 31
#: Largest homography entry (pixels → cm; the paper's are ≤ 59).
MAX_HOMOGRAPHY_ENTRY = 1e6
#: Most IK iterations per target (PD-PIJ needs ~100 on the paper's arm).
MAX_ITERATIONS = 100_000
#: Servo command rate [Hz]: one command per 10 s to 1 kHz (servos take 50–330 Hz).
RATE_HZ = (0.1, 1000.0)
#: Serial baud rates [Bd].
BAUD = (300, 4_000_000)
#: Most retries of anything.
MAX_RETRIES = 100
#: Most tries of one pick after the first (each is a full approach and grip).
MAX_PICK_RETRIES = 10
#: Most colour classes and most objects on the table.
MAX_CLASSES = 32
MAX_SCENE_OBJECTS = 500

HomographyEntry = Annotated[
    float, Field(ge=-MAX_HOMOGRAPHY_ENTRY, le=MAX_HOMOGRAPHY_ENTRY, allow_inf_nan=False)
]
Seconds = Annotated[float, Field(gt=0, le=MAX_TIMEOUT_S, allow_inf_nan=False)]


class CameraConfig(Strict):
    """Where frames come from.

    ``device``: a USB camera through ``cv2.VideoCapture`` (``device_index``, or ``path``
    when set); ``file``/``folder``: saved frames replayed in order (``path``); ``sim``: the
    simulated table rendered from the world model (mearm.vision.camera).
    """

    kind: Literal["device", "file", "folder", "sim"] = "sim"
    device_index: int = Field(default=0, ge=0, le=MAX_DEVICE_INDEX)
    path: PathText | None = None
    """``file``/``folder``: the video or image, or the folder of images, replayed (a
    relative path: to the config file's folder; given by ``--set``, to the current
    folder); ``device``: a device path opened instead of ``device_index``, as given."""
    width_px: int = Field(default=640, ge=MIN_FRAME_SIDE_PX, le=MAX_FRAME_SIDE_PX)
    height_px: int = Field(default=480, ge=MIN_FRAME_SIDE_PX, le=MAX_FRAME_SIDE_PX)
    open_timeout_s: Seconds = 5.0
    loop: bool = False
    latency_s: float = Field(default=0.0, ge=0, le=2.0, allow_inf_nan=False)
    """How long before a frame is read the scene was as the frame shows it [s]: exposure,
    readout, USB transfer and driver queue. What moves is tracked at the time it was seen
    (:mod:`mearm.vision.tracking`); measure it as docs/vision.md says."""
    # sim renderer (mearm.vision.render)
    noise_std: float = Field(default=2.0, ge=0, le=255, allow_inf_nan=False)
    """Sensor noise, standard deviation in 8-bit levels."""
    brightness: float = Field(default=1.0, gt=0, le=10, allow_inf_nan=False)
    """Overall light level, a factor on every pixel (1 = nominal)."""
    gradient: float = Field(default=0.15, ge=0, le=1, allow_inf_nan=False)
    """Lighting gradient: ±this fraction of the light from one corner to the other."""
    table: Literal["wood", "grey"] = "wood"
    """Table surface the sim renderer draws."""
    seed: Seed = 0
    """Seed of the texture and of the noise sequence (frame i uses seed + i)."""

    @model_validator(mode="after")
    def _path_for_replay(self) -> CameraConfig:
        if self.kind in ("file", "folder") and not self.path:
            raise ValueError(f"camera.kind '{self.kind}' needs camera.path")
        if self.width_px * self.height_px > MAX_FRAME_PIXELS:
            raise ValueError(
                f"@width_px: {self.width_px}x{self.height_px} px is more than "
                f"{MAX_FRAME_PIXELS} pixels (4K UHD, 3840x2160)"
            )
        return self


class CalibrationConfig(Strict):
    """How pixels map to the base frame [cm]: a plane homography (paper §4) or a calibrated camera.

    ``homography`` (the paper's model, the default): one pixel → table homography, exact
    for a distortion-free camera and points on the plane it was fitted in. The default
    matrix is the paper's measured rig: x = 0.0625·u − 20.5, y = 59.0 − 0.0625·v.

    ``perspective``: the camera's intrinsics (camera matrix, lens distortion; from
    ``mearm calibrate-intrinsics``) and its pose in the base frame (from
    ``mearm calibrate-camera --intrinsics``), each in its own calibration file; each
    object is located by its top face at its class's ``height_cm``
    (:mod:`mearm.vision.pinhole`). A relative file path is relative to the config file's
    folder; one given by ``--set``, to the current folder.
    """

    model: Literal["homography", "perspective"] = "homography"
    """``homography`` (paper) or ``perspective`` (needs both files below)."""
    intrinsics_file: PathText | None = None
    """The camera's intrinsics file (``model: perspective``)."""
    extrinsics_file: PathText | None = None
    """The camera's pose file (``model: perspective``)."""

    homography: tuple[
        tuple[HomographyEntry, HomographyEntry, HomographyEntry],
        tuple[HomographyEntry, HomographyEntry, HomographyEntry],
        tuple[HomographyEntry, HomographyEntry, HomographyEntry],
    ] = ((0.0625, 0.0, -20.5), (0.0, -0.0625, 59.0), (0.0, 0.0, 1.0))
    """Pixel (u, v, 1) → table (x w, y w, w) [cm]; checked against the camera's frame when
    the whole config loads: the frame's corners must land on the table (within ±1000 cm),
    on one side of the horizon (w of one sign)."""
    reprojection_error_cm: NonNegativeLength | None = None
    image_size_px: (
        tuple[
            Annotated[int, Field(ge=MIN_FRAME_SIDE_PX, le=MAX_FRAME_SIDE_PX)],
            Annotated[int, Field(ge=MIN_FRAME_SIDE_PX, le=MAX_FRAME_SIDE_PX)],
        ]
        | None
    ) = None
    """The frame size [width, height] px the homography was fitted at (``mearm
    calibrate-camera`` writes it). A config whose ``camera.width_px`` × ``height_px``
    differs is refused when it loads: the homography maps pixels of that size only.
    ``null``: unknown (a calibration written before mearm recorded it), not checked.
    Not given: with the built-in homography, the paper's 640 × 480; with a homography the
    config gives, unknown (a config that gives a homography without its size does not
    take the size of the config it extends, nor does a ``--set`` of it)."""

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

    @model_validator(mode="before")
    @classmethod
    def _paper_size(cls, data: Any) -> Any:
        """The built-in homography is the paper's, fitted to its 640 × 480 frames."""
        if isinstance(data, dict) and "homography" not in data and "image_size_px" not in data:
            return {**data, "image_size_px": PAPER_FRAME_PX}
        return data

    @model_validator(mode="after")
    def _files_for_perspective(self) -> CalibrationConfig:
        if self.model == "perspective":
            missing = [
                name
                for name in ("intrinsics_file", "extrinsics_file")
                if getattr(self, name) is None
            ]
            if missing:
                raise ValueError(
                    f"model 'perspective' needs {' and '.join(missing)} (make them with "
                    "mearm calibrate-intrinsics and mearm calibrate-camera --intrinsics)"
                )
        return self


PixelLevel = Annotated[float, Field(gt=0, le=255, allow_inf_nan=False)]
PixelPoint = tuple[
    Annotated[float, Field(ge=-MAX_FRAME_SIDE_PX, le=2 * MAX_FRAME_SIDE_PX, allow_inf_nan=False)],
    Annotated[float, Field(ge=-MAX_FRAME_SIDE_PX, le=2 * MAX_FRAME_SIDE_PX, allow_inf_nan=False)],
]
#: ``vision.work_area_px: whole_frame``: the work area is every pixel of the frame.
WHOLE_FRAME = "whole_frame"
#: What ``whole_frame`` is held as: a square from the origin past the largest image mearm
#: reads (65,535 px a side, :data:`mearm.vision.image.MAX_IMAGE_SIDE_PX`), so that every
#: user of the polygon (the detector, the benches) covers the whole frame with no case of
#: its own; a config's dump writes it back as ``whole_frame``.
WHOLE_FRAME_PX: list[tuple[float, float]] = [
    (0.0, 0.0), (65536.0, 0.0), (65536.0, 65536.0), (0.0, 65536.0)
]  # fmt: skip


class VisionConfig(Strict):
    """HSV colour segmentation; each class's hue bands are in ``task.classes``.

    A pixel counts when its saturation and value reach the floors and its hue lies in a
    band of a class. The floors' defaults reject white paper, a grey table and specular
    highlights (S < 0.15) and deep shadows (V < 0.25); the paper used 0.1 for both.
    """

    saturation_min: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.4
    value_min: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.25
    median_kernel: int = Field(
        default=3, ge=1, le=MAX_MEDIAN_KERNEL, json_schema_extra={RULES: ["odd"]}
    )
    min_area_px: int = Field(default=100, ge=1, le=MAX_FRAME_PIXELS)
    merged_area_ratio: Annotated[float, Field(gt=1, le=100, allow_inf_nan=False)] = 1.6
    """A region larger than this times one object's expected area is flagged merged."""
    merged_elongation: Annotated[float, Field(gt=1, le=100, allow_inf_nan=False)] = 1.5
    """A region whose major/minor axis ratio exceeds this is flagged merged."""
    shadow_value_min: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] | None = None
    """Grow each region into its own shadow: a pixel of the class's hue and saturation
    whose value is under ``value_min`` but at least this [-] counts when it joins a region
    that passes ``value_min`` (hysteresis), so that a lamp's shadow across an object does
    not cut its outline; ``null``: never (the paper's recipe). Hue bands on frames as
    they come only: not used with learned colours or ``reference_bgr``. With a work area
    (``work_area_px``, ``whole_frame`` or the calibrated table's outline) a region grows up
    to its edge and no further, and never into the arm's mask."""
    highlight_saturation_min: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] | None = None
    """Find blown-out tops: a pixel at or near the clip (V ≥ 0.95) whose hue lies in a
    class's band counts for it when its saturation is under ``saturation_min`` but at least
    this [-]. A glossy object's highlight adds the lamp's white to every channel, which
    keeps its hue but lowers its saturation; a top blown out under a lamp overhead came out
    at S ≈ 0.37–0.39 and was missed. White and grey highlights (paper, a grey table) stay
    under it near S = 0. ``null``: never (the paper's recipe). Hue bands on frames as they
    come only: not used with learned colours (their own highlight pass) or ``reference_bgr``."""
    reference_bgr: tuple[PixelLevel, PixelLevel, PixelLevel] | None = None
    """Colour constancy: the work area's median colour (B, G, R) in the frames the colours
    were learned from (``mearm learn-colours`` writes it); each frame's channels are scaled
    so that its own median matches it before any class is classified, which undoes the
    camera's white balance and exposure; ``null``: frames as they come."""
    work_area_px: Annotated[list[PixelPoint], Field(min_length=3, max_length=64)] | None = Field(
        default=None, json_schema_extra={SPELLINGS: [WHOLE_FRAME]}
    )
    """Where objects can be: a polygon (u, v) [px] in the pixels of the frames detected in
    (the camera's: ``camera.width_px`` × ``camera.height_px``), clipped to the frame;
    nothing outside it is detected. ``whole_frame``: every pixel of the frame, whatever the
    config it extends says. ``null``: with a perspective calibration the calibrated table's
    outline, else the whole frame. ``mearm learn-colours`` writes the table's outline it
    finds, the polygon given with ``--work-area``, or ``whole_frame`` (``--whole-frame``, or
    no table found). A polygon whose points lie on one line (enclosing under 1 px²) is
    refused as the config loads. ``mearm detect`` refuses a polygon with no pixel in a
    frame and warns
    when one leaves out most of a frame while most of it lies outside (drawn on frames of
    another size)."""

    @field_validator("work_area_px", mode="wrap")
    @classmethod
    def _whole_frame(
        cls, value: Any, handler: ValidatorFunctionWrapHandler
    ) -> list[tuple[float, float]] | None:
        # whole_frame's polygon reaches past the points' bounds: not validated as one
        if isinstance(value, str):
            if value != WHOLE_FRAME:
                raise ValueError(
                    f"expected a polygon [[u, v], ...] of 3 to 64 points, {WHOLE_FRAME} or null"
                )
            return list(WHOLE_FRAME_PX)
        held = isinstance(value, list) and all(isinstance(p, tuple) for p in value)
        if held and value == WHOLE_FRAME_PX:  # as held: a config's fields revalidate as they are
            return list(WHOLE_FRAME_PX)
        polygon: list[tuple[float, float]] | None = handler(value)
        flat = None if polygon is None else why_flat(polygon)
        if flat is not None:  # refused as it loads, as every command that takes one does
            raise ValueError(flat)
        return polygon

    @field_serializer("work_area_px")
    def _write_whole_frame(
        self, polygon: list[tuple[float, float]] | None
    ) -> list[tuple[float, float]] | str | None:
        return WHOLE_FRAME if polygon == WHOLE_FRAME_PX else polygon

    @model_validator(mode="after")
    def _shadow_below_value(self) -> VisionConfig:
        if self.shadow_value_min is not None and self.shadow_value_min >= self.value_min:
            raise ValueError(
                f"@shadow_value_min: {self.shadow_value_min:g} must be below value_min "
                f"({self.value_min:g}), or null"
            )
        return self

    @model_validator(mode="after")
    def _highlight_below_saturation(self) -> VisionConfig:
        low = self.highlight_saturation_min
        if low is not None and low >= self.saturation_min:
            raise ValueError(
                f"@highlight_saturation_min: {low:g} must be below saturation_min "
                f"({self.saturation_min:g}), or null"
            )
        return self

    @field_validator("median_kernel")
    @classmethod
    def _odd(cls, k: int) -> int:
        if k % 2 == 0:
            raise ValueError("must be odd")
        return k


# --------------------------------------------------------------------------- controller


#: The solver's stopping tolerance may lie in [lo, hi] [cm²] (``mearm ik --tolerance`` too).
TOLERANCE_CM2_RANGE = (1e-12, 100.0)


class ControllerConfig(Strict):
    """The IK solver: PD-PIJ (paper §3), or mink / the closed form as cross-checks.

    The gains must keep the linearised loop e_{t+1} = (1−kp−kd)·e_t + kd·e_{t−1} stable:
    kp > 0, 0 ≤ kd < 1 and kp + 2·kd < 2 (Jury's test on its characteristic polynomial).
    """

    solver: Literal["pdpij", "mink", "analytic"] = "pdpij"
    """Which solver :func:`mearm.ik.solve_ik` runs."""
    mode: Literal["paper", "coupled"] = "coupled"
    """paper: θ ∈ R⁴, 3×4 J, coupling re-imposed after each update; coupled: J·C."""
    kp: float = Field(default=0.1, gt=0, allow_inf_nan=False)
    """Proportional gain [-]."""
    kd: float = Field(default=0.01, ge=0, allow_inf_nan=False)
    """Derivative gain [-]."""
    tolerance_cm2: float = Field(
        default=1e-3, ge=TOLERANCE_CM2_RANGE[0], le=TOLERANCE_CM2_RANGE[1], allow_inf_nan=False
    )
    """Stop when |e|² is below this [cm²] (paper §3, eq. 6)."""
    max_iterations: int = Field(default=1000, ge=1, le=MAX_ITERATIONS)
    """Give up (status ``max_iterations``) after this many updates."""
    singular_value_cutoff: float = Field(default=1e-6, gt=0, lt=1, allow_inf_nan=False)
    """Singular values at or below this times the largest are treated as zero in J⁺ [-]."""
    damping: float = Field(default=0.0, ge=0, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """> 0 selects damped least squares, Jᵀ(J Jᵀ + λ² I)⁻¹, with this λ [cm/rad]."""
    safeguard: bool = True
    """Reject an update that would raise |e| and retry along the clamped exact step."""
    stall_iterations: int = Field(default=50, ge=1, le=MAX_ITERATIONS)
    """Status ``stalled`` when |e| fell by under a relative 1e-6 over this many updates."""
    qp_solver: Name = "daqp"
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
            problems = [
                describe_error({**e, "loc": ("controller", *e["loc"])}) for e in exc.errors()
            ]
            raise ConfigError(None, problems) from None


# --------------------------------------------------------------------------- servos


class SimErrorModel(Strict):
    """How the simulated servos miss their commands (paper §5).

    ``quantization``: ``microsecond`` — the integer-µs pulse the serial backends send;
    ``degree`` — a whole degree of the servo's 0–180° scale, as ``Servo.write`` does (one
    step is (max_us − min_us)/180 µs, 1 DH degree with the default mapping); ``none``.
    The realised angle is the quantised one plus ``offset_deg`` (static, per joint) plus
    Gaussian noise of ``noise_std_deg`` drawn per move and joint; a joint they send past its
    limits stops at them, as the twin's joints and the virtual Uno's arm do. The kinematic
    simulator's servos only: the twin's (``simulator: mujoco``) miss their commands by their
    physics, and as real units do with ``twin.kit``; of these it reads ``seed`` alone, and
    a sort says so of the others when they are set.
    """

    quantization: Literal["none", "degree", "microsecond"] = "microsecond"
    # a default pydantic copies for each model, not default_factory=dict: pydantic reads a
    # builtin's signature by compiling tokenize's patterns (≈ 15 ms at every start-up)
    offset_deg: dict[Name, Length] = Field(default={}, max_length=12)
    """Static offset per actuated joint [deg or cm], by joint name; unnamed joints: 0."""
    noise_std_deg: float = Field(default=0.0, ge=0, le=MAX_ANGLE_DEG, allow_inf_nan=False)
    seed: Seed = 0


#: A compile-time option of a firmware variant: ``NAME`` or ``NAME=VALUE`` (a C macro;
#: nothing a shell would read as more than one word).
DEFINE_PATTERN = r"^[A-Z][A-Z0-9_]{0,39}(=[A-Za-z0-9_]{1,20})?$"
FirmwareDefine = Annotated[str, Field(pattern=DEFINE_PATTERN, max_length=61)]
#: Fastest virtual Uno: simulated seconds per wall-clock second.
MAX_SIM_SPEED = 100.0


class VirtualUnoConfig(Strict):
    """The virtual Uno (``servo.backend: virtual_uno``): the project's firmware in simavr.

    The firmware (``tools/arduino/mearm_servo``) and its simulator harness are built on
    first use into ``~/.cache/mearm/virtual_uno`` (``$XDG_CACHE_HOME`` if set). The
    serial backend drives it over a pseudo-terminal (``servo.port`` is not used), and the
    simulated arm moves by the pulse widths the emulated pins produce, measured in CPU
    cycles (:mod:`mearm.sim.virtual_uno`).
    """

    speed: float = Field(default=1.0, ge=0, le=MAX_SIM_SPEED, allow_inf_nan=False)
    """Simulated seconds per wall-clock second; 0: as fast as the computer runs it. The
    host paces its moves and waits in simulated time and the firmware's timeouts are
    simulated time, so a run does the same at any speed."""
    pulse_tolerance_us: float = Field(default=10.0, gt=0, le=100, allow_inf_nan=False)
    """A measured pulse farther than this from the one sent faults the move [µs]. The
    firmware's pulses are within 1 µs of the command but for the odd one an interrupt
    (``millis``, the UART) stretches by up to ~6 µs (measured: max 6.2 µs over
    10 000 pulses); a swapped or miswired channel is off by hundreds."""
    defines: list[FirmwareDefine] = Field(default=[], max_length=16)  # (copied: see offset_deg)
    """Compile-time options of a firmware variant, e.g. ``SERVO_PIN_1=6`` (channel 1 on
    pin D6); each variant is built into its own cache folder. Empty: the shipped
    firmware."""


class ServoConfig(Strict):
    """The servo link (paper §1: an Arduino Uno over USB serial) and the simulated arm."""

    backend: Literal["sim", "serial", "ssc32", "virtual_uno"] = "sim"
    """``sim``: the simulated arm, moved by the commands; ``serial``: a board running
    ``tools/arduino/mearm_servo``; ``ssc32``: an SSC-32; ``virtual_uno``: that firmware
    in simavr, the simulated arm moved by its measured pulses (section ``virtual_uno``)."""
    port: PathText = "/dev/ttyACM0"
    """Serial device, or a pyserial URL of an allowed scheme: ``socket://host:port``,
    ``rfc2217://host:port`` or ``loop://`` (no other: ``spy://`` writes files)."""
    calibration_file: PathText | None = None
    """A servo calibration file written by ``mearm calibrate-servos`` (a relative path:
    to the config file's folder; given by ``--set``, to the current folder): its fitted
    zero, µs per unit and direction replace those of the arm's actuators it names, when
    the config loads. ``None``: the config's own."""
    calibrate_at_start: Literal["never", "when_uncalibrated"] = "never"
    """``when_uncalibrated``: a sort whose servos were never calibrated (no
    ``calibration_file``) first calibrates them by the camera, as ``mearm calibrate-servos
    --camera`` does (the arm moves over the table, clear of the objects, for up to 3
    minutes), and sorts with that calibration, kept for the run. Needs a marker on the
    claw (``arm.tool.marker``) and a perspective calibration of the camera. ``never``: the
    sort uses the arm's nominal calibration (no motion the user did not ask for)."""
    baud: int = Field(default=115200, ge=BAUD[0], le=BAUD[1])
    rate_hz: float = Field(default=50.0, ge=RATE_HZ[0], le=RATE_HZ[1], allow_inf_nan=False)
    """Commands per second at most (the servo frame rate); lower if the baud rate demands.
    The physical twin (``simulator: mujoco``) takes at most 500, one per physics step."""
    ack_timeout_s: Seconds = 0.5
    banner_timeout_s: Seconds = 3.0
    """How long a board has to say what it is once the port opens: the Uno's banner (it
    restarts as the port opens), the SSC-32's answer to the first ``VER`` [s]."""
    retries: int = Field(default=3, ge=0, le=MAX_RETRIES)
    """Tries after the first of one exchange with the board: a command that failed its
    checksum (Uno), a lost, late or garbled answer to a query (SSC-32)."""
    grip_tolerance_cm: float = Field(default=1.2, ge=0.01, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """Sim: a pick succeeds if the EE is this close to the object in the plane and to
    the pick height in z (paper §5: picks under 1.2 cm error always succeeded)."""
    bin_radius_cm: float = Field(default=4.0, ge=0.1, le=MAX_LENGTH_CM, allow_inf_nan=False)
    """Sim: an object released within this distance (in the plane) of a bin falls into
    it; farther away it drops onto the table under the EE."""
    sim_realtime: bool = False
    """Sim: pace moves at ``rate_hz`` like the real link (default: as fast as it can)."""
    error_model: SimErrorModel = SimErrorModel()
    virtual_uno: VirtualUnoConfig = VirtualUnoConfig()
    """The virtual Uno (``backend: virtual_uno``)."""

    @field_validator("port")
    @classmethod
    def _allowed_port(cls, value: str) -> str:
        try:
            return check_port(value)
        except SerialPortError as exc:  # the loc and the value are added by the loader
            raise ValueError(str(exc).split(": ", 1)[1]) from None


# --------------------------------------------------------------------------- task


class SceneObject(Strict):
    """One object on the (simulated) table, base frame [cm]; ``color`` names its class.

    Its shape is its class's (:attr:`ColorClass.object_shape`); ``yaw_deg`` turns it
    about the vertical (a cube's or a prism's faces; a cylinder looks the same) [deg].
    """

    color: Name
    x: Length
    y: Length
    yaw_deg: Angle = 0.0


class TaskConfig(Strict):
    """The sorting task: the colour classes in sort order, retries and the simulated table."""

    classes: list[ColorClass] = Field(
        default_factory=default_classes, min_length=1, max_length=MAX_CLASSES
    )
    pick_retries: int = Field(default=2, ge=0, le=MAX_PICK_RETRIES)
    approach_height_cm: float | None = Field(default=None, gt=0, le=50, allow_inf_nan=False)
    """Picks go via a point this far above the object and lift back to it with the object
    before the place, so the jaws neither sweep through other objects and bin walls nor
    drag what they hold [cm]; ``null``: the paper's direct routes (what the kinematic
    simulator, which has no collisions, reproduces). The point above every class's pick
    must lie in ``arm.target_box``, as the pick must (refused when the config loads)."""
    look_at_claw: bool = True
    """Picks that look: before the jaws close, the camera sees where the claw's marker is
    and the pick is corrected (:mod:`mearm.task.claw_loop`). Only where the tool carries
    a marker (``arm.tool.marker``), the camera has a perspective calibration and the pick
    goes via a point above the object (``approach_height_cm``); ``false``: never."""
    carry_accel_deg_s2: float | None = Field(default=None, ge=100, le=1e6, allow_inf_nan=False)
    """While the jaws hold an object, no servo's shaft accelerates faster than this
    [deg/s²] (nor than its own ``max_accel_deg_s2``): a grip of the top millimetres of an
    object's side holds at a gentle start and stop and lets go at a servo's full jolt
    (docs/twin.md); ``null``: only the servos' own limits."""
    clearance_cm: float = Field(default=0.3, ge=0, le=10, allow_inf_nan=False)
    """What the arm's body keeps from every bin and object on every route [cm], checked
    along the whole path before anything moves (the table gets none: the jaws come down
    to it to close on an object). A route that would come closer goes up, over at a
    safe height and down instead; one that cannot is refused (``collision``)."""
    position_error_cm: float = Field(default=0.0, ge=0, le=10, allow_inf_nan=False)
    """How far the arm's tool may land from where a pick is planned [cm]: the servos'
    zero and gain errors, their play. Where the jaws come down to a pick, they keep this
    from every bin's wall on top of ``clearance_cm``, so an arm that lands this far off
    does not press on the wall (a pick that would is moved off the wall, else refused,
    ``collision``); nothing else changes (the picks' jaws and the other objects, home,
    the places). Measured on the rig: the largest residual ``mearm check-camera`` prints,
    or the largest distance from a pick's target to where the tool came down."""
    order: Literal["class", "nearest"] = "class"
    """Which object the arm takes next. ``class``: the classes in the order listed (the
    paper's: every red, then green, then blue), the nearest of a class first; ``nearest``:
    the object nearest the TCP whatever its class, which shortens the travel from each bin
    to the next object. Either way an object whose open jaws come down clear of every
    neighbour goes before one that has a neighbour under them."""
    scene: list[SceneObject] = Field(
        default_factory=lambda: [SceneObject(color=c, x=x, y=y) for c, x, y in PAPER_LAYOUT],
        max_length=MAX_SCENE_OBJECTS,
    )

    @model_validator(mode="after")
    def _classes_distinct(self) -> TaskConfig:
        names: set[str] = set()
        bins: dict[tuple[float, float, float], str] = {}
        for c in self.classes:
            if c.name in names:
                raise ValueError(f"@classes: '{c.name}' is listed twice")
            names.add(c.name)
            if c.bin_cm in bins:
                raise ValueError(
                    f"@classes: '{c.name}' and '{bins[c.bin_cm]}' share the bin at "
                    f"{list(c.bin_cm)} cm; each class needs its own bin"
                )
            bins[c.bin_cm] = c.name
        self._told_apart()
        for i, obj in enumerate(self.scene):
            if obj.color not in names:
                raise ValueError(  # a scene a config that changed the classes took unchanged
                    f"@scene.{i}.color: '{obj.color}' is not a class "
                    f"(classes: {', '.join(c.name for c in self.classes)}); a config that "
                    "changes the classes gives its own task.scene, or task.scene: []"
                )
        return self

    def _told_apart(self) -> None:
        """Refuse two classes the camera cannot tell apart.

        A hue both hold, and no shape that differs (either may be any shape, or both are
        the same one). The detector gave such pixels to the first class, and the sort then
        counted objects it never had, with reasons that were not what happened. A class
        taught its colour (``learned_colour``) is compared by nothing here: its model
        stands for its bands.
        """
        banded = [c for c in self.classes if c.hue_bands_deg and c.learned_colour is None]
        for i, a in enumerate(banded):
            for b in banded[i + 1 :]:
                assert a.hue_bands_deg is not None and b.hue_bands_deg is not None
                shared = hues_shared(a.hue_bands_deg, b.hue_bands_deg)
                if shared is None or (a.shape and b.shape and a.shape != b.shape):
                    continue
                shapes = " ".join(f"{c.name}'s shape is {c.shape or 'any (null)'};" for c in (a, b))
                raise ValueError(
                    f"@classes: '{a.name}' and '{b.name}' are the same to the camera: both "
                    f"hold hues {shared[0]:g}..{shared[1]:g} deg and {shapes} give them "
                    "different shapes, or hue_bands_deg that do not overlap"
                )

    def class_named(self, name: str) -> ColorClass:
        """The class called ``name`` (:func:`~mearm.config.classes.class_named`)."""
        return class_named(self.classes, name)

    @property
    def class_names(self) -> list[str]:
        """Class names in sort order."""
        return [c.name for c in self.classes]
