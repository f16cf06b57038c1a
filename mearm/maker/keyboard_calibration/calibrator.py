"""The keyboard procedure: the keys and the screen, one actuator after another."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from mearm.cli import EXIT_FAILURE, check_output_file
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
    narrowing_text,
    recorded_fit,
    replaced_calibration,
    servo_of,
)
from mearm.errors import ConfigError, MearmError
from mearm.hardware.errors import ServoError
from mearm.maker.keyboard_calibration.pulse_session import PulseSession, open_arm_bus
from mearm.maker.keyboard_calibration.references import (
    TABLE_ROOM_CM,
    Actuator,
    TableHeight,
    reference_pose,
    sweep_lowest,
)
from mearm.maker.keys import KeyReader, require_terminal
from mearm.maker.servo_output import board_identity, hold_arm, write_calibration

#: The step sizes the keys choose from [µs].
STEPS_US = (1, 5, 20)


class Abandoned(MearmError):
    """The user stopped the session with ``q``: nothing is written."""


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
        # a live status line is for a terminal; a file or pipe gets the lines alone
        self.live = bool(getattr(out, "isatty", lambda: False)())
        # the arm's own calibration, before any file: what a fit's slope is compared with,
        # the limits it is narrowed against and the config a file of it is applied to
        self.own = replaced_calibration(config) or config
        self.nominal_arm = self.own.arm
        # the actuators past their limits, each warned about once when it crossed
        self.past_limits: set[str] = set()
        # the tool's height over the table at joint servo values (built at the first joint)
        self._table: TableHeight | None = None

    def say(self, text: str = "") -> None:
        """Print a line (ending any live status line)."""
        self.out.write(("\r\x1b[K" if self.live else "") + text + "\n")
        self.out.flush()

    def end_status(self) -> None:
        """End the live status line, kept as it was (a terminal only)."""
        if self.live:
            self.out.write("\n")
            self.out.flush()

    def status(self, act: Actuator, ref: float) -> None:
        """Rewrite the live status line (a terminal only)."""
        if not self.live:
            return
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
        elif self.session.simulated:  # said, not left blank beside the joints' readings
            text += f"  simulated arm: no reading of {act.name} (not measured by this simulator)"
        if p in (lo, hi):
            text += "  (end of the pulse range)"
        if self.past_limits:
            text += f"  (past the limits: {', '.join(sorted(self.past_limits))})"
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
                # it replaces the arm's own calibration, not a file's fit (what a config
                # without the file has, what a simulated rig's servos are), and a config
                # using it has the arm's own limits: it is fitted and narrowed to those
                arm = self.nominal_arm
                _, lo, hi = fit_span(arm, act.name)
                template = servo_of(self.config.arm, act.name)
                fit = fit_actuator(act.name, unit, template, points, (lo, hi))
                fit = recorded_fit(self.config, fit, arm)
                check_fit(arm, fit, servo_of(arm, act.name))
                apply_servo_calibration(self.own, [fit], source=f"the fit of {act.name}")
            except (ServoCalibrationError, ConfigError) as exc:
                self.refuse(act, exc)
                continue
            s = fit.servo
            what, lo, hi = fit_span(self.nominal_arm, act.name, fit.limits)
            self.say(
                f"{act.name}: zero {s.zero_us:.1f} µs, {s.us_per_unit:.3f} µs/{unit}, "
                f"direction {s.direction:+d}; {what} [{lo:.4g}, {hi:.4g}] {unit} → "
                f"[{s.pulse_us(lo):.0f}, {s.pulse_us(hi):.0f}] µs"
            )
            narrowing = narrowing_text(self.nominal_arm, fit)
            if narrowing is not None:
                self.say(narrowing)
            return fit

    def warn_past_limits(self) -> None:
        """Warn, once per crossing, about each actuator the pulses put past its limits.

        The keys range over the whole pulse range, not the limits: the present
        calibration is what is being measured, so its limits may not be where the arm's
        are, and a reference may need a pulse past them. But under it the arm may really
        be past them (the MeArm v1's base read 180.9° against its [45, 135]° with the
        horns on), where the links may hit each other, the base or the table. The line
        names the actuator (the joint itself for a servo that turns a combination), its
        value and its limits, when it crosses out; one more says when it is back inside.
        """
        smap = self.session.servo_map
        past = set()
        for name, value in self.session.actuator_values().items():
            a = smap[name]
            # the whole-µs pulse nearest a limit is at it, not past it
            slack = 0.5 / a.us_per_unit
            if a.lower - slack <= value <= a.upper + slack:
                if name in self.past_limits:
                    limits = f"[{a.lower:g}, {a.upper:g}] {a.unit}"
                    self.say(f"{name} is back inside its limits {limits}")
                continue
            past.add(name)
            if name not in self.past_limits:
                harm = (
                    "its jaws may jam on each other or on their stops"
                    if name == smap.gripper.name
                    else "the links may collide with each other, the base or the table"
                )
                self.say(
                    f"warning: {name} is at {value:.4g} {a.unit}, past its limits "
                    f"[{a.lower:g}, {a.upper:g}] {a.unit}: {harm}"
                )
        self.past_limits = past

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
        if self._table is None:
            self._table = TableHeight(self.config)
        lowest = self._table.lowest(smap)  # under the map as it is now, fits made included
        pose = reference_pose(smap, act, present, session.home_values, lowest)
        clear = sweep_lowest(act, pose, lowest) >= TABLE_ROOM_CM
        moved = {n: v for n, v in pose.items() if smap[n].command_us(v) != session.pulses_us[n]}
        if not moved:
            return
        for n, v in moved.items():
            session.pulses_us[n] = smap[n].command_us(v)
        session.send()
        self.warn_past_limits()
        where = ", ".join(
            f"{smap[n].combination_text} to {v:.4g} {smap[n].unit}" for n, v in moved.items()
        )
        self.say(
            f"moved {where}: at {act.name}'s references every joint then stays inside its limits"
            + (", the tool off the table" if clear else ", the tool as high as it goes")
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
                self.warn_past_limits()
            elif key in ("-", "_", "left"):
                self.session.set_pulse(act.name, self.session.pulses_us[act.name] - step)
                self.warn_past_limits()
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


def calibrate_by_keyboard(
    config: Config, actuators: Sequence[Actuator], output: Path, args: argparse.Namespace
) -> int:
    """The keyboard procedure on the config's bus (:mod:`mearm.maker.calibrate_servos`).

    Returns:
        The exit status: 0 written; 1 stopped with ``q``, the terminal closed, a servo
        fault, a refused file or a replace declined.

    Raises:
        KeyboardInterrupt: Ctrl-C, the arm held where it is (nothing written).
        MearmError: an ``--output`` that cannot be written, before anything opens; a
            board that cannot be opened or does not answer, before anything moves; or
            the write failed at the end (the fits printed first, as ``--set`` lines).
    """
    check_output_file(output, "--output")  # before the session: its work is not lost
    check_replace(output)  # a file that is not a calibration (a config): never, --force too
    require_terminal("calibrate-servos")
    out = sys.stdout
    with KeyReader() as keys:
        force = bool(args.force)
        if output.exists():
            if not force:
                if not keys.confirm(f"{output} exists: replace it (the old one → .bak)?"):
                    print(f"kept {output}; nothing calibrated", file=sys.stderr)
                    return EXIT_FAILURE
            force = True
        bus = open_arm_bus(config, args.port)
        # connected before the session: a port that cannot be opened (or a board that does
        # not answer) is bad input, said in one line (exit 2) as jog and --camera say it,
        # not a servo fault of a session that never started
        bus.connect()
        calibrator = None
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
            if calibrator is not None:
                calibrator.end_status()  # (the fault's line on its own, not after the status)
            print(f"mearm calibrate-servos: servo fault: {exc}; nothing written", file=sys.stderr)
            return EXIT_FAILURE
    return write_calibration(config, fits, board, port, output, force=force)
