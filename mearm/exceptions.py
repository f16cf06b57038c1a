"""Every error the mearm library raises on purpose, by name, for code that uses mearm.

The commands' own errors (``mearm.maker``'s, ``mearm.tools``': a refused key, an abandoned
calibration, no board found) are not named here: they say why a command stopped and stay
with it, and where a command's work runs inside the library (the servos' calibration at a
sort's start) its error becomes the library's (``StartCalibrationFailed``).

All derive from :class:`~mearm.errors.MearmError`, so one ``except`` catches them all;
subclasses name the cause and keep the offending values as attributes. Each family lives
next to the code that raises it (:data:`FAMILIES`); this module only names them and
imports a family the first time one of its errors is asked for, so
``from mearm.exceptions import ConfigError`` loads neither the simulator nor SciPy.

Inside the package, import an error from its family's module, never from here:
this module names errors of every layer, and a lower layer may not reach them.
"""

from __future__ import annotations

from mearm._lazy import lazy_exports

#: Each module that defines errors, from the base up the layers, and the errors it defines.
FAMILIES: dict[str, tuple[str, ...]] = {
    "mearm.errors": ("MearmError", "ConfigError", "InputFileError"),
    "mearm.config.errors": ("CalibrationError", "ServoCalibrationError", "SerialPortError"),
    "mearm.kinematics.errors": (
        "ModelError",
        "JointLimitError",
        "InvalidJointsError",
        "InvalidTargetError",
        "TargetError",
        "TargetOutsideBoxError",
        "UnreachableTargetError",
        "JointLimitTargetError",
        "SingularTargetError",
    ),
    "mearm.runlog.errors": (
        "RunLogError",
        "RepeatedTrialError",
        "RunLogFormatError",
        "RunLogLockedError",
    ),
    "mearm.ik.errors": ("QPSolverError",),
    "mearm.vision.errors": ("ImageError", "CameraError", "TrackingError", "SampleError"),
    "mearm.hardware.errors": (
        "InvalidCommandError",
        "PulseRangeError",
        "ServoError",
        "ServoNotConnectedError",
        "ServoFaultedError",
        "HandshakeError",
        "FirmwareVersionError",
        "LinkError",
        "PortInUseError",
        "LinkDroppedError",
        "BannerTimeoutError",
        "NoAckError",
        "GarbledReplyError",
        "ChecksumError",
        "BoardError",
        "BoardResetError",
        "MoveNotConfirmedError",
        "UnsolicitedBytesError",
        "ServoStallError",
    ),
    "mearm.view.errors": (
        "ViewError",
        "ViewRunError",
        "ViewPortError",
        "ViewInputError",
        "BrowserNotFoundError",
    ),
    "mearm.analysis.errors": ("AnalysisError",),
    "mearm.dataset.errors": (
        "DatasetError",
        "DatasetExistsError",
        "DatasetWriteError",
        "ExtraMissingError",
        "EncoderError",
    ),
    # The simulators' and the task's errors live beside the one module that raises them.
    "mearm.sim.errors": ("WorldError",),
    "mearm.sim.kinematic.servo_bus": ("SimCollisionError",),
    "mearm.sim.virtual_uno.errors": ("VirtualUnoError",),
    "mearm.task.scene": ("SceneError",),
    "mearm.task.armcheck": (
        "ArmCheckError",
        "CheckInterrupted",
        "NothingToCheck",
        "RigNotOpened",
    ),
    "mearm.task.execute": ("CollisionError",),
    "mearm.task.sorter": ("SortAborted", "StartCalibrationFailed"),
    "mearm.experiment.errors": ("TrialFailed",),
    # the environments' and the baseline's (their packages import Gymnasium: mearm[gym])
    "mearm.envs.errors": ("EnvOptionError", "PolicyError"),
    "mearm.learn.errors": ("DemosError", "LearnExtraMissingError"),
}

_LAZY = {name: module for module, names in FAMILIES.items() for name in names}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
