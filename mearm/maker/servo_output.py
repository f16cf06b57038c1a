"""What both servo calibration procedures share: the board's name, holding the arm, the file.

The keyboard procedure (:mod:`mearm.maker.calibrate_servos`) and the camera's
(:mod:`mearm.maker.calibrate_by_camera`) write the same servo calibration file, through
the same refusals (:func:`write_calibration`).
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import EXIT_FAILURE, EXIT_OK, backup_written, check_yaml_output, say_on_stderr
from mearm.config import Config
from mearm.config.servo_file import (
    ActuatorFit,
    ServoCalibrationError,
    ServoCalibrationFile,
    actuator_paths,
    apply_servo_calibration,
    check_fit,
    check_replace,
    load_servo_calibration,
    now_iso,
    replaced_calibration,
    save_servo_calibration,
    servo_of,
    servo_overrides,
)
from mearm.errors import ConfigError, MearmError
from mearm.hardware.bus import ServoBus


def board_identity(bus: ServoBus) -> tuple[str, str]:
    """The board's id (from its banner, else its version reply) and its port.

    A simulated board (the virtual Uno: ``simulated_as``) is said to be one, with no
    port (its pseudo-terminal is gone with the command): a calibration measured on its
    simulated arm is not taken for a real arm's.
    """
    port = str(getattr(bus, "port", ""))
    banner = getattr(bus, "banner", None)
    simulated = getattr(bus, "simulated_as", None)
    if isinstance(banner, bytes) and banner:
        text = banner.decode("ascii", "replace").split("*")[0].strip()
        text = text.removeprefix("READY").strip()
        if simulated:
            return f"simulated: {simulated} ({text})", ""
        return text, port
    version = getattr(bus, "version", None)
    if version:
        return str(version), port
    return f"simulated ({type(bus).__name__}, servo.backend: sim)", port


def check_output(output: Path, *, force: bool) -> None:
    """Refuse to replace an existing calibration file without ``--force``.

    Raises:
        MearmError: ``output`` is a folder or a device, or cannot be written
            (:func:`~mearm.cli.check_yaml_output`); it exists and ``force`` is not given;
            or it is a file that is not a servo calibration.
    """
    check_yaml_output(output, "--output")
    if output.exists():
        if not force:
            raise MearmError(
                f"{output} exists: pass --force to replace it (the old one is kept as "
                f"{output.name}.bak)"
            )
        check_replace(output)


def write_calibration(
    config: Config,
    fits: Sequence[ActuatorFit],
    board: str,
    port: str,
    output: Path,
    *,
    force: bool,
) -> int:
    """Check the fits together, write the file, print how a config uses it.

    Each fit is checked again (:func:`~mearm.config.servo_file.check_fit`) and all of
    them together with the config's checks: one refused, nothing is written (exit 1). A
    file replaced (``force``) is kept as ``<output>.bak``, named on stdout before the file
    itself, as every file a command writes is. The replaced file's fits of the arm's
    other actuators, those not calibrated in this session (skipped, or left out of
    ``--actuators``), are kept in the new file and named (:func:`kept_fits`): a session
    that recalibrates the base alone no longer leaves the config's file with the base
    alone, the others silently back on their nominal calibration.

    Raises:
        MearmError: the file could not be written (a full disk…); the fits are printed
            first as ``--set`` overrides, so the session's measurements are kept.
    """
    if not fits:
        say_on_stderr("no actuator calibrated: nothing written")
        return EXIT_FAILURE
    # a config that uses the file applies it to the arm's own calibration, limits too
    own = replaced_calibration(config) or config
    kept, dropped = kept_fits(own, fits, output)
    now = len(fits)
    fits = [*fits, *kept]
    try:
        for fit in fits:
            check_fit(own.arm, fit, servo_of(own.arm, fit.name))
        apply_servo_calibration(own, fits, source="the calibration")
    except (ServoCalibrationError, ConfigError) as exc:
        print(f"mearm calibrate-servos: refused: {exc}; nothing written", file=sys.stderr)
        return EXIT_FAILURE
    cal = ServoCalibrationFile(config.arm.name, board, port, now_iso(), tuple(fits))
    try:
        written = save_servo_calibration(
            output, cal, force=force, on_backup=lambda kept: print(backup_written(output, kept))
        )
    except ServoCalibrationError as exc:
        # the session's measurements (a real arm's can be 20 minutes of jogging) are not
        # lost with the file: the fits go to stdout as overrides, then the error (exit 2)
        print("not written; the fits, as overrides for a command or the config's servos:")
        _print_overrides(config, fits)
        raise MearmError(f"{exc}; the fits are printed above as --set overrides") from None
    what = f"{now} actuator{'s' if now != 1 else ''}"
    if kept:
        what += f"; {', '.join(f.name for f in kept)} kept from the file it replaced"
    if dropped:
        what += f"; {', '.join(dropped)} not kept (its fit no longer fits the arm)"
    print(f"wrote {written} ({what})")
    print(
        f"to use it, add to the config's servo section:  calibration_file: {written}\n"
        "(this path, or one relative to the config's folder), or add these overrides to a "
        "command:"
    )
    _print_overrides(config, fits)
    return EXIT_OK


def kept_fits(
    own: Config, fits: Sequence[ActuatorFit], output: Path
) -> tuple[list[ActuatorFit], list[str]]:
    """The fits ``output`` holds of the arm's actuators not in ``fits``, and those dropped.

    Only from a calibration file of the same arm; each kept fit passes its checks
    against the arm's own calibration (:func:`~mearm.config.servo_file.check_fit`), and
    one that no longer does is named among the dropped.
    """
    if not output.is_file():
        return [], []
    try:
        old = load_servo_calibration(output)
    except MearmError:  # (check_replace let only a calibration file this far)
        return [], []
    if old.arm != own.arm.name:
        return [], []
    now = {f.name for f in fits}
    known = set(actuator_paths(own.arm))
    kept, dropped = [], []
    for fit in old.actuators:
        if fit.name in now or fit.name not in known:
            continue
        try:
            check_fit(own.arm, fit, servo_of(own.arm, fit.name))
        except (ServoCalibrationError, ConfigError):
            dropped.append(fit.name)
        else:
            kept.append(fit)
    return kept, dropped


def _print_overrides(config: Config, fits: Sequence[ActuatorFit]) -> None:
    for line in servo_overrides(config.arm, fits):
        print(f"  --set '{line}'")
    sys.stdout.flush()


def hold_arm(bus: ServoBus) -> None:
    """Ask the bus to hold where it is (sends no new pulse); a failure is only reported."""
    try:
        bus.stop()
    except MearmError as exc:
        say_on_stderr(f"note: could not send hold: {exc}")
