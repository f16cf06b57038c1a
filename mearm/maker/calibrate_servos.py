"""``mearm calibrate-servos``: fit each servo's pulse calibration by jogging it with the keyboard.

    mearm calibrate-servos --config my.yaml [--port /dev/ttyACM0] [--output my.servos.yaml]
        [--actuators shoulder,elbow] [--force]
    mearm calibrate-servos --camera --config my.yaml [--simulate] [--output …] [--force]

With ``--camera`` no keys are pressed: the arm visits points over the table by itself and
the calibrated camera's view of the marker on the claw fits every joint servo
(:mod:`mearm.maker.calibrate_by_camera`; docs/servos.md). The rest of this docstring is
the keyboard procedure.

For each actuator (the actuated joints, the tool actuators, then the gripper) the screen
shows two reference values chosen from its limits (a fifth of the range in from each
end, on a 5° or 0.5 cm grid). Jog the actuator with the keys until it is at the shown
value — by eye, a protractor or a ruler — and press Enter; after the second the zero,
µs per unit and direction are fitted (:mod:`mearm.config.servo_file`) and checked: a
µs per unit more than 30 % off the arm's own, or limits (for a servo that turns a
combination: the joint's limits with the other joints at home) that the fit puts
outside the servo's pulse range, are refused with the reason, as is anything the
config's own checks refuse; a refused fit is never written, the actuator is done again.

A joint servo that turns a combination of joints (its ``drives``: the MeArm's elbow servo
turns the forearm's angle to the table, shoulder + elbow) is calibrated on that
combination: the references are values of it, chosen from the range it takes over the
joints' limits, within what the present calibration's pulse range reaches, and the
screen asks for the combination (``shoulder + elbow = 45 deg``), not for the joint.

Before a joint's references the other joints are moved, if need be, to where both
references keep every joint inside its limits (the screen says so): the MeArm's elbow
servo, asked for ``shoulder + elbow = -45 deg`` with the shoulder at 120°, would put
the elbow past its stop, and then turn the shoulder instead of the forearm.

Keys: ``+``/``-`` or →/← move by the step; ↑/↓ or ``1``/``2``/``3`` set the step (1, 5,
20 µs); Enter or Space records the reference; Backspace goes back to the previous one;
``s`` skips the actuator (its calibration stays as configured); ``q`` stops without
writing anything.

Every pulse sent lies inside the actuator's ``[min_us, max_us]``, whatever keys are
pressed (the keys stop at the ends, and the servo bus refuses anything outside). The
session starts by sending every actuator its home value under the present calibration,
then only changes the actuator being calibrated (and, before a joint's references, the
other joints as above).

The calibration file is written at the end, atomically, only if at least one actuator
was calibrated and every fit passes its checks again, all together (else exit 1,
nothing written). With ``--simulate`` no one is there to redo a fit: one refused twice
ends the command with exit 1 and nothing written (no partial file). An existing file
is replaced only after a y/N question (or with ``--force``/``--yes``), and only if it
is a servo calibration; the old one is kept as ``<name>.bak``. Ctrl-C writes nothing
and leaves the arm where it is (exit 130); ``q`` writes nothing (exit 1). Needs a
terminal: without one, exit 2 before anything opens.

A config uses the file through ``servo.calibration_file`` (relative to the config's
folder); the command prints that line, and the equivalent ``--set`` overrides.
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import math
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from mearm.backends import open_bus
from mearm.cli import (
    EXIT_FAILURE,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    run,
    seed_value,
)
from mearm.config import Config
from mearm.config.servo_file import (
    ActuatorFit,
    CalibrationPoint,
    ServoCalibrationError,
    apply_servo_calibration,
    check_fit,
    check_replace,
    fit_actuator,
    fit_span,
    replaced_calibration,
    servo_of,
)
from mearm.errors import ConfigError, MearmError
from mearm.hardware import ActuatorMap, ArmCommand, ServoBus, ServoMap
from mearm.hardware.errors import ServoError
from mearm.maker.keys import KeyReader, require_terminal
from mearm.maker.servo_output import board_identity, check_output, hold_arm, write_calibration

#: The step sizes the keys choose from [µs].
STEPS_US = (1, 5, 20)
#: Reference values lie this fraction of the limit range in from each end [-].
REFERENCE_INSET = 0.2
#: Reference values are rounded to this grid, per unit.
REFERENCE_GRID = {"deg": 5.0, "cm": 0.5}
#: At a joint's references every joint stays this share of its range inside its limits:
#: a joint on its stop no longer follows its servo (the MeArm's elbow servo, its joint
#: stopped, turns the shoulder instead).
POSE_INSET = 0.05
#: Values tried across each other joint servo's span for a pose that keeps the joints
#: inside their limits, when where it is, its home and its references do not.
POSE_GRID = 9


class Abandoned(MearmError):
    """The user stopped the session with ``q``: nothing is written."""


def reference_values(lower: float, upper: float, unit: str) -> tuple[float, float]:
    """Two reference values inside ``[lower, upper]``, a fifth of the range in from each end.

    Rounded to :data:`REFERENCE_GRID` when the rounded values stay inside the limits and
    apart; otherwise exact.
    """
    span = upper - lower
    a, b = lower + REFERENCE_INSET * span, upper - REFERENCE_INSET * span
    grid = REFERENCE_GRID.get(unit, 1.0)
    ra, rb = round(a / grid) * grid, round(b / grid) * grid
    if lower <= ra < rb <= upper:
        return (float(ra), float(rb))
    return (float(a), float(b))


@dataclasses.dataclass(frozen=True)
class Actuator:
    """One actuator to calibrate: its map (with the present calibration) and references.

    Attributes:
        name: The actuator's name.
        kind: ``joint``, ``tool`` or ``gripper``.
        amap: Its map under the present calibration.
        references: The two servo values to jog it to.
        lower: The lowest value its servo takes (its limits, or its combination's range).
        upper: The highest.
    """

    name: str
    kind: str  # joint, tool or gripper
    amap: ActuatorMap
    references: tuple[float, float]
    lower: float = -math.inf
    upper: float = math.inf

    @property
    def what(self) -> str:
        """What the references are values of: the name, or the combination its servo turns."""
        return self.amap.combination_text


def servo_span(smap: ServoMap, amap: ActuatorMap) -> tuple[float, float]:
    """The values an actuator's servo is calibrated over [unit].

    Its limits; for a servo that turns a combination, the range the combination takes over
    the joints' limits, cut to what the present calibration's pulse range reaches (where
    the two overlap).
    """
    if not amap.combined:
        return (amap.lower, amap.upper)
    lo, hi = smap.servo_range(amap.name)
    plo, phi = amap.pulse_limits
    if max(lo, plo) < min(hi, phi):
        lo, hi = max(lo, plo), min(hi, phi)
    return (lo, hi)


def actuators_of(config: Config) -> list[Actuator]:
    """Every actuator of the arm, in calibration order: joints, tool actuators, gripper."""
    return actuators_of_map(ServoMap.from_config(config))


def actuators_of_map(smap: ServoMap) -> list[Actuator]:
    """:func:`actuators_of` an arm's servos."""
    out = []
    for kind, maps in (("joint", smap.joints), ("tool", smap.tool), ("gripper", (smap.gripper,))):
        for a in maps:
            lo, hi = servo_span(smap, a)
            out.append(Actuator(a.name, kind, a, reference_values(lo, hi, a.unit), lo, hi))
    return out


def joints_overrun(smap: ServoMap, values: Mapping[str, float]) -> float:
    """How far the joints these joint-servo values set lie outside their limits.

    Each limit taken :data:`POSE_INSET` of the range in; the worst joint's distance past
    it, as a share of its range (0 or less: every joint inside).
    """
    q = smap.joints_of(values)
    worst = -math.inf
    for j in smap.joints:
        span = j.upper - j.lower
        lo, hi = j.lower + POSE_INSET * span, j.upper - POSE_INSET * span
        worst = max(worst, (lo - q[j.name]) / span, (q[j.name] - hi) / span)
    return worst


def pose_overrun(smap: ServoMap, act: Actuator, others: Mapping[str, float]) -> float:
    """:func:`joints_overrun` at the worse of ``act``'s references, the others at ``others``."""
    return max(joints_overrun(smap, {**others, act.name: r}) for r in act.references)


def _moved_with(smap: ServoMap, name: str) -> list[str]:
    """The other joint servos that set a joint which ``name``'s servo moves too."""
    m = smap.combination
    if m is None:  # every servo turns its own joint: no other shares one
        return []
    turns = np.abs(np.linalg.inv(m[0])) > 1e-9  # joint r ← servo c
    names = smap.joint_names
    k = names.index(name)
    moved = [r for r in range(len(names)) if turns[r, k]]
    return [n for c, n in enumerate(names) if c != k and any(turns[r, c] for r in moved)]


def pose_settings(
    choices: Mapping[str, Sequence[float]], fixed: Mapping[str, float] | None = None
) -> list[dict[str, float]]:
    """Every setting of the other joint servos: each of ``choices``, the rest ``fixed``.

    In ``itertools.product`` order: the first choice of each servo first.
    """
    rest = dict(fixed or {})
    return [
        {**rest, **dict(zip(choices, s, strict=True))} for s in itertools.product(*choices.values())
    ]


def poses_inside(
    smap: ServoMap,
    act: Actuator,
    choices: Mapping[str, Sequence[float]],
    fixed: Mapping[str, float] | None = None,
) -> list[dict[str, float]]:
    """The settings of the other joint servos that keep the joints inside at both references.

    Args:
        smap: The arm's servos (the present calibration).
        act: The joint actuator to be calibrated.
        choices: Other joint servos → their candidate values, preferred first.
        fixed: The other joint servos not in ``choices`` → their values.

    Returns:
        Every setting (:func:`pose_settings`) whose :func:`pose_overrun` is not
        positive, the preferred first; maybe none.
    """
    return [s for s in pose_settings(choices, fixed) if pose_overrun(smap, act, s) <= 0]


def reference_pose(
    smap: ServoMap, act: Actuator, present: Mapping[str, float], home: Mapping[str, float]
) -> dict[str, float]:
    """Where the other joint servos go before a joint's references are taken.

    Where they are, if that keeps every joint inside its limits at both references
    (:func:`pose_overrun`); else the first setting that does, trying for each servo
    that shares a joint with this one its present value, its home, its references and
    :data:`POSE_GRID` values across its span (the rest stay); else the setting of those
    that overruns least.

    Args:
        smap: The arm's servos (the present calibration).
        act: The joint actuator to be calibrated.
        present: Every other joint servo's present value.
        home: Every joint servo's value at home.
    """
    now = dict(present)
    if pose_overrun(smap, act, now) <= 0:
        return now
    shared = _moved_with(smap, act.name)
    choices = {
        o.name: list(
            dict.fromkeys(
                [now[o.name], home[o.name], *o.references]
                + np.linspace(o.lower, o.upper, POSE_GRID).tolist()
            )
        )
        for o in actuators_of_map(smap)
        if o.name in shared
    }
    inside = poses_inside(smap, act, choices, now)
    if inside:
        return inside[0]
    return min(pose_settings(choices, now), key=lambda s: pose_overrun(smap, act, s))


class PulseSession:
    """Drives a servo bus in pulses: each actuator holds a pulse [µs] the keys change.

    The bus's map is replaced by one whose limits are each actuator's whole pulse range
    (its calibration is what is being measured), so any pulse in ``[min_us, max_us]`` can
    be commanded and nothing outside can. A pulse is sent as the value the present
    calibration gives it, which the bus turns back into the same integer pulse; the
    joints are solved from the joint servos' values (:meth:`ServoMap.joints_of`: a servo
    that turns a combination of joints is set by that combination, the joint it sits in
    left free of its limits); the gripper, commanded open or closed, gets a map whose
    "open" is the pulse.

    Args:
        config: The whole configuration (the present calibration).
        bus: The servo bus, connected.
    """

    def __init__(self, config: Config, bus: ServoBus):
        self.config = config
        self.bus = bus
        original = ServoMap.from_config(config)
        self._original = original

        def widened(a: ActuatorMap) -> ActuatorMap:
            # no play compensated: the references are taken from both sides
            if a.combined:  # its pulse range bounds the combination, not this joint
                return dataclasses.replace(a, lower=-math.inf, upper=math.inf, play_us=0.0)
            lo, hi = a.pulse_limits
            return dataclasses.replace(a, lower=lo, upper=hi, play_us=0.0)

        self._joints = tuple(widened(a) for a in original.joints)
        self._tool = tuple(widened(a) for a in original.tool)
        home = original.servo_values(config.arm.home())
        tool_home = {t.name: t.home for t in config.arm.tool.actuators}
        self.home_values = home
        self.pulses_us: dict[str, int] = {
            j.name: j.command_us(home[j.name]) for j in original.joints
        }
        self.pulses_us.update({t.name: t.command_us(tool_home[t.name]) for t in original.tool})
        g = original.gripper
        self.pulses_us[g.name] = g.command_us(original.gripper_open_cm)

    @property
    def servo_map(self) -> ServoMap:
        """The arm's servos under the present calibration (not the widened ones sent)."""
        return self._original

    def joint_values(self) -> dict[str, float]:
        """Each joint servo's value now: its pulse under the present calibration [unit]."""
        return {a.name: a.value_of(self.pulses_us[a.name]) for a in self._original.joints}

    def limits_us(self, name: str) -> tuple[int, int]:
        """The pulse range of an actuator [µs]."""
        a = self._original[name]
        return (a.min_us, a.max_us)

    def set_pulse(self, name: str, pulse_us: int) -> int:
        """Send ``pulse_us`` (kept inside the actuator's range) to one actuator; return it."""
        lo, hi = self.limits_us(name)
        pulse = min(hi, max(lo, int(pulse_us)))
        previous = self.pulses_us[name]
        self.pulses_us[name] = pulse
        try:
            self.send()
        except BaseException:
            self.pulses_us[name] = previous
            raise
        return pulse

    def send(self) -> None:
        """Send every actuator's present pulse in one command."""
        g0 = self._original.gripper
        p = self.pulses_us[g0.name]
        open_cm = self._original.gripper_open_cm
        gripper = dataclasses.replace(g0, zero_us=p - g0.direction * g0.us_per_unit * open_cm)
        smap = ServoMap(
            self._joints, self._tool, gripper, open_cm, self._original.gripper_closed_cm
        )
        self.bus.servo_map = smap
        joints = smap.joints_of({a.name: a.value_of(self.pulses_us[a.name]) for a in self._joints})
        tool = {a.name: a.value_of(self.pulses_us[a.name]) for a in self._tool}
        self.bus.move(ArmCommand(joints, tool, False))

    def simulated_value(self, name: str) -> float | None:
        """What a simulated arm realised for an actuator's servo, else ``None``.

        A joint servo's value: the joint's, or the combination it turns.
        """
        joints = getattr(self.bus, "actual_joints", None)
        if isinstance(joints, dict) and name in self._original.joint_names:
            try:
                return self._original[name].servo_value(joints)
            except KeyError:  # a joint the simulator does not report
                return None
        values = getattr(self.bus, "actual_tool", None)
        if isinstance(values, dict) and name in values:
            return float(values[name])
        return None


class Calibrator:
    """The interactive session: one actuator after another, keys in, a fit out.

    Args:
        config: The whole configuration.
        session: The pulse session on the connected bus.
        keys: Where keys come from (``None``: a subclass that jogs by itself).
        out: Where the screen goes.
    """

    def __init__(self, config: Config, session: PulseSession, keys: KeyReader | None, out: TextIO):
        self.config = config
        self.session = session
        self.keys = keys
        self.out = out
        self.step_index = 1
        # the arm's own calibration, before any file: what a fit's slope is compared with
        self.nominal_arm = (replaced_calibration(config) or config).arm

    def say(self, text: str = "") -> None:
        """Print a line (ending any live status line)."""
        self.out.write("\r\x1b[K" + text + "\n")
        self.out.flush()

    def status(self, act: Actuator, ref: float) -> None:
        """Rewrite the live status line."""
        p = self.session.pulses_us[act.name]
        lo, hi = self.session.limits_us(act.name)
        target = f"{act.what} = {ref:g}" if act.amap.combined else f"{ref:g}"
        text = (
            f"{act.name}: pulse {p} µs  step {STEPS_US[self.step_index]} µs  "
            f"[{lo}, {hi}] µs  target {target} {act.amap.unit}"
        )
        sim = self.session.simulated_value(act.name)
        if sim is not None:
            text += f"  simulated arm: {sim:.2f} {act.amap.unit}"
        if p in (lo, hi):
            text += "  (end of the pulse range)"
        self.out.write("\r\x1b[K" + text)
        self.out.flush()

    def calibrate(self, act: Actuator, number: int, total: int) -> ActuatorFit | None:
        """Jog one actuator to its references and fit it; ``None`` if skipped.

        Raises:
            Abandoned: ``q`` was pressed.
        """
        unit = act.amap.unit
        if act.amap.combined:
            span = (
                f"its servo turns {act.what}: [{act.lower:.4g}, {act.upper:.4g}] {unit} "
                "over the joints' limits and its pulse range"
            )
        else:
            span = f"limits [{act.amap.lower:g}, {act.amap.upper:g}] {unit}"
        self.say(
            f"[{number}/{total}] {act.name} ({act.kind}, channel {act.amap.channel}): "
            f"{span}; references {act.references[0]:g} and {act.references[1]:g} {unit}"
        )
        self.place_others(act)
        while True:
            points: list[CalibrationPoint] = []
            while len(points) < len(act.references):
                ref = act.references[len(points)]
                if act.amap.combined:
                    self.say(
                        f"move {act.name}'s servo until {act.what} = {ref:g} {unit}, then "
                        "press Enter"
                    )
                else:
                    self.say(f"move {act.name} to {ref:g} {unit}, then press Enter")
                outcome = self._jog_until_recorded(act, ref)
                if outcome == "skip":
                    self.say(f"{act.name}: skipped; its calibration stays as configured")
                    return None
                if outcome == "back":
                    if points:
                        points.pop()
                    continue
                pulse = self.session.pulses_us[act.name]
                points.append(CalibrationPoint(ref, pulse))
                self.say(f"recorded {act.name} at {ref:g} {unit}: {pulse} µs")
            try:
                arm = self.config.arm
                _, lo, hi = fit_span(arm, act.name)
                fit = fit_actuator(act.name, unit, servo_of(arm, act.name), points, (lo, hi))
                check_fit(arm, fit, servo_of(self.nominal_arm, act.name))
                apply_servo_calibration(self.config, [fit], source=f"the fit of {act.name}")
            except (ServoCalibrationError, ConfigError) as exc:
                self.refuse(act, exc)
                continue
            s = fit.servo
            what, lo, hi = fit_span(self.config.arm, act.name)
            self.say(
                f"{act.name}: zero {s.zero_us:.1f} µs, {s.us_per_unit:.3f} µs/{unit}, "
                f"direction {s.direction:+d}; {what} [{lo:.4g}, {hi:.4g}] {unit} → "
                f"[{s.pulse_us(lo):.0f}, {s.pulse_us(hi):.0f}] µs"
            )
            return fit

    def refuse(self, act: Actuator, exc: MearmError) -> None:
        """Say why a fit was refused; the references are done again."""
        self.say(f"{act.name}: fit refused: {exc}")
        self.say(f"do {act.name} again (or press s at a reference to skip it)")

    def place_others(self, act: Actuator) -> None:
        """Before a joint's references, move the other joints where they keep it clear.

        At a reference a joint on its stop would not follow its servo: the other joint
        servos go to :func:`reference_pose` (where they are, when that keeps every joint
        inside its limits at both references), and the screen says so.
        """
        if act.kind != "joint":
            return
        session = self.session
        smap = session.servo_map
        present = {n: v for n, v in session.joint_values().items() if n != act.name}
        pose = reference_pose(smap, act, present, session.home_values)
        moved = {n: v for n, v in pose.items() if smap[n].command_us(v) != session.pulses_us[n]}
        if not moved:
            return
        for n, v in moved.items():
            session.pulses_us[n] = smap[n].command_us(v)
        session.send()
        where = ", ".join(
            f"{smap[n].combination_text} to {v:.4g} {smap[n].unit}" for n, v in moved.items()
        )
        self.say(
            f"moved {where}: at {act.name}'s references every joint then stays inside its limits"
        )

    def _jog_until_recorded(self, act: Actuator, ref: float) -> str:
        """Handle keys until a reference is recorded (``record``), ``back`` or ``skip``."""
        if self.keys is None:
            raise MearmError("no keys to jog with")
        while True:
            self.status(act, ref)
            key = self.keys.read()
            step = STEPS_US[self.step_index]
            if key in ("+", "=", "right"):
                self.session.set_pulse(act.name, self.session.pulses_us[act.name] + step)
            elif key in ("-", "_", "left"):
                self.session.set_pulse(act.name, self.session.pulses_us[act.name] - step)
            elif key == "up":
                self.step_index = min(len(STEPS_US) - 1, self.step_index + 1)
            elif key == "down":
                self.step_index = max(0, self.step_index - 1)
            elif key in ("1", "2", "3"):
                self.step_index = int(key) - 1
            elif key in ("enter", "space"):
                return "record"
            elif key == "backspace":
                return "back"
            elif key == "s":
                return "skip"
            elif key == "q":
                raise Abandoned("stopped with q: nothing written")
            else:
                self.say(
                    "keys: +/- or →/← move, ↑/↓ or 1/2/3 step 1/5/20 µs, Enter record, "
                    "Backspace back, s skip, q quit"
                )


#: How long the twin runs after each pulse before the observer reads the arm [s].
SIM_SETTLE_S = 0.3
#: How far below the first guess (in pulse) the observer starts its last approach, so
#: every reference is approached from the same side, through any backlash [µs].
SIM_APPROACH_US = 30
#: The observer's default reading error, one standard deviation: a protractor read by
#: eye [deg], a ruler across the jaws [cm].
READING_ERROR = {"deg": 0.5, "cm": 0.05}


class FitRefused(MearmError):
    """A fit the checks refuse ended the session: nothing is written (exit 1)."""


class SimulatedCalibrator(Calibrator):
    """The maker's procedure with the twin as the maker: it jogs and reads, no keys.

    At each reference the observer does what a maker at the keys does: it sends pulses
    and reads the arm — the twin's measured joint (or the combination its servo turns,
    or the jaws' opening) where a maker reads a protractor or a ruler, its reading off
    by a seeded normal error of ``reading_error[unit]`` (one standard deviation, fixed
    per reference: the maker believes the arm is at the reference when it is at the
    reference plus that error). It jumps near the reference with the present
    calibration's slope, then approaches it 1 µs at a time twice: from
    :data:`SIM_APPROACH_US` below, up to the first pulse whose reading reaches the
    reference, and from as far above, down to the first whose reading reaches it; it
    records the pulse midway between the two. One approach alone records where the
    reading lags the pulse by half the gears' backlash and up to the dead band (the
    servo ignores steps within its dead band, then jumps): a bias of about 1° of
    shaft, toward the side approached from, which the arm does not have in use,
    where its moves come from either side and each clears the dead band; the two
    lags cancel in the middle. The fit, its checks and the file are the interactive
    command's.

    The tool actuators (the paper's ``gripper_arm``) have no joint in the twin: they are
    skipped, their calibration stays as configured.

    Args:
        config: The whole configuration.
        session: The pulse session on the twin (:class:`~mearm.sim.twin.twin_bus.TwinArm`).
        out: Where the log of the session goes.
        reading_error: The reading error by unit (``deg``, ``cm``), one std.
        seed: The reading errors' seed.
    """

    def __init__(
        self,
        config: Config,
        session: PulseSession,
        out: TextIO,
        reading_error: dict[str, float] | None = None,
        seed: int = 0,
    ):
        super().__init__(config, session, None, out)
        self.reading_error = dict(READING_ERROR if reading_error is None else reading_error)
        self.rng = np.random.default_rng(seed)
        self.reads = 0
        self.refused = 0

    def read(self, act: Actuator, pulse_us: int) -> float:
        """Send ``pulse_us`` to the actuator, let the twin settle, read the arm."""
        self.session.set_pulse(act.name, pulse_us)
        bus = self.session.bus
        bus.settle(SIM_SETTLE_S)  # type: ignore[attr-defined]
        self.reads += 1
        if act.kind == "gripper":
            return float(bus.opening_cm)  # type: ignore[attr-defined]
        value = self.session.simulated_value(act.name)
        if value is None:
            raise MearmError(f"the twin does not report {act.name}'s position")
        return value

    def calibrate(self, act: Actuator, number: int, total: int) -> ActuatorFit | None:
        """As :meth:`Calibrator.calibrate`; a tool actuator the twin lacks is skipped."""
        if act.kind == "tool":
            self.say(f"{act.name}: not simulated by the twin; its calibration stays as configured")
            return None
        if act.kind == "joint":
            self.clear_pose(act)
        self.refused = 0
        return super().calibrate(act, number, total)

    def refuse(self, act: Actuator, exc: MearmError) -> None:
        """As :meth:`Calibrator.refuse`; refused a second time, the session ends.

        Raises:
            FitRefused: the actuator's fit was refused twice.
        """
        self.refused += 1
        if self.refused >= 2:
            raise FitRefused(f"{act.name}'s fit refused twice: {exc}")
        super().refuse(act, exc)

    def clear_pose(self, act: Actuator) -> None:
        """Put the other joints where the actuator's sweep keeps the arm highest.

        A maker lifts the arm out of the way of the table first: among the other joint
        servos' present values and references, the setting whose lower TCP height over
        the actuator's two references (under the present calibration) is highest, of
        those that keep every joint inside its limits there (:func:`poses_inside`;
        if none does, :func:`reference_pose`).
        """
        session = self.session
        smap = session.servo_map
        now = session.joint_values()
        others = [a for a in actuators_of_map(smap) if a.kind == "joint" and a.name != act.name]
        choices = {a.name: list(dict.fromkeys([now[a.name], *a.references])) for a in others}
        settings = poses_inside(smap, act, choices) or [
            reference_pose(smap, act, {n: now[n] for n in choices}, session.home_values)
        ]
        bus = session.bus
        best: tuple[float, tuple[int, ...]] | None = None
        for values in settings:
            setting = tuple(smap[a.name].command_us(values[a.name]) for a in others)
            for a, p in zip(others, setting, strict=True):
                self.session.pulses_us[a.name] = p
            low = math.inf
            for ref in act.references:
                self.session.set_pulse(act.name, act.amap.command_us(ref))
                bus.settle(SIM_SETTLE_S)  # type: ignore[attr-defined]
                low = min(low, float(bus.ee_cm[2]))  # type: ignore[attr-defined]
            if best is None or low > best[0]:
                best = (low, setting)
        assert best is not None
        for a, p in zip(others, best[1], strict=True):
            self.session.pulses_us[a.name] = p
        self.session.send()
        bus.settle(SIM_SETTLE_S)  # type: ignore[attr-defined]

    def _jog_until_recorded(self, act: Actuator, ref: float) -> str:
        """Jog the twin's actuator until its reading is at ``ref``; always ``record``."""
        seen = ref + float(self.rng.normal(0.0, self.reading_error.get(act.amap.unit, 0.0)))
        lo, hi = self.session.limits_us(act.name)
        slope = act.amap.direction * act.amap.us_per_unit  # µs per unit, as configured

        def clip(p: float) -> int:
            return int(min(hi, max(lo, round(p))))

        pulse = clip(act.amap.pulse_us(ref))
        for _ in range(8):  # jump near it, as a maker does with the 20 and 5 µs steps
            step = clip(pulse + (seen - self.read(act, pulse)) * slope) - pulse
            pulse += step
            if abs(step) <= 2:
                break
        up = self._approach(act, seen, pulse, 1, slope, (lo, hi))
        down = self._approach(act, seen, pulse, -1, slope, (lo, hi))
        p = clip((up + down) / 2)
        self.session.set_pulse(act.name, p)
        self.say(
            f"{act.name}: read {ref:g} {act.amap.unit} at {up} µs from below, {down} µs "
            f"from above: {p} µs"
        )
        return "record"

    def _approach(
        self,
        act: Actuator,
        seen: float,
        pulse: int,
        way: int,
        slope: float,
        limits: tuple[int, int],
    ) -> int:
        """The first pulse whose reading reaches ``seen``, stepping 1 µs in ``way`` (±1).

        It starts :data:`SIM_APPROACH_US` before ``pulse`` (farther while the reading
        there is already past the reference), so the gears' play is taken up on the way.
        """
        lo, hi = limits
        rising = way * (1.0 if slope > 0 else -1.0)  # the reading's sign of change

        def reached(value: float) -> bool:
            return rising * (value - seen) >= 0

        p = int(min(hi, max(lo, pulse - way * SIM_APPROACH_US)))
        for _ in range(4):
            if not reached(self.read(act, p)) or p in (lo, hi):
                break
            p = int(min(hi, max(lo, p - way * SIM_APPROACH_US)))
        start = p
        while lo < p < hi or p == start:
            nxt = p + way
            if not lo <= nxt <= hi or abs(nxt - start) > 6 * SIM_APPROACH_US:
                break
            p = nxt
            if reached(self.read(act, p)):
                break
        return p


def default_output(config_path: Path | None) -> Path:
    """``<config>.servos.yaml`` beside the config, or ``servos.yaml`` here."""
    if config_path is None:
        return Path("servos.yaml")
    return config_path.with_name(config_path.stem + ".servos.yaml")


def build_parser() -> ArgumentParser:
    """The command's arguments."""
    parser = ArgumentParser(
        prog="mearm calibrate-servos",
        description=(
            "Fit each servo's zero, µs per degree and direction: jog it with the keyboard "
            "to two reference angles shown on screen. Writes a servo calibration file."
        ),
    )
    add_config_argument(parser)
    parser.add_argument("--port", default=None, help="serial port (default: servo.port)")
    parser.add_argument(
        "--output",
        type=Path,
        default=None,
        help="calibration file to write (default: <config>.servos.yaml beside the config)",
    )
    parser.add_argument(
        "--actuators",
        default=None,
        metavar="NAMES",
        help="comma-separated actuators to calibrate (default: every one)",
    )
    parser.add_argument(
        "--force",
        "--yes",
        action="store_true",
        help="replace an existing calibration file without asking (the old one → .bak)",
    )
    parser.add_argument(
        "--camera",
        action="store_true",
        help="fit every joint servo from where the calibrated camera sees the ArUco marker on "
        "the claw (arm.tool.marker; needs calibration.model: perspective), no keys: the arm "
        "visits points over the table by itself; with --simulate on the twin",
    )
    sim = parser.add_argument_group(
        "simulated (--simulate)",
        "the procedure run against the twin (simulator: mujoco; its twin.kit's servos): "
        "the twin jogs each actuator and reads it, as a maker with a protractor would",
    )
    sim.add_argument(
        "--simulate",
        action="store_true",
        help="run against the MuJoCo twin with no keys (needs simulator: mujoco)",
    )
    sim.add_argument(
        "--reading-error",
        type=reading_error,
        default=READING_ERROR["deg"],
        metavar="DEG",
        help=f"the simulated maker's reading error, one std [deg] (default "
        f"{READING_ERROR['deg']:g}: a protractor by eye)",
    )
    sim.add_argument(
        "--reading-error-cm",
        type=reading_error,
        default=READING_ERROR["cm"],
        metavar="CM",
        help=f"the same for the jaws' opening [cm] (default {READING_ERROR['cm']:g}: a ruler)",
    )
    sim.add_argument(
        "--reading-seed",
        type=seed_value,
        default=0,
        help="seed of the simulated reading errors (default 0)",
    )
    return parser


def reading_error(text: str) -> float:
    """An argparse type: a reading error, a finite number in [0, 10]."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"a reading error is a number, got {text[:40]!r}"
        ) from None
    if not (math.isfinite(value) and 0.0 <= value <= 10.0):
        raise argparse.ArgumentTypeError(f"a reading error lies in [0, 10], got {text[:40]!r}")
    return value


def _chosen(config: Config, names: str | None) -> list[Actuator]:
    every = actuators_of(config)
    if names is None:
        return every
    by_name = {a.name: a for a in every}
    chosen = []
    for name in (n.strip() for n in names.split(",")):
        if name not in by_name:
            raise MearmError(f"--actuators: no actuator {name!r}; this arm's: {', '.join(by_name)}")
        chosen.append(by_name[name])
    return chosen


def open_arm_bus(config: Config, port: str | None = None) -> ServoBus:
    """The config's servo bus, not connected; the ``sim`` backend gets a cleared table.

    Calibration turns each servo alone across its range, where the arm's body may sweep
    low over the table: it is done with the table cleared (no bins, no objects), and the
    simulated arm, which faults on whatever it touches, stands on a cleared table too.
    """
    world = None
    if config.servo.backend == "sim":
        from mearm.sim import World

        world = World()
    return open_bus(config, world, port=port)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command (see the module docstring); returns the exit status."""
    args = build_parser().parse_args(argv)
    config = config_from_args(args)
    output = args.output if args.output is not None else default_output(args.config)
    if args.camera:  # the camera's procedure (mearm.maker.calibrate_by_camera)
        from mearm.maker.calibrate_by_camera import calibrate_by_camera  # noqa: PLC0415

        return calibrate_by_camera(config, output, args)
    actuators = _chosen(config, args.actuators)
    if args.simulate:
        return simulate(config, actuators, output, args)
    require_terminal("calibrate-servos")
    out = sys.stdout
    with KeyReader() as keys:
        force = bool(args.force)
        if output.exists():
            if not force:
                check_replace(output)
                if not keys.confirm(f"{output} exists: replace it (the old one → .bak)?"):
                    print(f"kept {output}; nothing calibrated", file=sys.stderr)
                    return EXIT_FAILURE
            force = True
        bus = open_arm_bus(config, args.port)
        try:
            with bus:
                board, port = board_identity(bus)
                out.write(f"connected: {board}{' on ' + port if port else ''}\n")
                session = PulseSession(config, bus)
                session.send()
                calibrator = Calibrator(config, session, keys, out)
                fits: list[ActuatorFit] = []
                try:
                    for k, act in enumerate(actuators, 1):
                        fit = calibrator.calibrate(act, k, len(actuators))
                        if fit is not None:
                            fits.append(fit)
                except Abandoned:
                    calibrator.say("stopped: nothing written")
                    hold_arm(bus)
                    return EXIT_FAILURE
                except KeyboardInterrupt:
                    calibrator.say("interrupted: nothing written; the arm stays where it is")
                    hold_arm(bus)
                    raise
                except EOFError:
                    hold_arm(bus)
                    print(
                        "mearm calibrate-servos: the terminal closed: nothing written",
                        file=sys.stderr,
                    )
                    return EXIT_FAILURE
                hold_arm(bus)
        except ServoError as exc:
            print(f"mearm calibrate-servos: servo fault: {exc}; nothing written", file=sys.stderr)
            return EXIT_FAILURE
    return write_calibration(config, fits, board, port, output, force)


def simulate(
    config: Config, actuators: Sequence[Actuator], output: Path, args: argparse.Namespace
) -> int:
    """``--simulate``: the procedure against the twin (:class:`SimulatedCalibrator`).

    The twin stands on a cleared table (no objects) with the config's ``twin.kit``.

    Raises:
        MearmError: the config's simulator is not the twin, or the output exists and
            ``--force`` is not given.
    """
    if config.simulator != "mujoco":
        raise MearmError(
            f"--simulate runs against the MuJoCo twin: the config's simulator is "
            f"{config.simulator!r}; use one with simulator: mujoco (configs/sim_mujoco_kits.yaml)"
        )
    check_output(output, force=bool(args.force))
    from mearm.sim.twin.twin_bus import TwinArm  # noqa: PLC0415

    cleared = config.model_copy(update={"task": config.task.model_copy(update={"scene": []})})
    twin = TwinArm(cleared)
    kit = config.twin.kit
    board = "simulated: the MuJoCo twin" + (
        f", kit seed {kit.seed} spread {kit.spread:g}"
        + (f" trial {config.servo.error_model.seed}" if kit.per_trial else "")
        if kit is not None
        else ", nominal servos"
    )
    errors = {"deg": args.reading_error, "cm": args.reading_error_cm}
    out = sys.stdout
    fits: list[ActuatorFit] = []
    try:
        with twin:
            out.write(
                f"connected: {board}; reading error {errors['deg']:g} deg, "
                f"{errors['cm']:g} cm (seed {args.reading_seed})\n"
            )
            session = PulseSession(config, twin)
            session.send()
            twin.settle(1.0)
            calibrator = SimulatedCalibrator(config, session, out, errors, args.reading_seed)
            for k, act in enumerate(actuators, 1):
                fit = calibrator.calibrate(act, k, len(actuators))
                if fit is not None:
                    fits.append(fit)
    except ServoError as exc:
        print(f"mearm calibrate-servos: servo fault: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    except FitRefused as exc:  # no one to redo it: a partial file would look complete
        print(f"mearm calibrate-servos: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    nominal = replaced_calibration(config)
    if nominal is not None:  # recalibrating over a file: the twin's units stay relative
        # to what that file replaced, so the new file records the same
        fits = [dataclasses.replace(f, replaces=servo_of(nominal.arm, f.name)) for f in fits]
    return write_calibration(config, fits, board, "", output, bool(args.force))


if __name__ == "__main__":
    run(main)
