r"""The servo calibration file: each actuator's fitted pulse map, with its provenance.

Each actuator's pulse is linear in its value (:class:`~mearm.config.ServoCalibration`),

.. math:: p = p_0 + s\,k\,v

where v is the servo's value: the actuator's own, or for a joint servo that turns a
combination of joints (its ``drives``, :class:`~mearm.config.ServoDrives`) that
combination — the MeArm's elbow servo is calibrated on the forearm's angle to the table,
shoulder + elbow. Two reference values :math:`v_1 \ne v_2` and the pulses
:math:`p_1, p_2` that put the servo there give the signed slope
:math:`\kappa = (p_2 - p_1)/(v_2 - v_1)`, so
:math:`k = |\kappa|` [µs/unit], :math:`s = \operatorname{sign}\kappa` and
:math:`p_0 = p_1 - \kappa v_1` [µs]. With more points the line is the least-squares fit
and ``residual_us`` the largest distance of a point from it.

**The file** is versioned YAML, one per board and arm, beside the config that uses it
(the camera's calibration files are kept the same way, :mod:`mearm.vision.pinhole`)::

    format: mearm-servo-calibration
    version: 1
    kind: servos
    arm: paper_mearm
    board_id: mearm_servo 2.0, 5 channels
    port: /dev/ttyACM0
    date: '2026-11-23T23:10:00+00:00'
    actuators:
      shoulder:
        {channel: 1, unit: deg, zero_us: 570.0, direction: 1, us_per_unit: 10.0,
         min_us: 600, max_us: 2400, residual_us: 0.0,
         replaces: {zero_us: 600.0, direction: 1, us_per_unit: 10.0},
         points: [{value: 51.0, pulse_us: 1080}, {value: 114.0, pulse_us: 1710}]}

``replaces`` is the arm's own calibration of the actuator, the one before any servo
calibration file: a fit made over an earlier file records what that file replaced, not
the earlier fit (optional: files written before it was recorded lack it). An entry that
narrows its joint's limits (``limits``, below) records the arm's own limits there too
(``replaces: {…, limits: {min: 20.0, max: 160.0}}``), which :func:`replaced_calibration`
puts back: a config that uses the file holds only the narrowed ones.

A servo that turns a combination records it (``drives: {terms: {shoulder: 1.0, elbow:
1.0}, offset: 0.0}`` in its entry): its points are values of that combination, and a
config applies the entry only to a servo that turns the same combination.

**What a fit must pass** (:func:`check_fit`): its µs per unit within
:data:`MAX_SLOPE_DEVIATION` of the arm's own (a misread reference is farther off than any
real unit), and its pulses over :func:`fit_span` — the limits, or for a servo that turns
a combination the combination over the joint's limits with the other joints at home —
inside ``[min_us, max_us]``. A fit whose line leaves that range by less than a reading's
uncertainty (:data:`FIT_SLACK`) takes the nearest line that does not
(:func:`fit_actuator` with ``span``): limits that fill the whole pulse range, as the
5-DOF arm's wrist's do, are otherwise refused for a half-degree misreading. A fit that
reaches less than a joint's limits by more than that narrows them to what it reaches
(:func:`~mearm.config.servo_reach.narrowed`; ``limits: {min, max}`` in its entry, which
a config that uses the file takes), unless it leaves more than
:data:`~mearm.config.servo_reach.MAX_NARROWING` of them: then it is refused. A fit is
narrowed against the arm's own limits (:func:`recorded_fit`), not those an earlier file
narrowed: a file is applied to the arm's own calibration, so a fit that reached the
earlier file's limits but not the arm's would make a file no config can load. A joint an
older file narrowed without recording the arm's own limits stays at least that narrow
(the arm's own are not known then).

:func:`save_servo_calibration` replaces a file only with ``force`` (the command asks
first) and only if it is a servo calibration, and keeps the old one as ``<name>.bak``.
:func:`apply_servo_calibration` puts a file's calibrations into a config and validates
the result with the config's own checks (limits, home, tool settings inside each
servo's pulse range); it sets the calibrated fields of each servo and keeps the rest
(its speed, ``seconds_per_60deg``) as the config has it. The file's pulse range narrows
the config's, never widens it.
"""

