"""Vision: colour detection, camera → table calibration, camera sources (SPEC §4).

``mearm.vision.reference`` (the plain NumPy/SciPy recipe) and ``mearm.vision.bench``
need SciPy and are not imported here.
"""

from mearm.vision.aruco import calibration_from_markers, detect_markers
from mearm.vision.calibration import Calibration
from mearm.vision.camera import (
    Camera,
    DeviceCamera,
    FileCamera,
    FolderCamera,
    SimCamera,
    open_camera,
)
from mearm.vision.classify import PixelClassifier, classify_exact
from mearm.vision.detector import ColorDetector, Detection
from mearm.vision.presets import PRESETS, Thresholds, resolve_thresholds
from mearm.vision.render import (
    DISTRACTOR_BGR,
    OBJECT_BGR,
    Disc,
    Highlight,
    Paper,
    Shadow,
    TableRenderer,
)

__all__ = [
    "DISTRACTOR_BGR",
    "OBJECT_BGR",
    "PRESETS",
    "Calibration",
    "Camera",
    "ColorDetector",
    "Detection",
    "DeviceCamera",
    "Disc",
    "FileCamera",
    "FolderCamera",
    "Highlight",
    "Paper",
    "PixelClassifier",
    "Shadow",
    "SimCamera",
    "TableRenderer",
    "Thresholds",
    "calibration_from_markers",
    "classify_exact",
    "detect_markers",
    "open_camera",
    "resolve_thresholds",
]
