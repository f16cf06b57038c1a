"""``mearm calibrate-servos``: fit each servo's pulse calibration by jogging it with the keyboard.

    mearm calibrate-servos --config my.yaml [--port /dev/ttyACM0] [--output my.servos.yaml]
        [--actuators shoulder,elbow] [--force]

For each actuator (the actuated joints, the tool actuators, then the gripper) the screen
shows two reference values chosen from its limits (a fifth of the range in from each
end, on a 5° or 0.5 cm grid). Jog the actuator with the keys until it is at the shown
value — by eye, a protractor or a ruler — and press Enter; after the second the zero,
µs per unit and direction are fitted (:mod:`mearm.config.servo_file`) and checked
with the config's own checks: the limits, home and tool settings must map into the
servo's pulse range, else the actuator is done again.

A joint servo that turns a combination of joints (its ``drives``: the MeArm's elbow servo
turns the forearm's angle to the table, shoulder + elbow) is calibrated on that
combination: the references are values of it, chosen from the range it takes over the
joints' limits, within what the present calibration's pulse range reaches, and the
screen asks for the combination (``shoulder + elbow = 45 deg``), not for the joint.

Keys: ``+``/``-`` or →/← move by the step; ↑/↓ or ``1``/``2``/``3`` set the step (1, 5,
20 µs); Enter or Space records the reference; Backspace goes back to the previous one;
``s`` skips the actuator (its calibration stays as configured); ``q`` stops without
writing anything.

Every pulse sent lies inside the actuator's ``[min_us, max_us]``, whatever keys are
pressed (the keys stop at the ends, and the servo bus refuses anything outside). The
session starts by sending every actuator its home value under the present calibration,
then only ever changes the actuator being calibrated.

The calibration file is written at the end, atomically, only if at least one actuator
was calibrated. An existing file is replaced only after a y/N question (or with
``--force``/``--yes``), and only if it is a servo calibration; the old one is kept as
``<name>.bak``. Ctrl-C writes nothing and leaves the arm where it is (exit 130); ``q``
writes nothing (exit 1). Needs a terminal: without one, exit 2 before anything opens.

A config uses the file through ``servo.calibration_file`` (relative to the config's
folder); the command prints that line, and the equivalent ``--set`` overrides.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from mearm.backends import open_bus
from mearm.cli import (
    EXIT_FAILURE,
    EXIT_OK,
    ArgumentParser,
    add_config_argument,
    config_from_args,
    run,
)
from mearm.config import Config
from mearm.config.servo_file import (
    ActuatorFit,
    CalibrationPoint,
    ServoCalibrationError,
    ServoCalibrationFile,
    apply_servo_calibration,
    check_replace,
    fit_actuator,
    now_iso,
    save_servo_calibration,
    servo_of,
    servo_overrides,
)
from mearm.errors import ConfigError, MearmError
from mearm.hardware import ActuatorMap, ArmCommand, ServoBus, ServoMap
from mearm.hardware.errors import ServoError
from mearm.maker.keys import KeyReader, require_terminal

#: The step sizes the keys choose from [µs].
STEPS_US = (1, 5, 20)
#: Reference values lie this fraction of the limit range in from each end [-].
REFERENCE_INSET = 0.2
#: Reference values are rounded to this grid, per unit.
REFERENCE_GRID = {"deg": 5.0, "cm": 0.5}


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
    smap = ServoMap.from_config(config)
    out = []
    for kind, maps in (("joint", smap.joints), ("tool", smap.tool), ("gripper", (smap.gripper,))):
        for a in maps:
            lo, hi = servo_span(smap, a)
            out.append(Actuator(a.name, kind, a, reference_values(lo, hi, a.unit), lo, hi))
    return out


def board_identity(bus: ServoBus) -> tuple[str, str]:
    """The board's id (from its banner, else its version reply) and its port."""
    port = str(getattr(bus, "port", ""))
    banner = getattr(bus, "banner", None)
    if isinstance(banner, bytes) and banner:
        text = banner.decode("ascii", "replace").split("*")[0].strip()
        return text.removeprefix("READY").strip(), port
    version = getattr(bus, "version", None)
    if version:
        return str(version), port
    return f"simulated ({type(bus).__name__}, servo.backend: sim)", port


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
            if a.combined:  # its pulse range bounds the combination, not this joint
                return dataclasses.replace(a, lower=-math.inf, upper=math.inf)
            lo, hi = a.pulse_limits
            return dataclasses.replace(a, lower=lo, upper=hi)

        self._joints = tuple(widened(a) for a in original.joints)
        self._tool = tuple(widened(a) for a in original.tool)
        home = original.servo_values(config.arm.home())
        tool_home = {t.name: t.home for t in config.arm.tool.actuators}
        self.pulses_us: dict[str, int] = {
            j.name: j.command_us(home[j.name]) for j in original.joints
        }
        self.pulses_us.update({t.name: t.command_us(tool_home[t.name]) for t in original.tool})
        g = original.gripper
        self.pulses_us[g.name] = g.command_us(original.gripper_open_cm)

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
        keys: Where keys come from.
        out: Where the screen goes.
    """

    def __init__(self, config: Config, session: PulseSession, keys: KeyReader, out: TextIO):
        self.config = config
        self.session = session
        self.keys = keys
        self.out = out
        self.step_index = 1

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
                fit = fit_actuator(act.name, unit, servo_of(self.config.arm, act.name), points)
                apply_servo_calibration(self.config, [fit], source=f"the fit of {act.name}")
            except (ServoCalibrationError, ConfigError) as exc:
                self.say(f"{act.name}: fit refused: {exc}")
                self.say(f"do {act.name} again (or press s at a reference to skip it)")
                continue
            s = fit.servo
            span = "limits" if not act.amap.combined else act.what
            self.say(
                f"{act.name}: zero {s.zero_us:.1f} µs, {s.us_per_unit:.3f} µs/{unit}, "
                f"direction {s.direction:+d}; {span} [{act.lower:g}, "
                f"{act.upper:g}] {unit} → [{s.pulse_us(act.lower):.0f}, "
                f"{s.pulse_us(act.upper):.0f}] µs"
            )
            return fit

    def _jog_until_recorded(self, act: Actuator, ref: float) -> str:
        """Handle keys until a reference is recorded (``record``), ``back`` or ``skip``."""
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
    return parser


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
    actuators = _chosen(config, args.actuators)
    output = args.output if args.output is not None else default_output(args.config)
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
    if not fits:
        print("no actuator calibrated: nothing written", file=sys.stderr)
        return EXIT_FAILURE
    apply_servo_calibration(config, fits, source="the calibration")
    cal = ServoCalibrationFile(config.arm.name, board, port, now_iso(), tuple(fits))
    written = save_servo_calibration(output, cal, force=force)
    print(f"wrote {written} ({len(fits)} actuator{'s' if len(fits) != 1 else ''})")
    print(
        f"to use it, add to the config's servo section:  calibration_file: {written}\n"
        "(relative to the config's folder), or add these overrides to a command:"
    )
    for line in servo_overrides(config.arm, fits):
        print(f"  --set '{line}'")
    return EXIT_OK


def hold_arm(bus: ServoBus) -> None:
    """Ask the bus to hold where it is (sends no new pulse); a failure is only reported."""
    try:
        bus.stop()
    except MearmError as exc:
        print(f"note: could not send hold: {exc}", file=sys.stderr)


if __name__ == "__main__":
    run(main)