from __future__ import annotations

import dataclasses
import datetime
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import ValidationError

from mearm.config.arm import ArmDescription, JointServo, ServoCalibration, ServoDrives
from mearm.config.base import MAX_LENGTH_CM, short_repr
from mearm.config.errors import ServoCalibrationError
from mearm.config.loader import config_from_dict
from mearm.config.root import Config
from mearm.config.servo_reach import (  # noqa: F401  (the checks on a fit, used from here)
    MAX_NARROWING,
    MAX_SLOPE_DEVIATION,
    check_fit,
    fit_span,
    narrowed,
    narrowing_text,
    turns,
)
from mearm.errors import ConfigError
from mearm.fileio import keep_backup, write_atomic
from mearm.yamlio import load_yaml_file

FORMAT = "mearm-servo-calibration"
VERSION = 1
KIND = "servos"


def now_iso() -> str:
    """Now, as calibration files record it (ISO 8601, UTC, seconds)."""
    return datetime.datetime.now(datetime.UTC).replace(microsecond=0).isoformat()


@dataclass(frozen=True)
class CalibrationPoint:
    """One reference: the actuator at ``value`` [deg or cm] took ``pulse_us`` [µs]."""

    value: float
    pulse_us: int


@dataclass(frozen=True)
class ActuatorFit:
    """One actuator's fitted calibration and the points it was fitted to.

    Attributes:
        name: The actuator's name in the arm description.
        unit: ``deg`` or ``cm``.
        servo: The fitted calibration (channel and pulse range as configured).
        points: The references it was fitted to.
        residual_us: The largest distance of a point from the fitted line [µs].
        replaces: The arm's own calibration of the actuator, before any servo
            calibration file (its zero, direction and µs per unit; written as
            ``replaces``), or ``None`` (unknown: a file written before it was
            recorded). The twin with a kit of servos takes it as the arm's nominal servo,
            the one its units deviate from (docs/twin.md).
        limits: The joint's limits narrowed to what the servo reaches inside its pulse
            range (min, max) [deg or cm], or ``None``: the arm's
            (:func:`~mearm.config.servo_reach.narrowed`).
        own_limits: The joint's limits in the arm's own calibration (min, max), recorded
            where ``limits`` narrows them (written in ``replaces``), or ``None``: not
            narrowed, or unknown (a file written before they were recorded).
    """

    name: str
    unit: str
    servo: ServoCalibration
    points: tuple[CalibrationPoint, ...]
    residual_us: float
    replaces: ServoCalibration | None = None
    limits: tuple[float, float] | None = None
    own_limits: tuple[float, float] | None = None

    def with_limits(self, limits: tuple[float, float] | None) -> ActuatorFit:
        """The same fit with these narrowed limits (``None``: the arm's)."""
        return dataclasses.replace(self, limits=limits)

    @property
    def drives(self) -> ServoDrives | None:
        """The combination the servo turns, or ``None``: the actuator's own value."""
        return self.servo.drives if isinstance(self.servo, JointServo) else None

    def to_dict(self) -> dict[str, Any]:
        """The actuator's entry in the file."""
        s = self.servo
        out: dict[str, Any] = {
            "channel": s.channel,
            "unit": self.unit,
            "zero_us": round(s.zero_us, 4),
            "direction": s.direction,
            "us_per_unit": round(s.us_per_unit, 6),
            "min_us": s.min_us,
            "max_us": s.max_us,
        }
        if self.drives is not None:
            out["drives"] = self.drives.model_dump(mode="json")
        if s.play_us != 0:
            out["play_us"] = round(s.play_us, 2)
        out["residual_us"] = round(self.residual_us, 4)
        if self.limits is not None:
            out["limits"] = {"min": self.limits[0], "max": self.limits[1]}
        if self.replaces is not None:
            r = self.replaces
            out["replaces"] = {
                "zero_us": round(r.zero_us, 4),
                "direction": r.direction,
                "us_per_unit": round(r.us_per_unit, 6),
            }
            if self.limits is not None and self.own_limits is not None:
                lo, hi = self.own_limits
                out["replaces"]["limits"] = {"min": lo, "max": hi}
        out["points"] = [{"value": p.value, "pulse_us": p.pulse_us} for p in self.points]
        return out


