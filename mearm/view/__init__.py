"""The meshcat view of the rig (issue 6, item 3) and its headless screenshots.

:class:`ArmView` serves the scene on 127.0.0.1; :func:`screenshot` renders any view URL
in headless Chromium. Layer: after kinematics and vision, before the task loop.
"""

from mearm.view.arm_view import PALETTE, ArmView, ViewObject
from mearm.view.browser import find_browser, screenshot
from mearm.view.camera import DEFAULT_CAMERA, ViewCamera
from mearm.view.frame_plane import FramePlane, frame_plane
from mearm.view.server import MeshcatServer

__all__ = [
    "DEFAULT_CAMERA",
    "PALETTE",
    "ArmView",
    "FramePlane",
    "MeshcatServer",
    "ViewCamera",
    "ViewObject",
    "find_browser",
    "frame_plane",
    "screenshot",
]
