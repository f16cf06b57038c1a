"""The keyboard procedure with the MuJoCo twin as the maker: it jogs and reads, no keys."""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Protocol, TextIO, runtime_checkable

import numpy as np

from mearm.cli import EXIT_FAILURE
from mearm.config import Config
from mearm.config.servo_file import ActuatorFit
from mearm.errors import MearmError
from mearm.hardware.bus import MeasuresTcp
from mearm.hardware.errors import ServoError
from mearm.maker.keyboard_calibration.calibrator import Calibrator
from mearm.maker.keyboard_calibration.pulse_session import PulseSession
from mearm.maker.keyboard_calibration.references import (
    Actuator,
    actuators_of_map,
    poses_inside,
    reference_pose,
)
from mearm.maker.servo_output import check_output, write_calibration

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


@runtime_checkable
class SettlingArm(MeasuresTcp, Protocol):
    """The twin as the observer uses it: it lets the arm settle, reads the jaws and the TCP.

    What :class:`~mearm.sim.twin.twin_bus.TwinArm` has besides a servo bus's work. A
    protocol, not the class: every ``calibrate-servos`` imports this module, and the
    twin's module imports MuJoCo.
    """

    @property
    def opening_cm(self) -> float: ...  # noqa: D102
    def settle(self, seconds: float) -> None: ...  # noqa: D102


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

    Raises:
        TypeError: the session's bus is not the twin (:class:`SettlingArm`).
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
        if not isinstance(session.bus, SettlingArm):
            raise TypeError(f"the simulated maker needs the twin's bus, got {session.bus!r}")
        #: The session's bus, as the twin the observer reads.
        self.twin: SettlingArm = session.bus
        self.reading_error = dict(READING_ERROR if reading_error is None else reading_error)
        self.rng = np.random.default_rng(seed)
        self.reads = 0
        self.refused = 0

    def read(self, act: Actuator, pulse_us: int) -> float:
        """Send ``pulse_us`` to the actuator, let the twin settle, read the arm."""
        self.session.set_pulse(act.name, pulse_us)
        self.twin.settle(SIM_SETTLE_S)
        self.reads += 1
        if act.kind == "gripper":
            return float(self.twin.opening_cm)
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
        twin = self.twin
        best: tuple[float, tuple[int, ...]] | None = None
        for values in settings:
            setting = tuple(smap[a.name].command_us(values[a.name]) for a in others)
            for a, p in zip(others, setting, strict=True):
                self.session.pulses_us[a.name] = p
            low = math.inf
            for ref in act.references:
                self.session.set_pulse(act.name, act.amap.command_us(ref))
                twin.settle(SIM_SETTLE_S)
                low = min(low, float(twin.ee_cm[2]))
            if best is None or low > best[0]:
                best = (low, setting)
        assert best is not None
        for a, p in zip(others, best[1], strict=True):
            self.session.pulses_us[a.name] = p
        self.session.send()
        twin.settle(SIM_SETTLE_S)

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

    cleared = config.with_scene([])
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
    # over a file, each fit records what that file replaced (Calibrator.calibrate): the
    # twin's units stay relative to the arm's own calibration
    return write_calibration(config, fits, board, "", output, force=bool(args.force))
