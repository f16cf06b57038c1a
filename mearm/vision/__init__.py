"""Vision: colour detection, camera → table calibration, camera sources (paper §4).

Everything is keyed by colour class (``task.classes``): build a detector with
``ColorDetector(config.vision, calibration, config.task.classes)`` or
``ColorDetector.from_config(config)``. The simulated camera lives in :mod:`mearm.sim`.

``mearm.vision.reference`` (the plain NumPy/SciPy recipe), ``mearm.vision.scenes`` and
``mearm.vision.bench`` (rendered test scenes, the benchmark) need SciPy or the simulator
and are not imported here.
"""

from mearm.vision.aruco import calibration_from_markers, detect_markers
from mearm.vision.calibration import Calibration
from mearm.vision.camera import (
    Camera,
    DeviceCamera,
    FileCamera,
    FolderCamera,
    open_camera,
)
from mearm.vision.classify import PixelClassifier, classify_exact
from mearm.vision.detector import ColorDetector, Detection
from mearm.vision.image import probe_image, read_image
from mearm.vision.thresholds import Thresholds

__all__ = [
    "Calibration",
    "Camera",
    "ColorDetector",
    "Detection",
    "DeviceCamera",
    "FileCamera",
    "FolderCamera",
    "PixelClassifier",
    "Thresholds",
    "calibration_from_markers",
    "classify_exact",
    "detect_markers",
    "open_camera",
    "probe_image",
    "read_image",
]
