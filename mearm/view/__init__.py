"""The meshcat view of the rig (issue 6, item 3) and its headless screenshots.

:class:`ArmView` serves the scene of any arm and class set on 127.0.0.1;
:func:`screenshot` renders any view URL in headless Chromium. Layer: after kinematics
and vision, before the task loop.
"""

import warnings

# meshcat 0.3.2 imports pyzmq's deprecated zmq.eventloop.ioloop; nothing for us to act on.
warnings.filterwarnings(
    "ignore", message="zmq.eventloop.ioloop is deprecated", category=DeprecationWarning
)

from mearm.view.arm_view import ArmView, TwinBody, ViewObject, rgb_int  # noqa: E402
from mearm.view.browser import (  # noqa: E402
    HeadlessBrowser,
    SceneCounts,
    find_browser,
    screenshot,
)
from mearm.view.frame_plane import FramePlane, frame_plane  # noqa: E402
from mearm.view.layout import SceneLayout  # noqa: E402
from mearm.view.server import MeshcatServer  # noqa: E402
from mearm.view.viewpoint import DEFAULT_CAMERA, ViewCamera  # noqa: E402

__all__ = [
    "DEFAULT_CAMERA",
    "ArmView",
    "FramePlane",
    "HeadlessBrowser",
    "MeshcatServer",
    "SceneLayout",
    "SceneCounts",
    "TwinBody",
    "ViewCamera",
    "ViewObject",
    "find_browser",
    "frame_plane",
    "rgb_int",
    "screenshot",
]