#: How far a fit may pass from its references to keep a span's pulses inside the servo's
#: range [unit]: two standard deviations of a reading by eye (protractor; ruler across
#: the jaws), a difference the references cannot tell.
FIT_SLACK = {"deg": 1.0, "cm": 0.1}
#: Such a line holds an end of the span this far inside the pulse range [µs], so the
#: file's rounding (0.0001 µs, 1e-6 µs per unit) keeps it inside.
FIT_EDGE_US = 0.01


def fit_actuator(
    name: str,
    unit: str,
    template: ServoCalibration,
    points: Sequence[CalibrationPoint],
    span: tuple[float, float] | None = None,
) -> ActuatorFit:
    """Fit zero, direction and µs per unit to two or more reference points.

    The least-squares line through the points. With ``span``, when that line puts an
    end of the span outside ``[min_us, max_us]``, the nearest line that keeps both
    inside is taken instead, if it passes within :data:`FIT_SLACK` of every point (a
    joint whose limits span the whole pulse range, as the nominal calibration maps
    them, would otherwise be refused for its reading error); else the line stays, for
    :func:`check_fit` to refuse.

    Args:
        name: The actuator's name.
        unit: ``deg`` or ``cm``.
        template: The actuator's present calibration: its channel, pulse range and (a
            joint servo's) ``drives`` are kept.
        points: At least two references at different values (of the servo's value: the
            combination, for a servo that turns one).
        span: The values the calibration must put inside the pulse range
            (:func:`fit_span`), or ``None``.

    Raises:
        ServoCalibrationError: fewer than two distinct values, equal pulses at different
            values (the servo did not move), or a slope outside what a calibration allows.
    """
    values = np.array([p.value for p in points], dtype=float)
    pulses = np.array([p.pulse_us for p in points], dtype=float)
    if len(points) < 2 or np.ptp(values) <= 0:
        raise ServoCalibrationError(
            f"{name}: a fit needs two references at different values, got "
            f"{short_repr(values.tolist())}"
        )
    slope, zero = np.polyfit(values, pulses, 1)
    if np.ptp(pulses) == 0:
        raise ServoCalibrationError(
            f"{name}: the same pulse ({int(pulses[0])} µs) at {values.min():g} and "
            f"{values.max():g} {unit}: the servo did not move; check its wiring and channel"
        )
    if span is not None:
        bounds = (template.min_us + FIT_EDGE_US, template.max_us - FIT_EDGE_US)
        slope, zero = _line_inside(values, pulses, (slope, zero), span, bounds, FIT_SLACK[unit])
    servo = fitted_servo(template, name, float(zero), float(slope), "; redo the references")
    residual = float(np.max(np.abs(zero + slope * values - pulses)))
    return ActuatorFit(name, unit, servo, tuple(points), residual, replaces=template)


def fitted_servo(
    template: ServoCalibration,
    name: str,
    zero_us: float,
    slope: float,
    advice: str = "",
    *,
    play_us: float = 0.0,
) -> ServoCalibration:
    """``template`` with a fitted mapping: ``zero_us``, ``slope`` µs per unit (signed).

    Its ``play_us`` is the one measured, none unless given: an old file's play does not
    carry over to a new fit.

    Raises:
        ServoCalibrationError: the servo's calibration refuses a fitted value (naming it,
            then ``advice``).
    """
    data = template.model_dump()
    data.update(
        zero_us=zero_us,
        direction=1 if slope > 0 else -1,
        us_per_unit=abs(slope),
        play_us=play_us,
    )
    try:
        return type(template).model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        raise ServoCalibrationError(
            f"{name}: the fit gives {'.'.join(map(str, err['loc']))} = "
            f"{short_repr(err.get('input'))}: {err['msg']}{advice}"
        ) from None


