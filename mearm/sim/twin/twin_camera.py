r"""The physical twin's camera: MuJoCo renders what the camera above the table sees.

It stands behind the same :class:`~mearm.vision.camera.Camera` interface as a real
camera, so the detector sees perspective, light and shadow as the twin's physics left
them: an object dropped or knocked over is seen where it lies. Rendering is offscreen on
the CPU; on Linux without a display ``MUJOCO_GL`` defaults to ``egl`` (Mesa), set before
MuJoCo is first imported (:mod:`mearm`).

**What a frame costs** (measured, simulated scenes: the paper's scene mid-sort at
640×480, Mesa 'llvmpipe' on the 2-core development machine, median CPU time of 60 frames
interleaved, two runs, at a load of 11 from other work): MuJoCo's defaults, 4× MSAA
(``vis.quality.offsamples``) and the light's 4096² shadow map, 56–69 ms; without MSAA
34–44 ms; 4× MSAA without shadows 16–18 ms; neither 4.6–5.4 ms. Nearly all of it is
``mjr_render`` (the shadow pass and its lookup in every fragment, the multisampled buffer);
reading the pixels back costs 0.4 ms (4–8 ms with MSAA, which resolves the samples
first), ``mjv_updateScene`` 0.1 ms, flipping the rows and turning RGB to BGR about
0.2 ms. ``MUJOCO_GL=osmesa`` is the same Mesa rasteriser and costs the same (4.6–5.4 ms
against EGL's 4.9–5.0 ms, the same runs); EGL is kept, as OSMesa needs
``PYOPENGL_PLATFORM=osmesa`` and its context, when a renderer is left unclosed at exit,
fails in ``__del__`` with PyOpenGL's ``ctypes.ArgumentError`` (its handler for ``None``
cannot be imported while Python shuts down). Opening a renderer (its GL context, the
model's meshes and textures) costs 45–90 ms without MSAA and shadows and 180–360 ms with
them, once per sort.

**The sorter's frames** (:class:`TwinCamera`) are rendered without MSAA or shadows
(:data:`SORTER_MSAA_SAMPLES`, :data:`SORTER_SHADOWS`): on every frame the paper's, the
5-DOF arm's and the perspective rig's sorts read (69 frames), the detector found the same
objects on the table, not merged, as in the full-quality frame; centroids moved by 0.48 px
at most and table positions by 0.065 cm. The shadows fall beside the objects and into the
bins, which the sorter does not pick from.

**Under a lamp** (``twin.lamp``, :class:`~mearm.config.twin_lamp_config.TwinLampConfig`)
the sorter's frames keep the lamp's shadows, which are what such frames are for; a
640×480 frame of the paper's scene then cost a median 27–30 ms of CPU with the lamp's
2048² shadow map (20 ms at 1024², 63 ms at 4096²; frames interleaved, two runs on the
loaded 2-core machine, simulated) against 4.9–5.0 ms without a lamp, and 5.0–5.1 ms
under the lamp with ``shadows: false``.

**The calibration pictures**
(:mod:`~mearm.sim.twin.calibration_scenes`) keep both: the sub-pixel fits need MSAA.
Scored as ``mearm camera-accuracy`` scores them (55 cm, tilted 8°, 10 scenes of 12 per
height, one calibration), objects 1 cm / 2.5 cm tall are located within 0.010 / 0.014 cm
mean (0.029 / 0.062 max) in MSAA frames and 0.018 / 0.020 cm (0.063 / 0.053) without;
leaving out the shadows changes neither (0.010 / 0.014).

**Where the camera is** (:func:`camera_pose`): by default straight down from
:data:`~mearm.sim.twin.mjcf.CAMERA_HEIGHT_M` over the calibrated field's centre, yawed and
with the field of view that make ``calibration.homography`` hold on the table; with
``twin.camera`` set (:class:`~mearm.config.twin_camera_config.TwinCameraConfig`), wherever that
puts it, tilted, with any field of view.

**The pinhole** (:func:`twin_camera_model`): MuJoCo's ``fovy`` spans the frame's full
height and its pixels are square, so

.. math::

    f_x = f_y = \frac{h/2}{\tan(\mathrm{fovy}/2)}, \qquad
    c_x = \frac{w - 1}{2}, \quad c_y = \frac{h - 1}{2}

in OpenCV's pixel convention (pixel (0, 0)'s *centre* is at (0, 0); the frame's outer
edge at −0.5 and w − 0.5), which is what ``cv2.projectPoints`` and every detector use.

**The lens**: with non-zero ``distortion`` (k1 k2 p1 p2 k3, OpenCV's model) each frame is
rendered as the ideal pinhole picture, with a margin wide enough to hold every point the
lens bends into the frame, and remapped once per frame: output pixel :math:`p_d` takes the
ideal pixel :math:`p_u` with :math:`p_d = K\,\mathrm{distort}(K^{-1}p_u)`, i.e.
:math:`p_u = K\,\mathrm{undistort}(K^{-1}p_d)` (``cv2.undistortPoints``, iterated to
convergence). ``cv2.initUndistortRectifyMap`` computes the other direction (for every
*ideal* pixel where it lies in the distorted picture) and is what removes distortion, not
what adds it.
"""

