"""Vision: colour detection, camera → table calibration, camera sources (paper §4).

Everything is keyed by colour class (``task.classes``): build a detector with
``ColorDetector(config.vision, calibration, config.task.classes)`` or
``ColorDetector.from_config(config.vision, config.calibration, config.camera,
config.task.classes)`` (which also takes the calibrated table as the work area). The
simulated camera lives in :mod:`mearm.sim`.

``mearm.vision.paper_recipe`` (the plain NumPy/SciPy recipe) needs SciPy and is not imported
here (the rendered test scenes and the benchmark are ``mearm.sim.kinematic.vision_scenes`` and
``mearm.tools.vision_bench``, above); the ArUco markers (:mod:`mearm.vision.aruco`), which only
calibration needs, are imported on first use.
"""

from __future__ import annotations

from mearm._lazy import lazy_exports
from mearm.vision.calibration import Calibration
from mearm.vision.camera import (
    Camera,
    DeviceCamera,
    FileCamera,
    FolderCamera,
)
from mearm.vision.classify import PixelClassifier, classify_exact
from mearm.vision.detector import ColorDetector, Detection
from mearm.vision.image import probe_image, read_image
from mearm.vision.thresholds import Thresholds
from mearm.vision.tracking import Seen, Tracker, TrackState

#: Public name → the module that defines it; imported on first access.
_LAZY: dict[str, str] = {
    "calibration_from_markers": "mearm.vision.aruco",
    "detect_markers": "mearm.vision.aruco",
}

__all__ = [
    "Calibration",
    "Camera",
    "ColorDetector",
    "Detection",
    "DeviceCamera",
    "FileCamera",
    "FolderCamera",
    "PixelClassifier",
    "Seen",
    "Thresholds",
    "TrackState",
    "Tracker",
    "calibration_from_markers",
    "classify_exact",
    "detect_markers",
    "probe_image",
    "read_image",
]


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, globals(), __all__)