def _line_inside(
    values: np.ndarray,
    pulses: np.ndarray,
    line: tuple[float, float],
    span: tuple[float, float],
    bounds: tuple[float, float],
    slack: float,
) -> tuple[float, float]:
    """The least-squares (slope, zero) with the span's pulses inside ``bounds``.

    ``line`` itself when it keeps them inside; else the best line through one or both
    corners (an end of the span at an end of the pulse range), if it passes within
    ``slack`` [unit] of every point; else ``line``.
    """

    def inside(k: float, z: float) -> bool:
        return all(bounds[0] - 1e-6 <= z + k * v <= bounds[1] + 1e-6 for v in span)

    if inside(*line):
        return line
    candidates = []
    for e in span:  # one end held at an end of the pulse range: the best slope about it
        for b in bounds:
            k = float(np.sum((values - e) * (pulses - b)) / np.sum((values - e) ** 2))
            candidates.append((k, b - k * e))
    for b0 in bounds:  # both ends held
        for b1 in bounds:
            if b0 != b1 and span[1] != span[0]:
                k = (b1 - b0) / (span[1] - span[0])
                candidates.append((k, b0 - k * span[0]))
    best = min(
        (c for c in candidates if c[0] != 0 and inside(*c)),
        key=lambda c: float(np.sum((c[1] + c[0] * values - pulses) ** 2)),
        default=None,
    )
    if best is None:
        return line
    k, z = best
    if np.max(np.abs(z + k * values - pulses)) / abs(k) > slack:
        return line
    return best


@dataclass(frozen=True)
class ServoCalibrationFile:
    """A whole calibration file.

    Attributes:
        arm: The arm description's name.
        board_id: The board, as it introduced itself (firmware, version, channels).
        port: Where it was connected.
        date: When the calibration was made (ISO 8601, UTC).
        actuators: The fitted actuators, in the order calibrated.
    """

    arm: str
    board_id: str
    port: str
    date: str
    actuators: tuple[ActuatorFit, ...]

    def text(self) -> str:
        """The file's YAML text."""
        header = {
            "format": FORMAT,
            "version": VERSION,
            "kind": KIND,
            "arm": self.arm,
            "board_id": self.board_id,
            "port": self.port,
            "date": self.date,
        }
        body = {"actuators": {a.name: a.to_dict() for a in self.actuators}}
        head = yaml.safe_dump(header, sort_keys=False, allow_unicode=True)
        rest = yaml.safe_dump(body, sort_keys=False, default_flow_style=None, width=100)
        return f"# mearm servo calibration; written by mearm calibrate-servos\n{head}{rest}"


def load_servo_calibration(path: str | Path) -> ServoCalibrationFile:
    """Read a servo calibration file.

    Raises:
        ServoCalibrationError: missing, not YAML, not a mearm servo calibration, another
            version, or a bad field; the message names the file and the field.
    """
    where = str(path)
    try:
        data = load_yaml_file(path, what="servo calibration")
    except ConfigError as exc:
        raise ServoCalibrationError(str(exc)) from None
    if not isinstance(data, dict) or data.get("format") != FORMAT or data.get("kind") != KIND:
        raise ServoCalibrationError(
            f"{where}: not a mearm servo calibration (format: {FORMAT}, kind: {KIND})"
        )
    if data.get("version") != VERSION:
        raise ServoCalibrationError(
            f"{where}: servo calibration version {short_repr(data.get('version'))}; this "
            f"mearm reads version {VERSION}"
        )
    try:
        actuators = []
        entries = data["actuators"]
        if not isinstance(entries, dict) or not entries:
            raise ValueError("actuators must be a non-empty mapping of name → calibration")
        for name, entry in entries.items():
            fields = dict(entry)
            unit = str(fields.pop("unit"))
            residual = _number(f"{name}.residual_us", fields.pop("residual_us", 0.0), 0, MAX_US)
            points = tuple(
                CalibrationPoint(
                    _number(f"{name}.points[{k}].value", p["value"], -MAX_LENGTH_CM, MAX_LENGTH_CM),
                    int(
                        _number(
                            f"{name}.points[{k}].pulse_us", p["pulse_us"], 0, MAX_US, whole=True
                        )
                    ),
                )
                for k, p in enumerate(fields.pop("points", []))
            )
            replaced = fields.pop("replaces", None)
            limits = _limits(str(name), fields.pop("limits", None))
            kind = JointServo if "drives" in fields else ServoCalibration
            servo = kind.model_validate(fields)
            replaces, own = None, None
            if replaced is not None:
                replaced = dict(replaced)
                own = _limits(f"{name}.replaces", replaced.pop("limits", None))
                replaces = kind.model_validate({**fields, **replaced})
            actuators.append(
                ActuatorFit(str(name), unit, servo, points, residual, replaces, limits, own)
            )
        return ServoCalibrationFile(
            arm=str(data["arm"]),
            board_id=str(data["board_id"]),
            port=str(data.get("port", "")),
            date=str(data["date"]),
            actuators=tuple(actuators),
        )
    except KeyError as exc:
        raise ServoCalibrationError(f"{where}: missing field {exc.args[0]!r}") from None
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(map(str, err["loc"]))
        raise ServoCalibrationError(f"{where}: {name}.{loc}: {err['msg']}") from None
    except (TypeError, ValueError, AttributeError, OverflowError) as exc:
        raise ServoCalibrationError(f"{where}: {exc}") from None