from __future__ import annotations

import copy
import functools
import math
from typing import TYPE_CHECKING

import cv2
import mujoco
import numpy as np

from mearm.config import Config
from mearm.sim.twin.frame_drawer import close_renderer, offscreen_renderer
from mearm.sim.twin.twin_frame_state import TwinFrameSource, pack_frame_state
from mearm.sim.twin.twin_optics import (  # noqa: F401  (re-exported: where the camera is)
    CAMERA_HEIGHT_M,
    M_PER_CM,
    CameraPose,
    TwinCameraModel,
    camera_pose,
    homography_view,
    twin_camera_model,
)
from mearm.vision.camera import NumberedCamera
from mearm.vision.errors import CameraError

if TYPE_CHECKING:
    from mearm.sim.twin.twin_bus import TwinArm

#: The camera's name in the twin's MJCF (:mod:`mearm.sim.twin.mjcf`).
CAMERA_NAME = "camera"
#: The sorter's frames: no multisampling, no shadows (:class:`TwinCamera`; the
#: calibration pictures keep MuJoCo's 4× MSAA and 4096² shadow map): about 5 ms of CPU a
#: frame instead of about 60, the same objects found (the module docstring has the figures).
SORTER_MSAA_SAMPLES = 0
SORTER_SHADOWS = False
#: The lens maps must invert the distortion to within this [px]; a stronger distortion
#: folds over inside the frame and has no single inverse.
LENS_INVERSE_TOL_PX = 1e-3
#: The ideal picture rendered under a distorting lens may be at most this many times the
#: frame's side (its margin holds what the lens bends into view).
MAX_LENS_MARGIN_FACTOR = 3.0


