"""Consistency at load: what a config promises, checked before any device opens.

The validator checks each section on its own (a limit inside its servo's pulse range, a
home inside its limits). This module checks what only the whole config can tell, by
solving it: every class's bin is reached from home within the limits; the jaws close on
the object (the grip height within the object's height plus the jaws' length); every
class's pick height (derived from the object's height, the grip height and the tool's geometry) lies
in the target box and is reached somewhere in it; and how much of the camera's
view of the table the arm cannot reach, said once (surveyed only for a sort that prints
its notes; none of it reached is a failure: the sort would find nothing to do); at home,
no part of the tool below the table. Home itself
needs no solve: the arm
goes home along a straight line in joint space, inside the limits by construction.

A failure is a :class:`~mearm.errors.ConfigError` naming the field and its value, so
the CLIs end with exit 2 before anything moves. A failure that the config's servo
calibration file causes (``servo.calibration_file``: the same check passes with the
calibration the file replaced) also names the file and what to do about it; failures
the IK controller's settings cause (gone with its defaults) are said as one line naming
the settings, not as the arm's.

:func:`calibration_note` is the line a sort on servos that were never calibrated
prints before it starts (real boards, or the twin with a kit of servos).
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field

import numpy as np
from pydantic import BaseModel

from mearm.cli import check_closed_form
from mearm.config import ColorClass, Config, ControllerConfig, TaskConfig
from mearm.config.files import config_source, unit_warning
from mearm.config.loader import unit_hints
from mearm.errors import ConfigError, MearmError
from mearm.kinematics import ArmModel
from mearm.kinematics.bodies import (
    BIN_MIN_WALL_HEIGHT_M,
    M_PER_CM,
    base_radius_m,
    bin_half_outer_m,
    wall_height_m,
)
from mearm.kinematics.collision import TOUCH_CM, CollisionModel
from mearm.sim.table_collision import collision_model
from mearm.task.plan import Planner
from mearm.task.route import Route
from mearm.vision.calibration import camera_geometry

#: The camera's view is sampled on a grid of this many points across × down.
VIEW_GRID = (7, 5)


@dataclass
class Consistency:
    """What the check found besides failures.

    Attributes:
        pick_z_cm: Per class, the TCP height of its picks [cm].
        unreachable_share: Per pick height [cm], the share of the camera's view of the
            table the arm cannot pick from (0–1); surveyed only for the notes
            (:func:`check_consistency`'s ``notes``), else empty.
        notes: Lines to show once before the run (with ``notes``).
        warnings: Lines for standard error before the run, each after ``PROG: warning:``
            (:func:`~mearm.config.files.unit_warning`: an arm whose lengths look like mm
            or angles like radians is valid, but not the arm that was built).
    """

    pick_z_cm: dict[str, float] = field(default_factory=dict)
    unreachable_share: dict[float, float] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)


#: Per config: what the check found, and whether it surveyed the view (``notes``).
_CACHE: dict[str, tuple[Consistency, bool]] = {}


def check_consistency(
    config: Config, model: ArmModel | None = None, *, notes: bool = False
) -> Consistency:
    """Solve what the config promises; raise on what cannot hold.

    ``notes``: also survey how much of the camera's view is out of reach at each pick
    height (:attr:`Consistency.unreachable_share` and its note), planning a pick from home
    at each of its points; without, the survey stops at the first point reached, which is
    all the failures need (a view holding none), and the share and the note stay unsaid.
    Only a sort that prints its notes asks for them. Results are cached per config (a run
    of many trials checks once); one without the survey is made again when asked for it.

    Raises:
        ConfigError: an ``arm.closed_form`` the arm cannot use, a bin that cannot be
            reached from home, or a class whose picks are outside the target box or
            reached nowhere in it; one line per problem, each naming the field and its
            value (led by the arm's unit hints, :func:`~mearm.config.loader.unit_hints`).
    """
    key = hashlib.sha256(config.model_dump_json().encode()).hexdigest()
    if key in _CACHE and (_CACHE[key][1] or not notes):
        return _CACHE[key][0]
    check_closed_form(config)  # named with the config's source, before a solver stops on it
    model = model if model is not None else ArmModel(config.arm)
    planner = Planner(config, model)
    found = Consistency()
    for warning in (unit_warning(config), twin_only_warning(config)):
        if warning is not None:
            found.warnings.append(warning)
    problems = _check_bins(planner, model, config.task.classes)
    table = collision_model(config, model, clearance_cm=0.0)  # bins and table, for both checks
    problems += _check_bodies(config, model, table)
    problems += _check_home_above_table(config, model, table)
    view_cm = _view_points_cm(config)
    reached_anywhere = False
    by_height: dict[float, list[str]] = {}
    for cls in config.task.classes:
        z = float(planner.pick_target(cls, 0.0, 0.0).position_cm[2])
        found.pick_z_cm[cls.name] = z
        by_height.setdefault(round(z, 6), []).append(cls.name)
    jaw_cm = config.arm.tool.gripper.jaw_length_cm
    for cls in config.task.classes:
        if cls.grip_z_cm > cls.height_cm + jaw_cm:
            problems.append(
                f"{_pick_field(cls)}: the jaws would close {cls.grip_z_cm:g} cm above the "
                f"table, above the object ({cls.height_cm:g} cm high) by more than the jaws "
                f"are long ({jaw_cm:g} cm): at most {cls.height_cm + jaw_cm:g} cm"
            )
    box = config.arm.target_box
    for z, names in by_height.items():
        field_name = _pick_field(config.task.class_named(names[0]))
        if not box.z_cm.contains(z):
            problems.append(
                f"{field_name}: picks of {', '.join(names)} put the TCP at z = {z:.2f} cm, "
                f"outside arm.target_box.z_cm [{box.z_cm.min:g}, {box.z_cm.max:g}] "
                "(pick height = grip height + arm.tool.tcp_above_grip_cm)"
            )
            continue
        if not _reached_somewhere(planner, model, names[0], _box_points_cm(config)):
            problems.append(
                f"{field_name}: picks of {', '.join(names)} at z = {z:.2f} cm are reached "
                "nowhere in arm.target_box within the joint limits: check the arm's reach, "
                "the box and the pick height (grip height + arm.tool.tcp_above_grip_cm)"
            )
            continue
        if not notes:  # the failure needs one point reached, at any height
            reached_anywhere = reached_anywhere or any(_reached(planner, model, names[0], view_cm))
            continue
        reached = np.fromiter(_reached(planner, model, names[0], view_cm), bool, len(view_cm))
        reached_anywhere |= bool(reached.any())
        share = 1.0 - float(np.mean(reached))
        found.unreachable_share[z] = share
        if share > 0:
            lo, hi = view_cm.min(axis=0), view_cm.max(axis=0)
            found.notes.append(
                f"note: {share:.0%} of the camera's view of the table "
                f"(x {lo[0]:.0f}…{hi[0]:.0f} cm, y {lo[1]:.0f}…{hi[1]:.0f} cm) is out of the "
                f"arm's reach at the pick height {z:.2f} cm ({', '.join(names)}); objects "
                "there are reported and left"
            )
    if not problems and not reached_anywhere:
        lo, hi = view_cm.min(axis=0), view_cm.max(axis=0)
        problems.append(
            f"calibration.homography: the camera's view of the table (x {lo[0]:.0f}…"
            f"{hi[0]:.0f} cm, y {lo[1]:.0f}…{hi[1]:.0f} cm) holds no point the arm can pick "
            "from at any class's pick height: a sort would find nothing to do; point the "
            "camera (and its calibration) at the arm's reach"
        )
    if problems:
        problems = _blame_controller(config, problems)
        problems = _blame_calibration_file(config, problems)
        # an arm in mm or radians fails here first: the hint names what the problems show
        hints = unit_hints(config.model_dump(mode="json"))
        raise ConfigError(config_source(config), [*hints, *problems])
    _CACHE[key] = (found, notes)
    return found


def _blame_controller(config: Config, problems: list[str]) -> list[str]:
    """The problems; those the IK controller's settings cause made one line naming them.

    Caused by the settings: gone when the check runs again with the controller's defaults
    (the arm unchanged). A solver stopped at ``controller.max_iterations=1`` missed every
    bin, and the refusal named the arm's DH rows as the likely cause: the problems it
    causes say what the arm does not, so they are left out, and the settings said first.
    """
    defaults = ControllerConfig()
    changed = [
        (name, value, getattr(defaults, name))
        for name, value in config.controller
        if value != getattr(defaults, name)
    ]
    if not changed:
        return problems
    plain = config.model_copy(update={"controller": defaults})
    also: set[str] = set()  # the problems the config has with the default settings too
    try:
        check_consistency(plain)
    except ConfigError as exc:
        also = set(exc.problems)
    caused = [p for p in problems if p not in also]
    if not caused:
        return problems
    settings = ", ".join(f"controller.{n} = {v} (default {d})" for n, v, d in changed)
    fields = ", ".join(p.split(": ", 1)[0] for p in caused)
    them, default = ("it", "its default") if len(changed) == 1 else ("them", "their defaults")
    line = (
        f"{settings}: the IK solver fails with {them} where the default controller settings "
        f"succeed ({fields}): the controller's settings are the cause, not the arm; set "
        f"{them} back to {default}"
    )
    return [line, *(p for p in problems if p in also)]


def _blame_calibration_file(config: Config, problems: list[str]) -> list[str]:
    """The problems; those the servo calibration file causes name it and what to do.

    Caused by the file: gone with the calibration it replaced (its ``replaces``). A file
    that records none cannot be told apart: each problem then names it as a maybe.
    """
    path = config.servo.calibration_file
    if path is None:
        return problems
    from mearm.config.servo_file import replaced_calibration  # noqa: PLC0415  (a file's only)

    try:
        before = replaced_calibration(config)
    except MearmError:  # the file loaded with the config; if it no longer does, say maybe
        before = None
    # said first: a CLI's one line may cut the end of a long problem
    fix = "re-run mearm calibrate-servos or remove servo.calibration_file"
    if before is None:
        return [
            f"with the servo calibration from {path} (maybe the cause: {fix}): {p}"
            for p in problems
        ]
    plain = before.model_copy(
        update={"servo": before.servo.model_copy(update={"calibration_file": None})}
    )
    also: set[str] = set()  # the problems the config has without the file too
    try:
        check_consistency(plain)
    except ConfigError as exc:
        also = set(exc.problems)
    blame = f"with the servo calibration from {path} (without it this holds: {fix})"
    return [p if p in also else f"{blame}: {p}" for p in problems]


def twin_only_warning(config: Config) -> str | None:
    """The line for the physical twin's settings on a config the twin does not run, or None.

    ``twin.faults``, ``twin.kit``, ``twin.lamp`` and ``twin.camera`` act only where
    ``simulator`` is ``mujoco``; elsewhere they do nothing, and a fault meant to test the
    sort's handling of one would pass untested. On the twin, the other way round: the
    kinematic renderer's ``camera`` settings, which it does not use
    (:func:`kinematic_camera_warning`).
    """
    if config.simulator == "mujoco":
        said = [w for w in (kinematic_camera_warning(config), kinematic_servo_warning(config)) if w]
        return "; ".join(said) or None
    twin = config.twin
    given = [
        name
        for name, value in (
            ("twin.faults", twin.faults), ("twin.kit", twin.kit),
            ("twin.lamp", twin.lamp), ("twin.camera", twin.camera),
        )
        if value
    ]  # fmt: skip
    if not given:
        return None
    what = "it does" if len(given) == 1 else "they do"
    return (
        f"{', '.join(given)}: the physical twin's (simulator: mujoco); this config's "
        f"simulator is {config.simulator}: {what} nothing here"
    )


#: The ``camera`` keys only the kinematic renderer reads
#: (:meth:`mearm.sim.kinematic.renderer.TableRenderer.from_config`): the twin's camera
#: (:class:`~mearm.sim.twin.twin_camera.TwinCamera`) renders its MuJoCo scene at
#: ``width_px × height_px`` and reads none of them.
KINEMATIC_CAMERA_KEYS = ("noise_std", "brightness", "gradient", "table", "seed")


def kinematic_camera_warning(config: Config) -> str | None:
    """The line for the kinematic renderer's camera settings on the twin, or ``None``.

    ``camera.noise_std``, ``brightness``, ``gradient``, ``table`` and ``seed``
    (:data:`KINEMATIC_CAMERA_KEYS`) draw the kinematic rig's frames; the twin
    (``simulator: mujoco``) renders its own scene, lit by its light (``twin.lamp``) and
    seen from its camera (``twin.camera``), with no sensor noise. Said for each one a
    config sets to other than its default: a sort meant to test dim or noisy frames would
    otherwise pass on the twin's clean ones.
    """
    if config.simulator != "mujoco":
        return None
    return _nothing_here(
        _changed(config.camera, "camera", KINEMATIC_CAMERA_KEYS),
        "the kinematic renderer's (simulator: kinematic); this config's simulator is mujoco, "
        "whose camera renders the twin's scene under its own light (twin.lamp) from "
        "twin.camera, with no sensor noise",
    )


def _changed(section: BaseModel, name: str, keys: Sequence[str]) -> list[str]:
    """The settings of ``keys`` a config's ``section`` (called ``name``) sets off their defaults."""
    defaults = type(section)()
    return [f"{name}.{k}" for k in keys if getattr(section, k) != getattr(defaults, k)]


def _nothing_here(given: Sequence[str], whose: str) -> str | None:
    """One line: the settings ``given``, whose they are, and that they do nothing here."""
    if not given:
        return None
    what = "it does" if len(given) == 1 else "they do"
    return f"{', '.join(given)}: {whose}: {what} nothing here"


#: The ``servo.error_model`` keys only the kinematic simulator's servos read: the twin's
#: servos err by their physics and kit (``twin.kit``), and read only its ``seed``.
KINEMATIC_SERVO_KEYS = ("offset_deg", "noise_std_deg", "quantization")


def kinematic_servo_warning(config: Config) -> str | None:
    """The line for the kinematic simulator's servo errors on the twin, or ``None``.

    ``servo.error_model.offset_deg``, ``noise_std_deg`` and ``quantization``
    (:data:`KINEMATIC_SERVO_KEYS`) make the kinematic rig's servos miss their commands;
    the twin's (``simulator: mujoco``) miss them by their physics, and as real units do
    with ``twin.kit``. A shoulder 30° off set on the twin sorted 3 of 3, silently, where
    the kinematic rig sorted none. Said for each one a config sets to other than its
    default.
    """
    if config.simulator != "mujoco":
        return None
    return _nothing_here(
        _changed(config.servo.error_model, "servo.error_model", KINEMATIC_SERVO_KEYS),
        "the kinematic simulator's servos' (simulator: kinematic); this config's simulator "
        "is mujoco, whose servos miss their commands by their physics (and as real units "
        "do, twin.kit)",
    )


def calibration_note(config: Config, config_args: Sequence[str]) -> str | None:
    """The line saying the servos were never calibrated, or ``None``.

    Said for servos that are real (``servo.backend`` ``serial`` or ``ssc32``) or that the
    twin draws as a kit of real units (``twin.kit``), when the config applies no servo
    calibration file: the arm's nominal calibration may be good enough, or not (or, with
    ``servo.calibrate_at_start: when_uncalibrated``, the sort calibrates them first). With a
    file, the limits it narrowed, if any (:func:`~mearm.config.servo_file.narrowed_limits_note`).

    Args:
        config: The whole configuration.
        config_args: The ``--config`` and ``--set`` arguments the config came from, for
            the command the line names.
    """
    if config.servo.calibration_file is not None:
        from mearm.config.servo_file import (  # noqa: PLC0415  (a file's only)
            load_servo_calibration,
            narrowed_limits_note,
        )

        path = config.servo.calibration_file
        cal = load_servo_calibration(path)
        board = cal.board_id
        if config.servo.backend == "virtual_uno" and all(a.replaces is None for a in cal.actuators):
            return (  # (own_servos.own_arm's choice, said where a user reads it)
                f"warning: {path} records no calibration it replaced (it was written before "
                "`replaces` was): the virtual Uno's servos turn by the calibration it gives, "
                "so a run can find no error in it; run mearm calibrate-servos again to write "
                "one that records it"
            )
        if config.servo.backend in ("serial", "ssc32") and board.startswith("simulated"):
            return (
                f"note: {path} was calibrated on a simulated board ({board}), not on these "
                "servos: its fits are the simulation's; run mearm calibrate-servos on this "
                "board to measure them"
            )
        return narrowed_limits_note(config)
    if config.servo.backend in ("serial", "ssc32"):
        what, extra = f"the servos on the {config.servo.backend} board", []
    elif config.simulator == "mujoco" and config.twin.kit is not None:
        what, extra = "the servos of the twin's kit (twin.kit)", ["--simulate"]
    else:
        return None
    import shlex  # noqa: PLC0415  (servos never calibrated only)

    command = shlex.join(["mearm", "calibrate-servos", *config_args, *extra])
    if config.servo.calibrate_at_start == "when_uncalibrated":
        return (
            f"note: {what} have never been calibrated (no servo.calibration_file): the sort "
            "calibrates them by the camera first (servo.calibrate_at_start), the arm moving "
            "over the table clear of the objects; to keep a calibration, pass "
            f"--save-calibration FILE or run {command}"
        )
    return (
        f"note: {what} have never been calibrated (no servo.calibration_file): the sort "
        f"uses the arm's nominal calibration; to measure theirs, run {command}"
    )


def _pick_field(cls: ColorClass) -> str:
    what = "height_cm" if cls.grip_height_cm is None else "grip_height_cm"
    return f"task.classes.{cls.name}.{what}"


#: How a bin inside the target box is missed when the arm is described otherwise than it
#: is built (not ``outside_box``: the bin's place; not ``collision``: what stands in the way).
ARM_FAILURES = frozenset({"unreachable", "limit", "stalled", "singular"})


def _check_bins(planner: Planner, model: ArmModel, classes: Sequence[ColorClass]) -> list[str]:
    """Every class's bin planned from home; one problem per bin missed.

    Two or more bins inside the target box that the arm misses (:data:`ARM_FAILURES`)
    make one problem instead, said first: their names, the likely cause (an arm described
    otherwise than it is built: a DH row's sign, a joint's limits, which ``mearm preview``
    draws) and the first one's reason.
    """
    problems: list[str] = []
    missed: list[str] = []  # the classes whose bins the arm misses
    reasons: list[str] = []  # each one's bin and reason
    for cls in classes:
        route = Route("", cls.name, "place", 1, planner.place_target(cls))
        planner.plan(route, model.home)
        if route.planned:
            continue
        place = f"[{', '.join(f'{v:g}' for v in cls.bin_cm)}]"
        if route.failure_kind in ARM_FAILURES:
            missed.append(cls.name)
            reasons.append(f"{cls.name} {place}: {route.failure}")
        problems.append(
            f"task.classes.{cls.name}.bin_cm: {place} cannot be reached from home within the "
            f"joint limits: {route.failure}"
        )
    if len(missed) < 2:
        return problems
    summary = (
        f"task.classes.{{{','.join(missed)}}}.bin_cm: {len(missed)} bins inside "
        "arm.target_box cannot be reached from home within the joint limits: the arm's "
        "description is the likely cause; check the signs of its DH rows (arm.joints.*.dh: "
        "alpha_deg, a_cm, d_cm, theta_deg) and its joint limits against the real arm, drawn "
        f"as described by mearm preview --sweep (the same --config and --set): {reasons[0]}"
    )
    kept = [p for p in problems if not any(p.startswith(f"task.classes.{n}.") for n in missed)]
    return [summary, *kept]


def _check_bodies(config: Config, model: ArmModel, collision: CollisionModel) -> list[str]:
    """The table as the collision model builds it: bins apart, clear of the arm at home.

    Each bin stands on its own square of the table, off the arm's base plate; the arm at
    home touches no bin and keeps ``task.clearance_cm`` from each (every run starts and
    ends there).
    """
    problems = []
    half = {c.name: bin_half_outer_m(c) / M_PER_CM for c in config.task.classes}
    base = base_radius_m(config.arm) / M_PER_CM
    seen: list[ColorClass] = []
    for cls in config.task.classes:
        x, y = cls.bin_cm[0], cls.bin_cm[1]
        where = f"task.classes.{cls.name}.bin_cm: [{x:g}, {y:g}]"
        for other in seen:
            reach = half[cls.name] + half[other.name]
            if abs(x - other.bin_cm[0]) < reach and abs(y - other.bin_cm[1]) < reach:
                problems.append(
                    f"{where}: its bin ({2 * half[cls.name]:g} cm square with its walls) "
                    f"overlaps {other.name}'s at [{other.bin_cm[0]:g}, {other.bin_cm[1]:g}]: "
                    "each bin needs its own place on the table"
                )
        seen.append(cls)
        dx, dy = max(abs(x) - half[cls.name], 0.0), max(abs(y) - half[cls.name], 0.0)
        if math.hypot(dx, dy) < base:
            problems.append(
                f"{where}: its bin stands on the arm's base plate ({base:.1f} cm radius "
                "about the origin): move it clear"
            )
    if problems:
        return problems
    near = list(bins_near_home(config, model, collision))
    if not near:
        return _clearance_shuts_bin(config, model, collision)
    kept = [distance for _, _, distance in near if distance > TOUCH_CM]
    # the least figure is the one that holds at every bin; taken, the sort must start
    most_cm, shut = _clearance_into_bins(config, model, min(kept)) if kept else (None, None)
    for name, part, distance in near:
        if distance <= TOUCH_CM:
            # walls grown for the table's objects reach the arm as a bin moved does: a
            # belt of 29 with red's diameter 1.59 cm (13.3 cm walls) said only "move the
            # bin or arm.joints[].home", where 10 sort whole
            problems.append(
                f"task.classes.{name}.bin_cm: the arm at home ({part}) touches its bin: "
                f"move the bin or arm.joints[].home{_walls_grown(config, collision, name)}"
            )
            continue
        keeps = (
            f"task.clearance_cm: {config.task.clearance_cm:g} cm is more than the arm keeps "
            f"from {name}'s bin at home ({part}, {_cm_down(distance)} cm)"
            if distance < config.task.clearance_cm
            else f"task.clearance_cm: {config.task.clearance_cm:g} cm is too much for the "
            f"arm at home beside {name}'s bin ({part}, {too_little_spare(distance, config)})"
        )
        walls = _walls_built(config, collision, name)
        if shut is None:
            most = _cm_down(distance - TOUCH_CM)
            problems.append(f"{keeps}: at most {most} cm, or move the bin{walls}")
        elif most_cm is not None:
            problems.append(
                f"{keeps}: at most {most_cm:.2f} cm (at {_cm_down(min(kept))} cm the arm has "
                f"no way into {shut}'s bin with one held), or move the bin{walls}"
            )
        else:
            problems.append(
                f"{keeps}, and no clearance leaves the arm a way into {shut}'s bin with one "
                f"held: move the bin{walls}"
            )
    return problems


def _clearance_shuts_bin(config: Config, model: ArmModel, collision: CollisionModel) -> list[str]:
    """A ``task.clearance_cm`` the arm keeps at home but not on its way into a bin: its line.

    The check at home passes a clearance the arm keeps there, yet no place into a bin may
    keep it from the walls with an object held: the MeArm v1 keeps over 1 cm from its bins
    at home, and ``mearm sort --config sim_mearm_v1_mujoco_perspective --set
    task.clearance_cm=1`` picked each of its six objects and left it, ``sorted 0 of 6
    objects (… 5 bin out of reach …)``. A place of each class is planned, as the sort plans
    it, from home and from the pick of each object of the config's own table
    (:func:`_place_shut_at`); where one is refused, the most clearance that lets every one
    through is named, one with which each object of the config's own table is picked from
    home too where a clearance of none lets them all be (:func:`_picks_shut_at`; the 5-DOF
    arm's at 9 cm: 3.90 cm let a held object into every bin, and its own table sorted 0 of
    9, each pick's jaws within it of a neighbour). Only a clearance above the default is
    checked: the shipped configs' own sorts place every object at theirs, and the check
    costs a plan per object (some 60–130 ms). A place refused at no clearance at all is out
    of reach, not shut by the clearance: the sort's own lines say so (``bin out of reach``).
    """
    clearance_cm = config.task.clearance_cm
    if clearance_cm <= TaskConfig.model_fields["clearance_cm"].default:
        return []
    starts = _place_starts(config, model)
    shut = _place_shut_at(config, model, clearance_cm, starts)
    if shut is None or _place_shut_at(config, model, 0.0, starts) is not None:
        return []
    # the clearance named lets the table's picks through too, where none does at 0: at
    # the most a place allowed, 3.90 cm, the 5-DOF arm's own table (9 objects) sorted 0 of
    # 9, each pick's jaws within it of a neighbour
    picks = _picks_shut_at(config, model, 0.0) is None

    def opens(cents: int) -> bool:
        clearance = cents / 100
        if _place_shut_at(config, model, clearance, starts) is not None:
            return False
        return not picks or _picks_shut_at(config, model, clearance) is None

    good, bad = 0, math.ceil(clearance_cm * 100)
    while bad - good > 1:
        mid = (good + bad) // 2
        if opens(mid):
            good = mid
        else:
            bad = mid
    return [
        f"task.clearance_cm: {clearance_cm:g} cm leaves the arm no way into {shut}'s bin with "
        f"one held: at most {good / 100:.2f} cm{' (its picks of task.scene too)' if picks else ''}"
        ", or move the bin"
        f"{_walls_built(config, collision, shut)}"
    ]


def _place_starts(config: Config, model: ArmModel) -> list[tuple[str | None, np.ndarray]]:
    """Where the sort plans places from: home, and the pick of each object of the table.

    ``(class, pose)`` each: a pick's place is planned into its own class's bin only, as the
    sort plans it; home's (``None``) into every bin.
    """
    planner = Planner(config, model)
    starts: list[tuple[str | None, np.ndarray]] = [(None, np.asarray(model.home, dtype=float))]
    for obj in config.task.scene:
        cls = config.task.class_named(obj.color)
        pick = Route(cls.name, cls.name, "pick", 1, planner.pick_target(cls, obj.x, obj.y))
        planner.plan(pick, model.home)
        if pick.planned and pick.plan is not None:
            starts.append((cls.name, np.asarray(pick.plan.q, dtype=float)))
    return starts


def _picks_shut_at(config: Config, model: ArmModel, clearance_cm: float) -> str | None:
    """The first object of the config's own table whose pick from home is refused, or ``None``.

    Each pick is planned at ``clearance_cm`` with every other object of the table on it, the
    jaws open, as the sort's first look finds them.
    """
    collision, planner = _planner_at(config, model, clearance_cm)
    objects = [(f"o{i}", o.color, o.x, o.y) for i, o in enumerate(config.task.scene)]
    for i, obj in enumerate(config.task.scene):
        cls = config.task.class_named(obj.color)
        collision.set_world(
            objects[:i] + objects[i + 1 :], opening_cm=config.arm.tool.gripper.open_cm, held=None
        )
        route = Route(f"o{i}", cls.name, "pick", 1, planner.pick_target(cls, obj.x, obj.y))
        if not planner.plan(route, model.home).planned:
            return f"o{i}"
    return None


def _planner_at(
    config: Config, model: ArmModel, clearance_cm: float
) -> tuple[CollisionModel, Planner]:
    """The collision model and planner a sort of ``config`` at ``clearance_cm`` plans with.

    The config's bins and walls, its ``task.clearance_cm`` replaced: the checks that look
    for the most clearance that works try each figure as the sort would plan at it.
    """
    task = config.task.model_copy(update={"clearance_cm": clearance_cm})
    lowered = config.model_copy(update={"task": task})
    collision = collision_model(lowered, model, clearance_cm=clearance_cm)
    return collision, Planner(lowered, model, collision)


def _place_shut_at(
    config: Config,
    model: ArmModel,
    clearance_cm: float,
    starts: Sequence[tuple[str | None, np.ndarray]],
) -> str | None:
    """The first class no place into whose bin is planned at ``clearance_cm``, or ``None``.

    The one answer to "does a place into this bin, from there, plan at this clearance",
    for a clearance too much at home (:func:`_clearance_into_bins`: from home alone) and
    one the arm keeps there (:func:`_clearance_shuts_bin`: from home and the table's
    picks). Each place is planned from each of ``starts`` whose class is ``None`` or its
    own, one object of its class held, against the bins alone, with its release, as the
    sort plans it (:meth:`~mearm.task.plan.Planner.plan_place`: the jaws open clear of the
    walls and have a way up). A clearance is named only where this finds no bin shut: at
    0.11 cm, the most the arm kept at home from the walls a belt's 500 arrivals grew
    (``belt.arrivals.count=500``: 170 cm for 169 reds, 179 cm for 178 greens), a refusal
    had named it, and the sort then refused it, no way into the green bin; the red one
    is shut there too, its place planned but the jaws opened in it with no way up past
    its walls, as a place without its release did not tell.

    Args:
        config: The config; its ``task.clearance_cm`` is replaced by ``clearance_cm``.
        model: Its arm.
        clearance_cm: The clearance planned at [cm].
        starts: ``(class, pose)`` each (:func:`_place_starts`): where places are planned
            from, ``None`` for every class's.

    Returns:
        The name of the first class (in the config's order) one of whose places is
        refused; ``None``: every one is planned.
    """
    collision, planner = _planner_at(config, model, clearance_cm)
    for cls in config.task.classes:
        for _, q in (start for start in starts if start[0] in (None, cls.name)):
            collision.set_world([], opening_cm=cls.diameter_cm, held=(cls.name, cls.name))
            route = Route(cls.name, cls.name, "place", 1, planner.place_target(cls))
            if not planner.plan_place(route, q).planned:
                return cls.name
    return None


def _clearance_into_bins(
    config: Config, model: ArmModel, home_cm: float
) -> tuple[float | None, str | None]:
    """The most clearance the arm keeps at home and gets into every bin with; what shuts one.

    ``home_cm``: the least the arm keeps from a bin at home. ``(None, None)``: its figure
    (:func:`_cm_down`) lets the arm into every bin; ``(most, name)``: a lower one does,
    ``most`` [cm] to two decimals (found by halving, each tried: :func:`_place_shut_at`,
    a place of each class from home), and ``name``'s bin is shut at the figure; ``(None,
    name)``: none does.
    """
    home = [(None, np.asarray(model.home, dtype=float))]
    cents = math.floor((home_cm - TOUCH_CM) * 100)  # (a check keeps TOUCH_CM more)
    shut = _place_shut_at(config, model, cents / 100, home)
    if shut is None:
        return None, None
    if _place_shut_at(config, model, 0.0, home) is not None:
        return None, shut
    good, bad = 0, cents
    while bad - good > 1:
        mid = (good + bad) // 2
        if _place_shut_at(config, model, mid / 100, home) is None:
            good = mid
        else:
            bad = mid
    return good / 100, shut


def too_little_spare(distance_cm: float, config: Config) -> str:
    """A distance the arm at home keeps from a bin, over ``task.clearance_cm`` by too little.

    The clearance holds there, but not the :data:`TOUCH_CM` a check keeps beyond it
    (:func:`bins_near_home`): the words a refusal says it with.
    """
    c = config.task.clearance_cm
    return (
        f"{distance_cm:.4f} cm, {distance_cm - c:.4f} cm over task.clearance_cm ({c:g} cm), "
        f"less than the {TOUCH_CM:g} cm the checks keep beyond it"
    )


def _cm_down(distance_cm: float) -> str:
    """A distance [cm] to two decimals, rounded down: the most clearance that holds.

    Rounded to the nearest, the arm's 3.308 cm from the paper's red bin read "at most
    3.31 cm", and a clearance of 3.31 cm was then refused in turn.
    """
    return f"{math.floor(distance_cm * 100) / 100:.2f}"


def _walls_built(config: Config, collision: CollisionModel, name: str) -> str:
    """How tall a bin's walls are built, where the objects of its class decide it.

    A class's objects' height or number raises its bin's walls (built to hold them
    stacked: :func:`~mearm.kinematics.bodies.wall_height_m`), and a user who changed
    ``height_cm`` read only that the clearance was too much.
    """
    cls = config.task.class_named(name)
    if cls.bin_height_cm is not None:
        return ""
    n = collision.table.objects(name)
    wall_cm = wall_height_m(cls, n) / M_PER_CM
    # a belt's objects are its arrivals: their count is what the user sets
    fewer = (
        "fewer objects (belt.arrivals.count) or lower ones"
        if config.belt is not None
        else "fewer or lower objects"
    )
    return (
        f", or lower its walls: {wall_cm:.3g} cm, built to hold its {n} objects "
        f"({cls.height_cm:g} cm high) stacked ({fewer}, or "
        f"task.classes.{name}.bin_height_cm)"
    )


def _walls_grown(config: Config, collision: CollisionModel, name: str) -> str:
    """:func:`_walls_built`, where the objects grow the walls past the least they are built.

    Walls at their least (:data:`~mearm.kinematics.bodies.BIN_MIN_WALL_HEIGHT_M`) stand so
    whatever the table holds: neither fewer nor lower objects lower them, and nothing is
    said of them.
    """
    cls = config.task.class_named(name)
    if wall_height_m(cls, collision.table.objects(name)) <= BIN_MIN_WALL_HEIGHT_M:
        return ""
    return _walls_built(config, collision, name)


def bins_near_home(
    config: Config, model: ArmModel, collision: CollisionModel
) -> Iterator[tuple[str, str, float]]:
    """The bins the arm at home keeps less than ``task.clearance_cm`` from, or touches.

    ``(class, arm part, distance [cm])`` per such bin, as ``collision`` builds the bins
    (their walls as tall as the table it was built for makes them:
    :func:`~mearm.kinematics.bodies.wall_height_m`). Every run starts and ends at home.
    Less than the clearance as the way home counts it: with :data:`TOUCH_CM` to spare
    (:meth:`~mearm.kinematics.collision.CollisionModel.first_contact`); a belt's walls
    grown to 0.30094 cm from the paper arm's jaws at home passed a clearance of 0.3 cm
    here, and the sort then stopped after its first object, not parked.
    """
    for name, part, distance in collision.bins_at(model.home):
        if distance < config.task.clearance_cm + TOUCH_CM or distance <= TOUCH_CM:
            yield name, part, distance


def _check_home_above_table(
    config: Config, model: ArmModel, collision: CollisionModel
) -> list[str]:
    """At home, every part of the tool (jaws open, their servo, the hand) is above the table.

    Every run starts and ends at home, and the arm goes there first: a home under the
    table would drive the tool into it.
    """
    low_cm, part = collision.tool_lowest_cm(model.home)
    if low_cm >= 0.0:
        return []
    home = ", ".join(f"{j.name} {j.home:g}" for j in config.arm.joints if j.home is not None)
    return [
        f"arm.joints[].home: at home ({home}) the tool's {part} is {-low_cm:.2f} cm below "
        "the table (z = 0): every part of the tool must be above it; choose a home that "
        "holds the tool up"
    ]


def _view_points_cm(config: Config) -> np.ndarray:
    """Table points [cm] on a grid over the camera's image, (N, 2)."""
    nu, nv = VIEW_GRID
    w, h = config.camera.width_px, config.camera.height_px
    u, v = np.meshgrid(np.linspace(0, w - 1, nu), np.linspace(0, h - 1, nv))
    pixels = np.column_stack([u.ravel(), v.ravel()])
    return camera_geometry(config.calibration, config.camera).pixel_to_table(pixels)


def _box_points_cm(config: Config) -> np.ndarray:
    """Points (x, y) [cm] on a grid over the target box, (N, 2)."""
    box = config.arm.target_box
    nu, nv = VIEW_GRID
    x, y = np.meshgrid(
        np.linspace(box.x_cm.min, box.x_cm.max, nu), np.linspace(box.y_cm.min, box.y_cm.max, nv)
    )
    return np.column_stack([x.ravel(), y.ravel()])


def _reached_somewhere(
    planner: Planner, model: ArmModel, class_name: str, points_cm: np.ndarray
) -> bool:
    """Whether a pick at any of the points is planned from home.

    The point nearest the points' middle is tried alone first: it is usually reached, and
    then the batch solve of the others, whose unreachable points each run every
    iteration of it, is never needed (a point's answer depends on no other point).
    """
    if len(points_cm) == 0:
        return False
    order = np.argsort(np.linalg.norm(points_cm - points_cm.mean(axis=0), axis=1), kind="stable")
    parts = (order[:1], order[1:])
    return any(
        any(_reached(planner, model, class_name, points_cm[part])) for part in parts if len(part)
    )


def _reached(
    planner: Planner, model: ArmModel, class_name: str, points_cm: np.ndarray
) -> Iterator[bool]:
    """Whether a pick at each point is planned from home, one point at a time.

    ``any`` of it stops at the first point reached. A point no joints reach, with a
    margin (:meth:`Planner.reaches <mearm.task.plan.Planner.reaches>`), is not planned:
    its multi-start recovery would only fail, slowly.
    """
    cls = planner.config.task.class_named(class_name)
    targets = [planner.pick_target(cls, float(x), float(y)) for x, y in points_cm]
    for target, ok in zip(targets, planner.reaches(targets).tolist(), strict=True):
        if not ok:
            yield False
            continue
        route = Route("", class_name, "pick", 1, target)
        yield planner.plan(route, model.home).planned