#: Largest pulse width or residual a servo calibration file may hold [µs].
MAX_US = 10_000


def _number(field: str, value: Any, lo: float, hi: float, *, whole: bool = False) -> float:
    """A number read from the file: finite, in [lo, hi] (and whole), or a named ValueError."""
    kind = "a whole number" if whole else "a number"
    ok = isinstance(value, int | float) and not isinstance(value, bool)
    if ok and not (np.isfinite(value) and lo <= value <= hi and (not whole or value == int(value))):
        ok = False
    if not ok:
        raise ValueError(f"{field} must be {kind} in {lo:g} … {hi:g}, got {short_repr(value)}")
    return float(value)


def _limits(name: str, value: Any) -> tuple[float, float] | None:
    """An entry's narrowed ``limits: {min, max}``, or ``None``; a named ValueError if bad."""
    if value is None:
        return None
    if not isinstance(value, dict) or set(value) != {"min", "max"}:
        raise ValueError(f"{name}.limits must be {{min: …, max: …}}, got {short_repr(value)}")
    lo = _number(f"{name}.limits.min", value["min"], -MAX_LENGTH_CM, MAX_LENGTH_CM)
    hi = _number(f"{name}.limits.max", value["max"], -MAX_LENGTH_CM, MAX_LENGTH_CM)
    if not lo < hi:
        raise ValueError(f"{name}.limits: min ({lo:g}) must be below max ({hi:g})")
    return (lo, hi)


def check_replace(path: Path, *, force: str = "--force", elsewhere: str = "--output") -> None:
    """Refuse to replace ``path`` if it exists and is not a servo calibration.

    ``force`` and ``elsewhere``: the command's own flags, for its line (``mearm sort``
    writes with ``--save-calibration`` and has no ``--force``: ``""``).

    Raises:
        ServoCalibrationError: it is a folder, or a file that is not a servo calibration.
    """
    if not path.exists():
        return
    if path.is_dir():
        raise ServoCalibrationError(f"{path} is a folder: name a file to write")
    try:
        load_servo_calibration(path)
    except ServoCalibrationError as exc:
        even = f", even with {force}" if force else ""
        raise ServoCalibrationError(
            f"{path} is not replaced{even}: {exc.reason.removeprefix(f'{path}: ')}; write "
            f"elsewhere with {elsewhere}, or remove it"
        ) from None