class LensRenderer:
    """Renders the twin's camera through its lens: ideal pinhole, then distortion.

    Args:
        model: The twin's model (it is not changed: a distorting lens renders from a copy
            whose camera sees a margin more).
        config: The whole config (frame size, ``twin.camera``'s lens).
        camera: The camera's name in ``model``.
        option: What to draw (geom groups, …); ``None``: MuJoCo's defaults.
        msaa_samples: Multisamples per pixel (``vis.quality.offsamples``); ``None``: the
            model's (MuJoCo's default, 4). 0 renders aliased edges, at about half the cost.
        shadows: Draw the light's shadows (a shadow map of the model's
            ``vis.quality.shadowsize``, 4096² by default); ``False`` costs neither the
            shadow pass nor the map's memory.

    Raises:
        CameraError: no offscreen OpenGL context could be made, or the distortion has no
            inverse over the frame (it folds over).
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        config: Config,
        camera: str = CAMERA_NAME,
        option: mujoco.MjvOption | None = None,
        *,
        msaa_samples: int | None = None,
        shadows: bool = True,
    ):
        self.camera = camera
        self.option = option
        self.shadows = shadows
        w, h = config.camera.width_px, config.camera.height_px
        self.size_px = (w, h)
        truth = twin_camera_model(config)
        self._maps: tuple[np.ndarray, np.ndarray] | None = None
        render_model, rw, rh = model, w, h
        if np.any(truth.dist != 0):
            map_x, map_y, mx, my = _lens_maps(truth.K, truth.dist, (w, h))
            self._maps = (map_x, map_y)
            rw, rh = w + 2 * mx, h + 2 * my
            render_model = copy.copy(model)
            cam_id = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
            fy = truth.K[1, 1]
            render_model.cam_fovy[cam_id] = 2 * math.degrees(math.atan(rh / 2 / fy))
            render_model.vis.global_.offwidth = max(rw, model.vis.global_.offwidth)
            render_model.vis.global_.offheight = max(rh, model.vis.global_.offheight)
        self._model = render_model
        if msaa_samples is None:
            msaa_samples = int(render_model.vis.quality.offsamples)
        self.msaa_samples = msaa_samples
        try:
            self._renderer = offscreen_renderer(
                render_model, (rw, rh), msaa_samples=msaa_samples, shadows=shadows
            )
        except Exception as exc:  # MuJoCo raises plain errors for a missing GL
            raise CameraError(
                "twin",
                f"cannot render offscreen ({type(exc).__name__}: {exc}); install Mesa's EGL "
                "or OSMesa and set MUJOCO_GL=egl or MUJOCO_GL=osmesa",
            ) from None

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """The camera's frame of ``data``'s state, (h, w, 3) uint8 BGR."""
        self._renderer.update_scene(data, camera=self.camera, scene_option=self.option)
        bgr = cv2.cvtColor(self._renderer.render(), cv2.COLOR_RGB2BGR)
        if self._maps is None:
            return bgr
        return cv2.remap(bgr, *self._maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    @property
    def distorts(self) -> bool:
        """Whether a lens distorts the frames (remapped from a larger picture)."""
        return self._maps is not None

    def render_rgb(self, data: mujoco.MjData, out: np.ndarray) -> bool:
        """Draw ``data``'s frame straight into ``out``, (h, w, 3) uint8 RGB; whether it could.

        Without a lens only (a lens remaps a larger picture): no BGR conversion, no new
        array; MuJoCo reads the pixels back into ``out`` itself.
        """
        if self._maps is not None:
            return False
        self._renderer.update_scene(data, camera=self.camera, scene_option=self.option)
        self._renderer.render(out=out)
        return True

    def close(self) -> None:
        """Free the renderer's GL context (:func:`~mearm.sim.twin.frame_drawer.close_renderer`)."""
        close_renderer(self._renderer)


