r"""Calibration pictures from the twin's camera: ChArUco boards in the air, markers on the table.

What a person does to calibrate a real camera, done in the twin: hold a ChArUco board at
many poses in front of the camera (:func:`render_board_views`, for the intrinsics and the
lens distortion), and lay ArUco markers flat on the table at measured places
(:func:`render_sheet`, for the camera's pose). The frames go through the twin's lens
(:class:`~mearm.sim.twin.twin_camera.LensRenderer`), so they are what the calibration tools
would get from a real camera that they know nothing about.

Each picture is printed paper: a textured flat mesh whose texture coordinates are given
vertex by vertex (the board's or the marker's image, with a white margin), no collisions
(``contype`` = ``conaffinity`` = 0). The scene objects are left out and the arm is hidden
(its geoms are put in :data:`HIDDEN_GROUP`, which the renderer does not draw), so that
nothing occludes the pictures; the bins, the table and the twin's light stay.

**Orientation.** MuJoCo's texture coordinate v = 0 is the *first* (top) row of the PNG
(not OpenGL's bottom-left origin: checked by detecting the rendered markers, which come
out mirrored the other way). The meshes give v = row/rows along the quad's +y, so image
rows run along the board frame's +y (OpenCV's board frame: x along the image's columns,
y down its rows, z into the board) and, on the table, a marker's top row faces the base
frame's +y.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import mujoco
import numpy as np

from mearm.config import Config
from mearm.config.errors import CalibrationError
from mearm.kinematics.bodies import object_of
from mearm.sim.twin.mjcf import M_PER_CM, twin_spec
from mearm.sim.twin.twin_camera import CAMERA_NAME, LensRenderer, twin_camera_model
from mearm.vision.aruco import DEFAULT_DICTIONARY, get_dictionary, marker_image
from mearm.vision.charuco import DEFAULT_BOARD, BoardSpec, board_image

#: Geom group the arm is moved to, which the calibration renders do not draw.
HIDDEN_GROUP = 5
#: The markers' paper lies this far above the table top (a sheet's thickness, and clear
#: of the table plane in the depth buffer) [cm].
SHEET_Z_CM = 0.01
#: White margin around a marker [modules] (OpenCV needs ≥ 1 to find its border).
MARKER_MARGIN_MODULES = 1
#: Texture pixels per marker module, and per board square.
PX_PER_MODULE = 32
PX_PER_SQUARE = 100
#: White margin around the board's squares [squares]: the paper it is printed on.
BOARD_MARGIN_SQUARES = 0.5
#: Distance of the board's centre from the camera [cm], and its largest tilt away from
#: facing the camera [deg].
BOARD_DISTANCE_CM = (20.0, 45.0)
BOARD_MAX_TILT_DEG = 40.0
#: A board pose is kept when at least this share of its inner corners projects into
#: the frame (with a margin of :data:`BOARD_EDGE_PX`), and its centre is ≥ 1 cm above the
#: table.
BOARD_MIN_IN_VIEW = 0.75
BOARD_EDGE_PX = 4.0
#: The default marker sheet's marker side [cm].
SHEET_SIDE_CM = 4.0
#: The raised view's markers: their widest spacing along x and y [cm], and the tallest
#: support [cm].
RAISED_SPACING_CM = (16.0, 12.0)
MAX_SUPPORT_CM = 40.0


def _quad_mesh(
    model: mujoco.MjSpec, name: str, x: tuple[float, float], y: tuple[float, float]
) -> None:
    """A flat quad over [x0, x1] × [y0, y1] at z = 0 [m], its face towards −z.

    Texture (u, v) = (0, 1) at (x0, y0), the image's first row along y0: rows run along +y.
    """
    (x0, x1), (y0, y1) = x, y
    model.add_mesh(
        name=name,
        uservert=[x0, y0, 0, x1, y0, 0, x1, y1, 0, x0, y1, 0],
        usertexcoord=[0, 0, 1, 0, 1, 1, 0, 1],
        # wound clockwise seen from +z: the face (and its normal) looks towards −z
        userface=[0, 2, 1, 0, 3, 2],
        inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL,
    )


def _textured(model: mujoco.MjSpec, name: str) -> None:
    model.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, file=f"{name}.png")
    material = model.add_material(name=name, rgba=[1, 1, 1, 1], specular=0, shininess=0,
                                  reflectance=0)  # fmt: skip
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name


def _png(image: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", cv2.cvtColor(image, cv2.COLOR_GRAY2BGR))
    assert ok
    return buf.tobytes()


def _scene_config(config: Config) -> Config:
    """``config`` without scene objects (the pictures are taken of an empty table)."""
    return config.with_scene([])


def _compile(model: mujoco.MjSpec, assets: dict[str, bytes]) -> mujoco.MjModel:
    model.assets = assets
    compiled = model.compile()
    base = mujoco.mj_name2id(compiled, mujoco.mjtObj.mjOBJ_BODY, "base_link")
    arm = compiled.body_rootid[compiled.geom_bodyid] == base
    compiled.geom_group[arm] = HIDDEN_GROUP
    return compiled


def _option() -> mujoco.MjvOption:
    option = mujoco.MjvOption()
    option.geomgroup[HIDDEN_GROUP] = 0
    return option


def _with_noise(frame: np.ndarray, noise_std: float, rng: np.random.Generator) -> np.ndarray:
    if noise_std <= 0:
        return frame
    noisy = frame.astype(np.float32) + rng.normal(0.0, noise_std, frame.shape).astype(np.float32)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)


def _check_noise(noise_std: float) -> None:
    if not 0 <= noise_std <= 255:
        raise CalibrationError(f"noise_std must be in [0, 255] (8-bit levels), got {noise_std!r}")


# --------------------------------------------------------------------------- the board


def board_poses(config: Config, n: int, seed: int, spec: BoardSpec = DEFAULT_BOARD) -> np.ndarray:
    """Seeded poses of the board in front of the twin's camera, (n, 4, 4) base ← board [m].

    The board's frame is OpenCV's (origin at the squares' top-left outer corner, x along
    the rows, y down the columns, z into the board). View i aims the board's centre at a
    point of a 3 × 3 grid over the frame (its corners first, so every few views cover
    the frame's corners) or, after the first nine, anywhere, at
    :data:`BOARD_DISTANCE_CM` from the camera, facing it within
    :data:`BOARD_MAX_TILT_DEG` about a random axis and turned in its plane by up to 30°.

    Raises:
        CalibrationError: ``n`` outside 1 … 200, or no pose keeps the board in view.
    """
    if not 1 <= n <= 200:
        raise CalibrationError(f"the number of board views must be in [1, 200], got {n}")
    truth = twin_camera_model(config)
    K, dist, R_bc = truth.K, truth.dist, truth.R_base_cam
    C = truth.camera_centre_cm * M_PER_CM
    w, h = config.camera.width_px, config.camera.height_px
    size = np.array(spec.size_cm) * M_PER_CM
    inner = np.asarray(spec.board().getChessboardCorners(), dtype=float) * M_PER_CM  # (N, 3)
    rng = np.random.default_rng(seed)
    grid = [(0.18, 0.18), (0.82, 0.18), (0.82, 0.82), (0.18, 0.82), (0.5, 0.5),
            (0.5, 0.2), (0.8, 0.5), (0.5, 0.8), (0.2, 0.5)]  # fmt: skip
    poses = []
    for i in range(n):
        for _ in range(500):
            fu, fv = grid[i] if i < len(grid) else rng.uniform(0.1, 0.9, 2)
            fu, fv = fu + rng.normal(0, 0.03), fv + rng.normal(0, 0.03)
            edge = max(abs(fu - 0.5), abs(fv - 0.5)) > 0.25
            lo, hi = BOARD_DISTANCE_CM
            dist_cm = rng.uniform((lo + hi) / 2 if edge else lo, hi)
            ray_cam = np.linalg.solve(K, [fu * (w - 1), fv * (h - 1), 1.0])
            ray_cam /= np.linalg.norm(ray_cam)
            # facing the camera: z (into the board) along the ray, x along the image's x
            z = ray_cam
            x = np.array([1.0, 0.0, 0.0]) - z[0] * z
            x /= np.linalg.norm(x)
            R_cam_board = np.column_stack([x, np.cross(z, x), z])
            axis_angle = rng.uniform(0, 2 * math.pi)
            axis = R_cam_board @ [math.cos(axis_angle), math.sin(axis_angle), 0.0]
            tilt = math.radians(rng.uniform(0.3, 1.0) * BOARD_MAX_TILT_DEG)
            spin = math.radians(rng.uniform(-30, 30))
            R_cam_board = (
                cv2.Rodrigues(axis * tilt)[0]
                @ R_cam_board
                @ cv2.Rodrigues(np.array([0, 0, spin]))[0]
            )
            centre_cam = ray_cam * dist_cm * M_PER_CM
            origin_cam = centre_cam - R_cam_board @ [size[0] / 2, size[1] / 2, 0.0]
            px, _ = cv2.projectPoints(inner, cv2.Rodrigues(R_cam_board)[0], origin_cam, K, dist)
            px = px.reshape(-1, 2)
            pts_cam = inner @ R_cam_board.T + origin_cam
            inside = (
                (px[:, 0] >= BOARD_EDGE_PX)
                & (px[:, 0] <= w - 1 - BOARD_EDGE_PX)
                & (px[:, 1] >= BOARD_EDGE_PX)
                & (px[:, 1] <= h - 1 - BOARD_EDGE_PX)
                & (pts_cam[:, 2] > 0.05)
            )
            T = np.eye(4)
            T[:3, :3] = R_bc @ R_cam_board
            T[:3, 3] = C + R_bc @ origin_cam
            board_z = (C + R_bc @ centre_cam)[2]
            facing = (R_cam_board[:, 2] @ ray_cam) > math.cos(math.radians(60))
            if inside.mean() >= BOARD_MIN_IN_VIEW and board_z > 0.01 + size.max() / 2 and facing:
                poses.append(T)
                break
        else:
            raise CalibrationError(
                f"no pose of the {spec.size_cm[0]:g}x{spec.size_cm[1]:g} cm board keeps it in "
                f"the twin camera's view (view {i}): check twin.camera"
            )
    return np.array(poses)


def board_model(config: Config, spec: BoardSpec = DEFAULT_BOARD) -> mujoco.MjModel:
    """The twin (no scene objects, arm hidden) with the board as mocap body ``charuco``."""
    model = twin_spec(_scene_config(config))[0]
    image = board_image(spec, PX_PER_SQUARE)
    pad = round(BOARD_MARGIN_SQUARES * PX_PER_SQUARE)
    image = cv2.copyMakeBorder(image, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
    margin = BOARD_MARGIN_SQUARES * spec.square_cm * M_PER_CM
    bw, bh = (s * M_PER_CM for s in spec.size_cm)
    _quad_mesh(model, "charuco", (-margin, bw + margin), (-margin, bh + margin))
    _textured(model, "charuco")
    body = model.worldbody.add_body(name="charuco", mocap=True)
    body.add_geom(name="charuco", type=mujoco.mjtGeom.mjGEOM_MESH, meshname="charuco",
                  material="charuco", contype=0, conaffinity=0, mass=0.01)  # fmt: skip
    return _compile(model, {"charuco.png": _png(image)})


def render_board_views(
    config: Config,
    n: int = 15,
    seed: int = 0,
    spec: BoardSpec = DEFAULT_BOARD,
    *,
    noise_std: float = 0.0,
) -> list[np.ndarray]:
    """The twin camera's frames of a ChArUco board held at ``n`` seeded poses.

    Args:
        config: The whole config (the twin's camera, frame size, table, bins).
        n: Number of views, 1 … 200.
        seed: Seed of the poses (:func:`board_poses`) and of the noise.
        spec: The board.
        noise_std: Gaussian sensor noise on each 8-bit level (std) [levels].

    Returns:
        ``n`` frames, each (h, w, 3) uint8 BGR, through the twin's lens.

    Raises:
        CalibrationError: bad ``n`` or ``noise_std``, or the board cannot be kept in view.
        CameraError: no offscreen rendering, or a lens distortion with no inverse.
    """
    _check_noise(noise_std)
    poses = board_poses(config, n, seed, spec)
    model = board_model(config, spec)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    lens = LensRenderer(model, config, CAMERA_NAME, option=_option())
    rng = np.random.default_rng([seed, 1])
    frames = []
    try:
        for T in poses:
            data.mocap_pos[0] = T[:3, 3]
            quat = np.zeros(4)
            mujoco.mju_mat2Quat(quat, np.ascontiguousarray(T[:3, :3]).ravel())
            data.mocap_quat[0] = quat
            mujoco.mj_forward(model, data)
            frames.append(_with_noise(lens.render(data), noise_std, rng))
    finally:
        lens.close()
    return frames


# --------------------------------------------------------------------------- the markers


def default_sheet_layout(
    config: Config, side_cm: float = SHEET_SIDE_CM
) -> dict[int, tuple[float, float]]:
    """Marker id → centre (x, y) [cm]: up to 12 markers over the field the arm works in.

    A 4 × 3 grid over the calibrated field (what ``calibration.homography`` maps the frame
    to, inset by one marker), clipped to the arm's ``target_box``; points whose marker
    and margin would touch a bin or the arm's base are dropped. Ids 0, 1, … in order.

    Raises:
        CalibrationError: fewer than four markers fit.
    """
    H = np.asarray(config.calibration.homography, dtype=float)
    w, h = config.camera.width_px, config.camera.height_px
    corners = np.array([[0, 0, 1], [w, 0, 1], [w, h, 1], [0, h, 1]], dtype=float) @ H.T
    xy = corners[:, :2] / corners[:, 2:]
    box = config.arm.target_box
    x0, x1 = max(xy[:, 0].min(), box.x_cm.min), min(xy[:, 0].max(), box.x_cm.max)
    y0, y1 = max(xy[:, 1].min(), box.y_cm.min), min(xy[:, 1].max(), box.y_cm.max)
    inset = side_cm
    half = side_cm / 2 * (1 + 2 * MARKER_MARGIN_MODULES / 6) + 0.5  # with margin and a gap
    counts = []
    for lo, hi in ((x0, x1), (y0, y1)):
        span = hi - lo - 2 * inset
        counts.append(max(1, min(4, int(span // (2 * half)) + 1)) if span >= 0 else 0)
    xs = np.linspace(x0 + inset, x1 - inset, counts[0]) if counts[0] > 1 else [(x0 + x1) / 2]
    ys = (
        np.linspace(y1 - inset, y0 + inset, min(3, counts[1])) if counts[1] > 1 else [(y0 + y1) / 2]
    )
    layout: dict[int, tuple[float, float]] = {}
    if 0 in counts:
        ys = []
    for y in ys:
        for x in xs:
            clear = all(
                abs(x - c.bin_cm[0]) > c.bin_inner_width_cm / 2 + half + 1
                or abs(y - c.bin_cm[1]) > c.bin_inner_width_cm / 2 + half + 1
                for c in config.task.classes
            )
            if clear and math.hypot(x, y) > 10 + half:
                layout[len(layout)] = (round(float(x), 2), round(float(y), 2))
    if len(layout) < 4:
        raise CalibrationError(
            f"only {len(layout)} markers of {side_cm:g} cm fit on the calibrated field clear "
            "of the bins: at least 4 are needed"
        )
    return layout


@dataclass(frozen=True)
class Support:
    """A box standing on the table, its top level: the raised view's markers lie on it.

    Attributes:
        centre_cm: Its centre on the table (x, y) [cm].
        size_cm: Its top's sides along x and y [cm].
        height_cm: Its top's height above the table [cm].
    """

    centre_cm: tuple[float, float]
    size_cm: tuple[float, float]
    height_cm: float


def raised_sheet_layout(
    config: Config, height_cm: float, side_cm: float = SHEET_SIDE_CM
) -> tuple[dict[int, tuple[float, float]], Support]:
    """Markers (3 × 2, else 2 × 2; ids 0, 1, …) on a box ``height_cm`` tall, and the box.

    The box stands at the middle of :func:`default_sheet_layout`'s field, or as near it
    as keeps it 1 cm clear of the bins; the markers are spread as far as the twin's
    camera still sees each whole at that height (:data:`RAISED_SPACING_CM` at most),
    the box's top one margin wider than they are.

    Raises:
        CalibrationError: ``height_cm`` not in (0, :data:`MAX_SUPPORT_CM`], or not even four
            markers fit in the camera's view at that height clear of the bins.
    """
    if not (math.isfinite(height_cm) and 0 < height_cm <= MAX_SUPPORT_CM):
        raise CalibrationError(
            f"the support's height must be in (0, {MAX_SUPPORT_CM:g}] cm, got {height_cm!r}"
        )
    xy = np.array(list(default_sheet_layout(config, side_cm).values()))
    middle = (xy.min(axis=0) + xy.max(axis=0)) / 2
    modules = get_dictionary(DEFAULT_DICTIONARY).markerSize + 2
    half = side_cm / 2 * (modules + 2 * MARKER_MARGIN_MODULES) / modules
    shifts = sorted(
        ((dx, dy) for dx in range(-12, 13, 2) for dy in range(-6, 7, 2)),
        key=lambda d: (math.hypot(*d), d),
    )  # the middle first, then ever further from it
    for grid in ((3, 2), (2, 2)):
        sx, sy = RAISED_SPACING_CM
        while min(sx, sy) >= 2 * half + 0.5:
            for dx, dy in shifts:
                centre = (float(middle[0] + dx), float(middle[1] + dy))
                found = _raised_fit(config, grid, centre, (sx, sy), half, height_cm)
                if found is not None:
                    return found
            sx, sy = 0.95 * sx, 0.95 * sy
    raise CalibrationError(
        f"not even four markers of {side_cm:g} cm on a support {height_cm:g} cm tall fit in the "
        "camera's view clear of the bins: use a lower support"
    )


def _raised_fit(
    config: Config,
    grid: tuple[int, int],
    centre: tuple[float, float],
    spacing: tuple[float, float],
    half: float,
    height_cm: float,
) -> tuple[dict[int, tuple[float, float]], Support] | None:
    """The grid of markers and its box at ``centre``, or ``None``.

    ``None`` unless the camera sees every marker whole at that height and the box keeps
    clear of the bins and the base.
    """
    (nx, ny), (cx, cy), (sx, sy) = grid, centre, spacing
    layout = {
        nx * j + i: (
            round(cx + (i - (nx - 1) / 2) * sx, 2),
            round(cy + ((ny - 1) / 2 - j) * sy, 2),
        )
        for j in range(ny)
        for i in range(nx)
    }
    size = ((nx - 1) * sx + 2 * half + 2.0, (ny - 1) * sy + 2 * half + 2.0)
    support = Support((cx, cy), size, float(height_cm))
    if not _support_clear(config, support):
        return None
    corners = np.array(
        [(x + dx * half, y + dy * half, height_cm)
         for x, y in layout.values() for dx in (-1, 1) for dy in (-1, 1)]
    )  # fmt: skip
    truth = twin_camera_model(config)
    in_cam = (corners - truth.camera_centre_cm) @ truth.R_base_cam
    px = cv2.projectPoints(in_cam, np.zeros(3), np.zeros(3), truth.K, truth.dist)[0].reshape(-1, 2)
    w, h = config.camera.width_px, config.camera.height_px
    inside = bool(
        (px >= BOARD_EDGE_PX).all()
        and (px <= [w - 1 - BOARD_EDGE_PX, h - 1 - BOARD_EDGE_PX]).all()
        and (in_cam[:, 2] > 1.0).all()
    )
    return (layout, support) if inside else None


def _support_clear(config: Config, support: Support) -> bool:
    """Whether the support's footprint keeps 1 cm from every bin and 10 cm from the base."""
    (bx, by), (sx, sy) = support.centre_cm, support.size_cm
    for c in config.task.classes:
        reach = c.bin_inner_width_cm / 2 + 1.0 + 1.0  # the bin's wall, then a gap
        if abs(bx - c.bin_cm[0]) < sx / 2 + reach and abs(by - c.bin_cm[1]) < sy / 2 + reach:
            return False
    near_x = max(abs(bx) - sx / 2, 0.0)
    near_y = max(abs(by) - sy / 2, 0.0)
    return math.hypot(near_x, near_y) > 10.0


def _add_support(
    model: mujoco.MjSpec,
    support: Support,
    markers: Mapping[int, tuple[float, float]],
    half_cm: float,
) -> None:
    """The support as a box on the table; each marker with its margin must lie on its top."""
    (bx, by), (sx, sy) = support.centre_cm, support.size_cm
    if not 0 < support.height_cm <= MAX_SUPPORT_CM:
        raise CalibrationError(
            f"the support's height must be in (0, {MAX_SUPPORT_CM:g}] cm, got {support.height_cm!r}"
        )
    for marker_id, (x, y) in markers.items():
        if abs(x - bx) + half_cm > sx / 2 + 1e-9 or abs(y - by) + half_cm > sy / 2 + 1e-9:
            raise CalibrationError(
                f"marker {marker_id} at ({x:g}, {y:g}) cm is not on the support's top "
                f"({sx:g} x {sy:g} cm around ({bx:g}, {by:g}))"
            )
    hz = support.height_cm / 2
    model.worldbody.add_geom(
        name="support", type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[sx / 2 * M_PER_CM, sy / 2 * M_PER_CM, hz * M_PER_CM],
        pos=[bx * M_PER_CM, by * M_PER_CM, hz * M_PER_CM], rgba=[0.62, 0.47, 0.32, 1.0],
    )  # fmt: skip


def sheet_model(
    config: Config,
    markers: Mapping[int, tuple[float, float]],
    side_cm: float,
    dictionary: str = DEFAULT_DICTIONARY,
    *,
    support: Support | None = None,
) -> mujoco.MjModel:
    """The twin (no scene objects, arm hidden) with the markers lying on the table.

    With ``support``, they lie on the top of that box, which stands on the table.
    """
    if not 0.5 <= side_cm <= 50:
        raise CalibrationError(f"the marker side must be in [0.5, 50] cm, got {side_cm!r}")
    if not markers:
        raise CalibrationError("no markers to lay on the table")
    modules = get_dictionary(dictionary).markerSize + 2
    pad = MARKER_MARGIN_MODULES * PX_PER_MODULE
    half_cm = side_cm / 2 * (modules + 2 * MARKER_MARGIN_MODULES) / modules
    ids = sorted(markers)
    for k, a in enumerate(ids):
        for b in ids[k + 1 :]:
            (xa, ya), (xb, yb) = markers[a], markers[b]
            if abs(xa - xb) < 2 * half_cm and abs(ya - yb) < 2 * half_cm:
                raise CalibrationError(
                    f"markers {a} at ({xa:g}, {ya:g}) and {b} at ({xb:g}, {yb:g}) cm overlap "
                    f"(each is {2 * half_cm:.3g} cm across with its white margin): space them "
                    "further apart"
                )
    half = half_cm * M_PER_CM
    model = twin_spec(_scene_config(config))[0]
    z_cm = SHEET_Z_CM
    if support is not None:
        _add_support(model, support, markers, half_cm)
        z_cm += support.height_cm
    _quad_mesh(model, "marker", (-half, half), (-half, half))
    assets = {}
    for marker_id, (x, y) in markers.items():
        image = marker_image(marker_id, modules * PX_PER_MODULE, dictionary)
        image = cv2.copyMakeBorder(image, pad, pad, pad, pad, cv2.BORDER_CONSTANT, value=255)
        name = f"marker_{marker_id}"
        assets[f"{name}.png"] = _png(image)
        _textured(model, name)
        model.worldbody.add_geom(
            name=name, type=mujoco.mjtGeom.mjGEOM_MESH, meshname="marker", material=name,
            pos=[x * M_PER_CM, y * M_PER_CM, z_cm * M_PER_CM],
            # the quad faces −z: turned over about x it faces up, its first row at +y
            quat=[0, 1, 0, 0], contype=0, conaffinity=0,
        )  # fmt: skip
    return _compile(model, assets)


def render_sheet(
    config: Config,
    markers: Mapping[int, tuple[float, float]],
    side_cm: float = SHEET_SIDE_CM,
    dictionary: str = DEFAULT_DICTIONARY,
    *,
    noise_std: float = 0.0,
    seed: int = 0,
    support: Support | None = None,
) -> np.ndarray:
    """The twin camera's frame of ArUco markers lying flat on the empty table.

    Each marker (with a white margin of :data:`MARKER_MARGIN_MODULES` module) has its
    top edge towards +y: its corners TL, TR, BR, BL lie at (x ∓ s/2, y ± s/2) as in
    :func:`~mearm.vision.aruco.table_corners_cm`, :data:`SHEET_Z_CM` above the table.

    Args:
        config: The whole config.
        markers: Marker id → centre (x, y) in the base frame [cm].
        side_cm: Side of each marker, its black border included [cm].
        dictionary: ArUco dictionary.
        noise_std: Gaussian sensor noise (std) [8-bit levels].
        seed: Seed of the noise.
        support: A box the markers lie on instead (:func:`raised_sheet_layout`); its
            top is ``support.height_cm`` above the table.

    Returns:
        The frame, (h, w, 3) uint8 BGR, through the twin's lens.

    Raises:
        CalibrationError: a bad id, side or noise level; no markers; a marker off the
            support's top.
        CameraError: no offscreen rendering, or a lens distortion with no inverse.
    """
    _check_noise(noise_std)
    model = sheet_model(config, markers, side_cm, dictionary, support=support)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    lens = LensRenderer(model, config, CAMERA_NAME, option=_option())
    try:
        frame = lens.render(data)
    finally:
        lens.close()
    # the raised view's noise is its own draw: the table's sheet stays as it was
    stream = 2 if support is None else 4
    return _with_noise(frame, noise_std, np.random.default_rng([seed, stream]))


# --------------------------------------------------------------------------- objects


def render_objects(
    config: Config, *, noise_std: float = 0.0, seed: int = 0
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The twin camera's frame of the scene's objects at rest, the arm hidden, and the truth.

    For measuring where the camera puts objects: nothing but the table, the bins and the
    objects (``config.task.scene``, standing where the scene puts them) is drawn.

    Returns:
        The frame ((h, w, 3) uint8 BGR, through the twin's lens) and each object's id →
        its true table position (x, y) [cm], (2,) (its body's centre, from the physics).

    Raises:
        CalibrationError: a bad noise level.
        CameraError: no offscreen rendering, or a lens distortion with no inverse.
    """
    _check_noise(noise_std)
    model = _compile(twin_spec(config)[0], {})
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("home").id)
    mujoco.mj_forward(model, data)
    truth = {}
    for i in range(model.nbody):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, i) or ""
        oid = object_of(name)
        if oid is not None:
            truth[oid] = data.xpos[i][:2] / M_PER_CM
    lens = LensRenderer(model, config, CAMERA_NAME, option=_option())
    try:
        frame = lens.render(data)
    finally:
        lens.close()
    return _with_noise(frame, noise_std, np.random.default_rng([seed, 3])), truth