def save_servo_calibration(
    path: str | Path,
    cal: ServoCalibrationFile,
    *,
    force: bool = False,
    on_backup: Callable[[Path], None] | None = None,
) -> Path:
    """Write ``cal`` to ``path``; an existing file only with ``force``, kept first.

    The replaced file is kept as ``<path>.bak``, or ``<path>.bak.N`` beside an earlier
    backup, which it never replaces (:func:`~mearm.fileio.keep_backup`); ``on_backup`` is
    told where.

    Returns:
        The file written.

    Raises:
        ServoCalibrationError: the file exists and ``force`` is not set (the caller asks
            the user first), or it cannot be written.
    """
    target = Path(path)
    try:
        if target.exists():
            if not force:
                raise ServoCalibrationError(
                    f"{target} exists: pass --force to replace it (the old one is kept as "
                    f"{target.name}.bak)"
                )
            backup = keep_backup(target, cal.text())
            if backup is not None and on_backup is not None:
                on_backup(backup)
        target.parent.mkdir(parents=True, exist_ok=True)
        return write_atomic(target, cal.text())
    except OSError as exc:
        raise ServoCalibrationError(f"cannot write {target}: {exc}") from None


def actuator_paths(arm: ArmDescription) -> dict[str, str]:
    """Each actuator's name → the dotted config key of its ``servo`` (for ``--set``)."""
    paths = {j.name: f"arm.joints.{j.name}.servo" for j in arm.actuated_joints()}
    paths.update({a.name: f"arm.tool.actuators.{a.name}.servo" for a in arm.tool.actuators})
    paths[arm.tool.gripper.name] = "arm.tool.gripper.servo"
    return paths


#: The fields of a servo a calibration sets; the others (its speed) stay the config's.
CALIBRATED_FIELDS = (
    "channel",
    "zero_us",
    "direction",
    "us_per_unit",
    "min_us",
    "max_us",
    "drives",
    "play_us",
)


def servo_overrides(arm: ArmDescription, fits: Sequence[ActuatorFit]) -> list[str]:
    """The ``--set KEY=VALUE`` overrides that give a config these calibrations.

    Each replaces the actuator's whole ``servo``: the calibrated fields from the fit, the
    others (``seconds_per_60deg``, ``max_accel_deg_s2``) as the arm has them, and the
    pulse range never wider than the arm's. A fit that narrowed its joint's limits sets
    them too, where they are narrower than the arm's.

    Raises:
        ServoCalibrationError: an actuator the arm does not have, or narrowed limits for
            one that has none (the gripper).
    """
    paths = actuator_paths(arm)
    out = []
    for fit in fits:
        if fit.name not in paths:
            raise ServoCalibrationError(
                f"the calibration names {fit.name!r}, which this arm ({arm.name}) does not "
                f"have; its actuators: {', '.join(paths)}"
            )
        s = fit.servo
        drives = ""
        if fit.drives is not None:
            terms = ", ".join(f"{n}: {c!r}" for n, c in fit.drives.terms.items())
            drives = f", drives: {{terms: {{{terms}}}, offset: {fit.drives.offset!r}}}"
        play = f", play_us: {s.play_us:.2f}" if s.play_us != 0 else ""
        present = servo_of(arm, fit.name).model_dump(mode="json")
        kept = "".join(
            f", {k}: {v!r}"
            for k, v in present.items()
            if k not in CALIBRATED_FIELDS and v is not None
        )
        # the pulse range is the config's, not measured: a file never widens it (one
        # written before the config narrowed it would send the pulses it keeps away from)
        min_us, max_us = max(s.min_us, present["min_us"]), min(s.max_us, present["max_us"])
        value = (
            f"{{channel: {s.channel}, zero_us: {s.zero_us:.4f}, direction: {s.direction}, "
            f"us_per_unit: {s.us_per_unit:.6f}, min_us: {min_us}, max_us: {max_us}"
            f"{drives}{play}{kept}}}"
        )
        out.append(f"{paths[fit.name]}={value}")
        if fit.limits is not None:
            out.append(_limits_override(arm, fit.name, fit.limits, paths[fit.name]))
    return out