def _lens_maps(
    K: np.ndarray, dist: np.ndarray, size_px: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """Remap tables from an ideal picture with margins (mx, my) to the distorted frame.

    Inverting the lens over every pixel costs about 0.4 s at 640x480, and a process makes
    the same camera many times (each calibration picture, each trial of an experiment):
    the tables are kept, read-only, for the lenses seen last.

    Returns:
        map_x, map_y: for each output (distorted) pixel, where it is in the ideal
        picture rendered with ``mx``, ``my`` extra pixels on each side, (h, w) float32
        [px]; and mx, my [px].

    Raises:
        CameraError: the distortion folds over inside the frame (no inverse).
    """
    flat = tuple(float(x) for x in np.asarray(K, dtype=np.float64).ravel())
    coefficients = tuple(float(x) for x in np.asarray(dist, dtype=np.float64).ravel())
    return _lens_maps_of(flat, coefficients, (int(size_px[0]), int(size_px[1])))


def _distorted_px(K: np.ndarray, dist: np.ndarray, undistorted_px: np.ndarray) -> np.ndarray:
    """Where the lens puts the points an ideal pinhole ``K`` puts at ``undistorted_px``, (N, 2).

    OpenCV's model of five coefficients (k1, k2, p1, p2, k3), as ``cv2.projectPoints``
    applies it (it reads fx, fy, cx and cy of ``K``: no skew), worked in NumPy: on a
    640×480 frame's every pixel in 31 ms of CPU, where ``projectPoints`` took 120 ms (220
    ms as the first call of a process), the two within 1e-12 px.
    """
    k1, k2, p1, p2, k3 = (float(c) for c in dist)
    fx, cx, fy, cy = K[0, 0], K[0, 2], K[1, 1], K[1, 2]
    x = (undistorted_px[:, 0] - cx) / fx
    y = (undistorted_px[:, 1] - cy) / fy
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return np.stack([fx * xd + cx, fy * yd + cy], axis=1)


@functools.lru_cache(maxsize=4)
def _lens_maps_of(
    K_flat: tuple[float, ...], dist_flat: tuple[float, ...], size_px: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """:func:`_lens_maps` of hashable values."""
    K, dist = np.reshape(K_flat, (3, 3)), np.asarray(dist_flat)
    w, h = size_px
    u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64))
    p_d = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    p_u = cv2.undistortPoints(p_d, K, dist, R=np.eye(3), P=K, criteria=criteria).reshape(-1, 2)
    # check the inverse: distorting p_u again must give p_d back
    back = _distorted_px(K, dist, p_u)
    err = float(np.max(np.abs(back - p_d.reshape(-1, 2))))
    if not err <= LENS_INVERSE_TOL_PX:
        raise CameraError(
            "twin",
            f"twin.camera.distortion {tuple(float(d) for d in dist)} folds the frame over "
            f"(no inverse within {LENS_INVERSE_TOL_PX} px; off by {err:.3g} px): use smaller "
            "coefficients",
        )
    mx = math.ceil(max(0.0, -p_u[:, 0].min(), p_u[:, 0].max() - (w - 1))) + 2
    my = math.ceil(max(0.0, -p_u[:, 1].min(), p_u[:, 1].max() - (h - 1))) + 2
    if w + 2 * mx > MAX_LENS_MARGIN_FACTOR * w or h + 2 * my > MAX_LENS_MARGIN_FACTOR * h:
        raise CameraError(
            "twin",
            f"twin.camera.distortion {tuple(float(d) for d in dist)} bends points from "
            f"{mx} px beyond the frame's side into view (more than "
            f"{MAX_LENS_MARGIN_FACTOR:g}x the frame): use smaller coefficients",
        )
    map_x = (p_u[:, 0] + mx).reshape(h, w).astype(np.float32)
    map_y = (p_u[:, 1] + my).reshape(h, w).astype(np.float32)
    map_x.setflags(write=False)
    map_y.setflags(write=False)
    return map_x, map_y, mx, my


def sorter_shadows(config: Config) -> bool:
    """Whether the sorter's frames draw shadows: only under a lamp that casts them.

    Without ``twin.lamp`` the light straight down casts each object's shadow beside it
    in the camera's perspective, which the detector does not need (:data:`SORTER_SHADOWS`);
    a configured lamp's shadows are what the frames are for.
    """
    lamp = config.twin.lamp
    return SORTER_SHADOWS if lamp is None else lamp.shadows


