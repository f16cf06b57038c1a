"""A sort's servos, never calibrated, calibrated by the camera before its first pick.

``servo.calibrate_at_start: when_uncalibrated`` with no ``servo.calibration_file``: once
the arm is at home, the sort runs the procedure of ``mearm calibrate-servos --camera``
(:class:`~mearm.maker.camera_calibration.session.CameraSession`: every move planned in
full and checked against what the servos' errors may still be) and sorts with its fit,
kept in memory for this run (``--save-calibration FILE`` writes it as that command does).
The commands that sort hand the sort :func:`calibrator` (the sort's layer is below this
one, :class:`~mearm.task.sorter.CalibrateFirst`).

**The objects on the table.** The procedure's moves keep ``task.clearance_cm`` from the
objects the camera sees from home (the planner's collision model), and the tool's lowest
point, however far the servos' doubt could lower it, :data:`TABLE_MARGIN_CM` above the
tallest class's top (:func:`floor_cm`): an object the arm hides from the camera at home
is passed over too. (The bins keep the clearance plus the doubt's reach, as in
``mearm calibrate-servos --camera``: ``SafeMoves.over_objects``.)

**A fit that does not converge** (or that the servo file's checks refuse, or with which
the config's consistency checks fail) stops the sort before its first pick
(:class:`~mearm.task.sorter.StartCalibrationFailed`, exit 1) rather than sorting on the
nominal calibration: the sort was asked to run on measured servos, and a fit that fails
means the marker is not where the arm puts it (a loose horn, a camera moved since its
calibration), which the nominal calibration would not survive either. **A camera that
fails** (a black frame, a frozen stream: the procedure's looks pass a
:class:`~mearm.vision.frame_check.FrameCheck`, as the sort's do) stops it the same way,
the camera named (``… by the camera: camera: camera (twin): the stream froze: …``): its
frames show the marker nowhere, or where the arm was, and the fit would be blamed.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mearm.cli import backup_written
from mearm.config import Config
from mearm.config.servo_file import (
    ActuatorFit,
    ServoCalibrationError,
    ServoCalibrationFile,
    apply_servo_calibration,
    now_iso,
    save_servo_calibration,
)
from mearm.errors import ConfigError
from mearm.hardware import ArmCommand, ServoMap
from mearm.hardware.bus import ServoBus
from mearm.kinematics import ArmModel
from mearm.maker.calibrate_by_camera import board_text, measure
from mearm.maker.camera_calibration.errors import CameraCalibrationFailed
from mearm.maker.camera_calibration.session import CameraSession
from mearm.maker.camera_calibration.settings import floor_cm
from mearm.task.check import check_consistency
from mearm.task.rig import Rig
from mearm.task.sorter import CalibrateFirst, StartCalibrationFailed, calibrates_at_start
from mearm.vision import Camera
from mearm.vision.calibration import camera_geometry
from mearm.vision.pinhole import PerspectiveCamera


@dataclass(frozen=True)
class Calibrated:
    """What the calibration at the start gave.

    Attributes:
        config: The sort's configuration with the fit applied.
        fits: The servo file's entries.
        rms_px: The fit's RMS corner residual, the arrivals from above [px].
        poses: The poses the marker was seen at (from above).
        motion_s: The arm's motion: moves, waits for arrival, holds [s].
        board: The board the file records.
        port: Its port.
    """

    config: Config
    fits: list[ActuatorFit]
    rms_px: float
    poses: int
    motion_s: float
    board: str
    port: str

    def line(self) -> str:
        """The one line the sort prints."""
        return (
            f"servos calibrated by the camera (servo.calibrate_at_start): {len(self.fits)} "
            f"servos, rms "
            f"{self.rms_px:.2f} px over {self.poses} poses, {self.motion_s:.1f} s of arm "
            "motion; kept for this run"
        )

    def save(self, output: Path) -> list[str]:
        """Write the fit as ``mearm calibrate-servos`` does: the lines that name what it wrote.

        An existing file is kept as ``<output>.bak`` (or ``.bak.N`` beside an earlier
        backup), named first (``wrote <output>.bak (the old <output>)``), then ``wrote
        <output>``: the sort names every file it writes.
        """
        cal = ServoCalibrationFile(
            self.config.arm.name, self.board, self.port, now_iso(), tuple(self.fits)
        )
        kept: list[str] = []
        written = save_servo_calibration(
            output,
            cal,
            force=True,
            on_backup=lambda backup: kept.append(backup_written(output, backup)),
        )
        return [*kept, f"wrote {written}"]


def calibrate(config: Config, rig: Rig, *, simulated: bool) -> Calibrated:
    """Run the procedure on the open rig, the arm at home: the fit (:func:`hand_over` it).

    Raises:
        CameraCalibrationFailed: the fit did not converge or was refused, or the camera
            failed (a black frame, a frozen stream: ``camera: …``); the arm parked where
            it could be.
        ServoError: a fault while moving (the arm held where it is).
        KeyboardInterrupt: Ctrl-C, the arm parked.
    """
    camera = camera_geometry(config.calibration, config.camera)
    assert isinstance(camera, PerspectiveCamera)  # the sort checked its needs
    session = CameraSession(config, rig, camera, io.StringIO(), floor_cm=floor_cm(config))
    fits = measure(session)
    result = session.result
    assert result is not None  # measure returned: the run gave one
    try:
        calibrated = apply_servo_calibration(config, fits, source="the camera's calibration")
    except (ServoCalibrationError, ConfigError) as exc:
        raise CameraCalibrationFailed(f"refused: {exc}") from None
    board, port = board_text(config, rig, simulate=simulated)
    return Calibrated(
        calibrated, fits, result.above.rms_px, len(session.above), session.motion_s(), board, port
    )


def hand_over(bus: ServoBus, model: ArmModel, config: Config) -> None:
    """The bus sends ``config``'s calibration from now on; the arm holds the same pulses.

    What the arm is at is then read in the new calibration's joints (the sort's next move,
    home, starts there).

    Raises:
        StartCalibrationFailed: that pose lies outside the joints' limits as calibrated
            (narrowed where the fit reaches less): no path from it could be planned
            inside them, and the sort's path home would start from the old calibration's
            joints, where the arm is not. Nothing is sent; the arm holds its pulses.
    """
    chain = model.chain  # config's arm: its limits, narrowed where the fit reaches less
    smap, state = ServoMap.from_arm(config.arm), bus.state
    assert state is not None  # the arm was parked
    held = {j.name: j.command_us(j.servo_value(state.joints)) for j in bus.servo_map.joints}
    q = chain.from_named(smap.joints_of({j.name: j.value_of(held[j.name]) for j in smap.joints}))
    if not chain.within_limits(np.asarray(q), tol=1e-6):
        named, lower, upper = chain.named(q), chain.named(chain.lower), chain.named(chain.upper)
        outside = ", ".join(
            f"{n} = {v:.2f} (limits [{lower[n]:g}, {upper[n]:g}])"
            for n, v in named.items()
            if not lower[n] - 1e-6 <= v <= upper[n] + 1e-6
        )
        raise StartCalibrationFailed(
            f"after the servos' calibration by the camera the arm stands outside its joints' "
            f"limits as calibrated: {outside}; nothing sent, the arm holds its pulses: jog it "
            "inside the limits (mearm jog) and start again"
        )
    bus.servo_map = smap
    bus.move(ArmCommand(chain.named_actuated(q), dict(state.tool), state.gripper_closed))


def calibrator(save: Path | None = None) -> CalibrateFirst:
    """What a sort calls to calibrate its servos first (:class:`~mearm.task.sorter.Sorter`).

    Args:
        save: Where the calibration is written too (``None``: kept in memory only).
    """

    def calibrate_first(
        config: Config, camera: Camera, bus: ServoBus, model: ArmModel, *, simulated: bool
    ) -> tuple[Config, list[str]]:
        try:
            done = calibrate(config, Rig(None, camera, bus, model), simulated=simulated)
            check_consistency(done.config)  # what the sort promises, with the fit
        except CameraCalibrationFailed as exc:
            raise StartCalibrationFailed(f"the servos' calibration by the camera: {exc}") from None
        except ConfigError as exc:
            raise StartCalibrationFailed(
                f"with the servos' calibration by the camera, the config fails: {exc}"
            ) from None
        hand_over(bus, ArmModel(done.config.arm), done.config)
        lines = [done.line()]
        if save is not None:
            lines += done.save(save)
        return done.config, lines

    return calibrate_first


def for_config(config: Config, save: Path | None = None) -> CalibrateFirst | None:
    """:func:`calibrator`, where a sort on ``config`` calibrates first; else ``None``."""
    return calibrator(save) if calibrates_at_start(config) else None