def _limits_override(
    arm: ArmDescription, name: str, limits: tuple[float, float], servo_key: str
) -> str:
    """The ``--set`` that narrows an actuator's limits: never wider than the arm's."""
    present = {j.name: j.limits for j in arm.actuated_joints()}
    present.update({a.name: a.limits for a in arm.tool.actuators})
    now = present.get(name)
    if now is None:
        raise ServoCalibrationError(
            f"the calibration narrows {name}'s limits, which {arm.name}'s {name} does not "
            "have (a gripper's are its opening): recalibrate it"
        )
    lo, hi = max(limits[0], now.min), min(limits[1], now.max)
    return f"{servo_key.removesuffix('.servo')}.limits={{min: {lo!r}, max: {hi!r}}}"


def servo_of(arm: ArmDescription, name: str) -> ServoCalibration:
    """The present calibration of the actuator called ``name`` (the gripper's if no other)."""
    for j in arm.actuated_joints():
        if j.name == name and j.servo is not None:
            return j.servo
    for a in arm.tool.actuators:
        if a.name == name:
            return a.servo
    return arm.tool.gripper.servo


def apply_servo_calibration(
    config: Config,
    fits: Sequence[ActuatorFit],
    source: str = "servo calibration",
    *,
    limits: Mapping[str, tuple[float, float]] | None = None,
) -> Config:
    """``config`` with these actuators' calibrations, validated by the config's checks.

    ``limits`` sets joints' limits as given, wider than the config's too (the arm's own,
    put back by :func:`replaced_calibration`).

    Raises:
        ServoCalibrationError: an actuator the arm does not have, on another channel, or
            whose servo was calibrated turning another combination of joints.
        ConfigError: the calibrated config is invalid (a limit, home or tool setting whose
            pulse leaves the servo's range); the message names the field.
    """
    try:
        overrides = servo_overrides(config.arm, fits)
    except ServoCalibrationError as exc:  # named by the file the maker can open
        raise ServoCalibrationError(f"{source}: {exc}") from None
    paths = actuator_paths(config.arm)
    overrides += [
        f"{paths[n].removesuffix('.servo')}.limits={{min: {lo!r}, max: {hi!r}}}"
        for n, (lo, hi) in (limits or {}).items()
    ]
    for fit in fits:
        present = servo_of(config.arm, fit.name)
        channel = present.channel
        if fit.servo.channel != channel:
            raise ServoCalibrationError(
                f"{source}: {fit.name} was calibrated on channel {fit.servo.channel}, the "
                f"config drives it on channel {channel}: recalibrate, or fix the channel"
            )
        was, now = turns(fit.servo, fit.name), turns(present, fit.name)
        if was != now:
            raise ServoCalibrationError(
                f"{source}: {fit.name}'s servo was calibrated turning {was.text()}, the "
                f"config's turns {now.text()}: recalibrate, or fix its drives"
            )
    try:
        return config_from_dict(config.model_dump(mode="json"), source=source, overrides=overrides)
    except ConfigError as exc:  # named by the calibration, not "--set" (its overrides are ours)
        raise ConfigError(source, exc.problems) from None


def apply_servo_calibration_file(config: Config, path: str | Path) -> Config:
    """:func:`apply_servo_calibration` of the file at ``path``, checked against the arm.

    Raises:
        ServoCalibrationError, ConfigError: as :func:`load_servo_calibration` and
            :func:`apply_servo_calibration`.
    """
    cal = load_servo_calibration(path)
    if cal.arm != config.arm.name:
        raise ServoCalibrationError(
            f"{path}: calibrates arm {cal.arm!r}, the config describes {config.arm.name!r}"
        )
    return apply_servo_calibration(config, cal.actuators, source=str(path))


def fits_by_name(cal: ServoCalibrationFile) -> Mapping[str, ActuatorFit]:
    """The file's actuators by name."""
    return {a.name: a for a in cal.actuators}