class TwinCamera(NumberedCamera):
    """Frames rendered from the twin's camera, at ``camera.width_px × height_px``.

    With ``twin.camera.distortion`` set, each frame goes through the lens
    (:class:`LensRenderer`). Frames are rendered without MSAA or shadows, at about a
    twelfth of the cost, with the same objects found in them (module docstring); under a
    ``twin.lamp`` that casts shadows, with its shadows (:func:`sorter_shadows`), still
    without MSAA.

    Args:
        config: The whole config (``camera`` gives the frame size, ``twin.camera`` the lens).
        twin: The twin whose state is rendered (its ``model`` and ``data``).

    Raises:
        CameraError: no offscreen OpenGL context could be made (install Mesa's EGL or
            OSMesa, and set ``MUJOCO_GL=egl`` or ``osmesa``), or the lens distortion has
            no inverse over the frame.
    """

    def __init__(self, config: Config, twin: TwinArm):
        cam = config.camera
        super().__init__("twin", (cam.width_px, cam.height_px))
        self.twin = twin
        self._lens = LensRenderer(
            twin.model, config, msaa_samples=SORTER_MSAA_SAMPLES, shadows=sorter_shadows(config)
        )
        self._config = config
        self.frames_read = 0
        #: The last frame rendered and its time (what a frozen stream repeats).
        self._rendered: tuple[np.ndarray, float] | None = None
        self._camera_id = twin.model.camera(CAMERA_NAME).id
        self._mount_m = twin.data.cam_xpos[self._camera_id].copy()

    def _read(self) -> np.ndarray:
        now = self.twin.time_s
        faults = self.twin.faults.camera(now)
        self._bump(faults.shift_m)
        if faults.frozen_at_s is not None and self._rendered is not None:
            frame, self.frame_time_s = self._rendered  # the stream froze: the stale frame again
            return frame.copy()
        frame = self._lens.render(self.twin.data)
        if faults.black:
            frame[:] = 0
        self.frames_read += 1
        self.frame_time_s = now
        if faults.frozen_at_s is None or self._rendered is None:
            self._rendered = (frame.copy(), now)
        return frame

    def peek_rgb(self, out: np.ndarray) -> None:
        """The frame :meth:`peek` gives, drawn into ``out`` as RGB, (h, w, 3) uint8.

        A recording's frame: rendered into the buffer the encoder reads (no conversion, no
        copy), and it leaves the camera as it was: the frames the sort reads, their count
        and what a frozen stream repeats are the same as without the recording. Under a
        camera fault or a lens it is :meth:`peek`'s frame, converted.
        """
        faults = self.twin.faults.camera(self.twin.time_s)
        clear = faults.frozen_at_s is None and not faults.black
        if self._closed or not clear:
            cv2.cvtColor(self.peek(), cv2.COLOR_BGR2RGB, dst=out)
            return
        self._bump(faults.shift_m)
        if not self._lens.render_rgb(self.twin.data, out):
            cv2.cvtColor(self.peek(), cv2.COLOR_BGR2RGB, dst=out)

    def frame_source(self) -> TwinFrameSource | None:
        """What another process needs to draw this camera's frames; ``None`` under a lens.

        A recording's frames are then drawn there from :meth:`frame_state`
        (:mod:`mearm.sim.twin.twin_frame_state`), pixel for pixel as :meth:`peek_rgb`.
        """
        lens = self._lens
        if lens.distorts or lens.option is not None:
            return None
        return TwinFrameSource(
            self.twin.model, lens.size_px, lens.camera, lens.msaa_samples, lens.shadows
        )

    def frame_state(self, out: np.ndarray) -> bool:
        """Write the state :meth:`peek_rgb`'s frame is drawn from into ``out``; whether it is one.

        ``False`` under a camera fault, a lens or once closed: the frame is then
        :meth:`peek_rgb`'s, drawn here. Leaves the camera as it was.
        """
        faults = self.twin.faults.camera(self.twin.time_s)
        if self._closed or self._lens.distorts or faults.frozen_at_s is not None or faults.black:
            return False
        self._bump(faults.shift_m)
        pack_frame_state(self.twin.data, out)
        return True

    @property
    def clock_s(self) -> float:
        """The twin's simulated time [s]: its frames' clock."""
        return self.twin.time_s

    def _bump(self, shift_m: np.ndarray) -> None:
        """Put the camera ``shift_m`` from its mount [m], (3,) (``camera_bump``).

        The camera hangs from the world body, whose frame MuJoCo does not compute again
        after the model is made: its place in the data is where it is rendered from.
        """
        self.twin.data.cam_xpos[self._camera_id] = self._mount_m + shift_m

    def close(self) -> None:  # noqa: D102
        if not self._closed:
            self._lens.close()
        super().close()