def replaced_calibration(config: Config) -> Config | None:
    """``config`` with the calibrations its servo calibration file replaced put back.

    What the arm had before ``servo.calibration_file``: each actuator's ``replaces``
    (:class:`ActuatorFit`), with the joint's own limits where the file narrowed them and
    recorded them. An end the config holds narrower than the file's is the config's own
    (it was narrowed after the file was written); a joint whose own limits the file does
    not record (one written before they were) keeps the narrowed ones
    (:func:`unrecorded_limits`). ``None`` when the config names no file, or the file
    records no ``replaces`` for any actuator.

    Raises:
        ServoCalibrationError, ConfigError: as :func:`apply_servo_calibration_file`.
    """
    path = config.servo.calibration_file
    if path is None:
        return None
    cal = load_servo_calibration(path)
    back = [
        ActuatorFit(a.name, a.unit, a.replaces, (), 0.0)
        for a in cal.actuators
        if a.replaces is not None
    ]
    if not back:
        return None
    present = config.arm.joint_limits()
    limits = {}
    for a in cal.actuators:
        if a.limits is None or a.own_limits is None or a.name not in present:
            continue
        now = present[a.name]
        lo = min(a.own_limits[0], now.min) if now.min <= a.limits[0] else now.min
        hi = max(a.own_limits[1], now.max) if now.max >= a.limits[1] else now.max
        limits[a.name] = (lo, hi)
    return apply_servo_calibration(
        config, back, source=f"{path} (the calibration it replaced)", limits=limits
    )


def unrecorded_limits(config: Config) -> frozenset[str]:
    """The joints the config's servo calibration file narrowed without their own limits.

    A file written before an entry recorded the arm's own limits (``replaces: {limits}``)
    says only the narrowed ones: the arm's are not known.

    Raises:
        ServoCalibrationError: as :func:`load_servo_calibration`.
    """
    path = config.servo.calibration_file
    if path is None:
        return frozenset()
    return frozenset(
        a.name
        for a in load_servo_calibration(path).actuators
        if a.limits is not None and (a.replaces is None or a.own_limits is None)
    )


def recorded_fit(
    config: Config, fit: ActuatorFit, own: ArmDescription | None = None
) -> ActuatorFit:
    """A fit made under ``config`` as a servo calibration file records it.

    A file is applied to the arm's own calibration, the one before any file
    (:func:`replaced_calibration`), not to the one the fit was made over: the fit records
    that calibration as ``replaces``, and its joint's limits narrowed against the arm's
    own (:func:`narrowed`), with those (``own_limits``) where it narrows them. Narrowed
    against an earlier file's limits instead, a fit that reaches those but not the arm's
    would record none, and no config could load the file. A joint whose own limits the
    config's file does not record (:func:`unrecorded_limits`) stays at least as narrow as
    the config has it.

    Args:
        config: The config the fit was made under (with its servo calibration file).
        fit: The fit.
        own: The arm's own description (``replaced_calibration(config) or config``), if
            at hand.

    Raises:
        ServoCalibrationError: as :func:`narrowed` (it reaches too little), or the
            config's file cannot be read.
    """
    arm = own if own is not None else (replaced_calibration(config) or config).arm
    fit = narrowed(arm, dataclasses.replace(fit, replaces=servo_of(arm, fit.name)))
    joint = next((j for j in arm.actuated_joints() if j.name == fit.name), None)
    if joint is None or joint.limits is None:
        return fit
    own_limits = (joint.limits.min, joint.limits.max)
    if fit.name not in unrecorded_limits(config):
        return dataclasses.replace(fit, own_limits=own_limits if fit.limits else None)
    return fit.with_limits(fit.limits or own_limits)


def narrowed_limits_note(config: Config) -> str | None:
    """The line naming the limits the config's servo calibration file narrowed, or ``None``.

    The limits as the config has them now (never wider than its arm's own).

    Raises:
        ServoCalibrationError: as :func:`load_servo_calibration`.
    """
    path = config.servo.calibration_file
    if path is None:
        return None
    limits = config.arm.joint_limits()
    limits.update({a.name: a.limits for a in config.arm.tool.actuators})
    narrowed_ones = [
        f"{a.name} to [{limits[a.name].min:g}, {limits[a.name].max:g}] {a.unit}"
        for a in load_servo_calibration(path).actuators
        if a.limits is not None and a.name in limits
    ]
    if not narrowed_ones:
        return None
    return (
        f"note: the servo calibration {path} narrows {', '.join(narrowed_ones)}: its servos, "
        "as calibrated, reach no farther inside their pulse ranges"
    )
