"""Render the docs' pictures from the code, so they stay true when the code changes.

Each group writes PNGs under ``docs/images/`` (``--out`` elsewhere):

- ``twin``: the physical twin (MuJoCo, offscreen) mid-sort, the moment an object is carried
  highest: the paper's arm (``twin_sorting.png``), the conveyor belt
  (``twin_conveyor.png``) and the shapes (``twin_shapes.png``); simulated, seed 0;
- ``frames``: a reference arm at home from the side and from above, drawn from its own
  description with OpenCV: the base frame's origin and axes, each joint's zero and its
  positive direction (``frames_mearm_v1.png``, ``frames_mearm_paper.png``);
- ``views``: each reference config's arm at home in the meshcat view, saved by headless
  Chromium (``view_<config stem>.png``; needs chromium);
- ``env``: ``mearm/PickPlace-v0`` mid-episode, the sorter stepped as the policy: what
  ``render()`` shows beside the observation's ``pixels`` (``env_pick_place.png``;
  simulated, seed 0; needs Gymnasium);
- ``dataset``: one pick-and-place recorded by ``mearm sort --record`` in the twin, its
  first, middle and last frames as ``mearm dataset show`` draws them
  (``dataset_sheet.png``; simulated, seed 0; needs the ``record`` extra).

A file of the same name in the output folder is replaced without asking (no ``--force``,
unlike the ``mearm`` commands): this is a developer tool whose job is to redraw the
pictures committed under ``docs/images/`` (CONTRIBUTING.md: never by hand), and git keeps
the ones it replaces. Give ``--out`` another folder to keep a folder's PNGs as they are.
Each PNG is written to a temporary file beside it, then renamed over the old one: a failed
write or a stop leaves the old picture whole, and a picture that could not be written
(a folder of its name there, a full disk) stops the tool with one line, exit 2 or 1.

Examples::

    python tools/screenshots.py                       # every group
    python tools/screenshots.py --only twin --only frames
    python tools/screenshots.py --only views configs/sim_5dof.yaml --out /tmp
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from mearm.cli import ArgumentParser, check_output_folder, run
from mearm.config import Config, load_config
from mearm.errors import MearmError
from mearm.fileio import write_atomic
from mearm.kinematics import ArmModel

ROOT = Path(__file__).resolve().parent.parent
REFERENCE_CONFIGS = ("sim.yaml", "sim_mearm_v1.yaml", "sim_5dof.yaml", "sim_4colours.yaml")
OUT_DIR = ROOT / "docs" / "images"
GROUPS = ("twin", "frames", "views", "env", "dataset")

#: The twin pictures: file name → (config, free camera azimuth [deg], elevation [deg]).
TWIN_SHOTS: dict[str, tuple[str, float, float]] = {
    "twin_sorting.png": ("sim_mujoco.yaml", 240.0, -25.0),
    "twin_conveyor.png": ("sim_conveyor.yaml", 240.0, -30.0),
    "twin_shapes.png": ("sim_shapes_mujoco.yaml", 240.0, -35.0),
}
#: The arms whose frames are drawn: file name → config.
FRAME_SHOTS = {"frames_mearm_v1.png": "sim_mearm_v1.yaml", "frames_mearm_paper.png": "sim.yaml"}
TWIN_SIZE_PX = (800, 560)
PNG = [cv2.IMWRITE_PNG_COMPRESSION, 9]


def write_png(out: Path, bgr: np.ndarray, params: Sequence[int] = PNG) -> Path:
    """Encode ``bgr`` as a PNG and put it at ``out`` in one step; return ``out``.

    Written to a temporary file in ``out``'s folder, then renamed over ``out``
    (:func:`~mearm.fileio.write_atomic`): a failure or a stop leaves the earlier picture
    whole.

    Raises:
        MearmError: the picture was not written: a folder at ``out`` (exit 2), or the
            write failed (a full disk: exit 1).
    """
    ok, png = cv2.imencode(".png", bgr, list(params))
    if not ok:
        error = MearmError(f"cannot write {out}: OpenCV could not encode the picture as PNG")
        error.exit_status = 1
        raise error
    try:
        write_atomic(out, png.tobytes())
    except OSError as exc:
        error = MearmError(f"cannot write {out}: {exc.strerror or exc}")
        if not isinstance(exc, IsADirectoryError):
            error.exit_status = 1  # the run failed; not the user's input
        raise error from None
    return out


# ----------------------------------------------------------------------------- twin


@dataclass
class PoseSampler:
    """Keeps the twin's state every ``period_s`` of simulated time while a sort runs.

    A :class:`~mearm.task.rig.RigRecorder` that records no episodes: it samples the
    bus's physics (``qpos``) through the bus's sampler hook.
    """

    period_s: float = 0.1
    states: list[np.ndarray] = field(default_factory=list)
    due_s: float = 0.0
    episodes_written: int = 0

    def attach(self, bus: Any, camera: Any) -> None:  # noqa: D102
        bus.sampler = self

    def detach(self) -> None:  # noqa: D102
        pass

    def sample(self, bus: Any) -> None:  # noqa: D102
        self.states.append(bus.data.qpos.copy())
        self.due_s += self.period_s

    def begin(self, class_name: str) -> None:  # noqa: D102
        pass

    def end(self) -> None:  # noqa: D102
        pass

    def end_run(self) -> None:  # noqa: D102
        pass

    def abandon(self) -> None:  # noqa: D102
        pass


def render_twin(config_path: Path, out: Path, azimuth_deg: float, elevation_deg: float) -> Path:
    """Sort ``config_path`` in the twin; render the moment an object is carried highest."""
    import mujoco

    from mearm.sim.twin.mjcf import twin_model
    from mearm.sim.twin.twin_bus import TwinArm
    from mearm.task.rig import run_sort

    config = load_config(config_path)
    sampler = PoseSampler()
    run_sort(config, echo=None, recorder=sampler)
    twin = TwinArm(config, twin_model(config))
    heights = []
    for qpos in sampler.states:
        twin.data.qpos[:] = qpos
        mujoco.mj_kinematics(twin.model, twin.data)
        heights.append(max(twin.object_pose(i).position_cm[2] for i in twin.object_ids))
    twin.data.qpos[:] = sampler.states[int(np.argmax(heights))]
    mujoco.mj_forward(twin.model, twin.data)
    return _render(twin.model, twin.data, out, azimuth_deg, elevation_deg)


def _render(model: Any, data: Any, out: Path, azimuth_deg: float, elevation_deg: float) -> Path:
    import mujoco

    width, height = TWIN_SIZE_PX
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    camera = mujoco.MjvCamera()
    mujoco.mjv_defaultFreeCamera(model, camera)
    camera.lookat[:] = (0.0, 0.22, 0.16)
    camera.distance = 0.95
    camera.azimuth, camera.elevation = azimuth_deg, elevation_deg
    with mujoco.Renderer(model, height, width) as renderer:
        renderer.update_scene(data, camera)
        rgb = renderer.render()
    seen = np.argwhere(rgb.max(axis=2) > 12)  # the scene without the empty sky around it
    (top, left), (bottom, right) = seen.min(axis=0), seen.max(axis=0)
    rgb = rgb[max(0, top - 8) : bottom + 8, max(0, left - 8) : right + 8]
    return write_png(out, cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))


# ----------------------------------------------------------------------------- frames

_INK = (40, 40, 40)
_AXIS = {"x": (40, 40, 220), "y": (40, 160, 40), "z": (200, 90, 30)}  # BGR
_JOINT = (0, 130, 230)


def _arm_points_cm(config: Config, values: dict[str, float]) -> np.ndarray:
    """Each DH frame's origin at ``values`` (the base first, the TCP last) [cm]."""
    arm = config.arm
    full = arm.full_values(values)
    T = np.eye(4)
    points = [T[:3, 3].copy()]
    for joint in arm.joints:
        value = full[joint.name]
        T = T @ joint.dh.transform(
            math.radians(value) if joint.type == "revolute" else value, joint.type
        )
        points.append(T[:3, 3].copy())
    points.append(arm.tcp_cm(full))
    return np.array(points)  # (n + 2, 3)


def draw_frames(config_path: Path, out: Path) -> Path:
    """An arm at home from the side (y–z, facing +y) and from above (x–y): frames and zeros."""
    config = load_config(config_path)
    arm = config.arm
    ArmModel(arm)  # the description is checked as a model would be
    home = arm.home()
    base = arm.actuated_joints()[0]
    straight = {**home, base.name: 90.0}  # facing +y: the side view shows the arm flat
    side = _arm_points_cm(config, straight)[:, [1, 2]]
    top = _arm_points_cm(config, home)[:, [0, 1]]
    size = (450, 340)
    extent = max(np.ptp(side, axis=0).max(), np.abs(top).max(), 5.0)
    px_cm = min(size[0] - 120, size[1] - 90) / extent
    canvas = np.full((size[1] + 30 + 22 * 4, size[0] * 2, 3), 255, np.uint8)
    o_side = (60, size[1] - 40)
    o_top = (size[0] + size[0] // 2, size[1] - 40)
    _panel(canvas, side, o_side, px_cm, ("y", "z"), f"from the side, {base.name} at 90 deg")
    _panel(canvas, top, o_top, px_cm, ("x", "y"), "from above, at home")
    _zero_marks(canvas, config, side, o_side, px_cm)
    _arc(canvas, o_top, 0.0, math.radians(home[base.name]), f"{base.name} {home[base.name]:g}")
    lines = [
        f"{arm.name}: the base frame's origin is on the table under the base's axis; "
        "+z up, +y ahead, +x right.",
        "A joint's angle grows counter-clockwise from its 0 line (grey); at home: "
        + ", ".join(f"{n} {v:g}" for n, v in home.items())
        + " deg.",
    ]
    for j in arm.actuated_joints():
        assert j.servo is not None
        if not j.servo.drives_only(j.name):
            lines.append(
                f"{j.name}'s servo turns {j.servo.combination(j.name).text()}: "
                "the next link's angle to the table, 0 = level."
            )
    for k, text in enumerate(lines):
        cv2.putText(canvas, text, (12, size[1] + 26 + 22 * k), _FONT, 0.45, _INK, 1, cv2.LINE_AA)
    return write_png(out, canvas)


_FONT = cv2.FONT_HERSHEY_SIMPLEX


def _px(p_cm: np.ndarray, origin: tuple[int, int], px_cm: float) -> tuple[int, int]:
    return round(origin[0] + p_cm[0] * px_cm), round(origin[1] - p_cm[1] * px_cm)


def _panel(canvas: np.ndarray, pts: np.ndarray, o: tuple[int, int], px_cm: float,
           axes: tuple[str, str], title: str) -> None:  # fmt: skip
    cv2.putText(canvas, title, (o[0] - 50, 24), _FONT, 0.55, _INK, 1, cv2.LINE_AA)
    for k, name in enumerate(axes):
        tip = _px(np.eye(2)[k] * 40 / px_cm, o, px_cm)
        cv2.arrowedLine(canvas, o, tip, _AXIS[name], 2, cv2.LINE_AA, tipLength=0.25)
        cv2.putText(canvas, f"+{name}", (tip[0] + 5, tip[1] - 5), _FONT, 0.5, _AXIS[name], 1,
                    cv2.LINE_AA)  # fmt: skip
    if axes == ("y", "z"):
        cv2.line(canvas, (o[0] - 50, o[1]), (o[0] + 370, o[1]), (160, 160, 160), 1)
        cv2.putText(canvas, "table", (o[0] - 50, o[1] + 16), _FONT, 0.4, (120, 120, 120), 1)
    else:
        cv2.putText(canvas, "+z toward you", (o[0] + 8, o[1] + 30), _FONT, 0.4, _AXIS["z"], 1)
    px = [_px(p, o, px_cm) for p in pts]
    for a, b in zip(px, px[1:], strict=False):
        cv2.line(canvas, a, b, _INK, 3, cv2.LINE_AA)
    for p in px[1:-1]:
        cv2.circle(canvas, p, 5, _JOINT, -1, cv2.LINE_AA)
    cv2.circle(canvas, px[-1], 5, (0, 0, 200), 2, cv2.LINE_AA)
    cv2.putText(canvas, "TCP", (px[-1][0] + 7, px[-1][1] + 15), _FONT, 0.45, (0, 0, 200), 1)
    cv2.circle(canvas, o, 4, _INK, -1)
    cv2.putText(canvas, "origin", (o[0] - 24, o[1] + 32), _FONT, 0.4, _INK, 1)


def _arc(canvas: np.ndarray, at: tuple[int, int], zero: float, value: float, label: str) -> None:
    """A joint's 0 line (grey) at angle ``zero`` and an arc to its value [rad, image CCW]."""
    end = (round(at[0] + 45 * math.cos(zero)), round(at[1] - 45 * math.sin(zero)))
    cv2.line(canvas, at, end, (150, 150, 150), 1, cv2.LINE_AA)
    start, stop = -math.degrees(zero), -math.degrees(zero + value)
    cv2.ellipse(canvas, at, (26, 26), 0, start, stop, _JOINT, 2, cv2.LINE_AA)
    tip = zero + value
    u, v = at[0] + 26 * math.cos(tip), at[1] - 26 * math.sin(tip)
    text = (round(u + 30 * math.cos(tip - 0.4)) - 10, round(v - 30 * math.sin(tip - 0.4)))
    cv2.putText(canvas, label, text, _FONT, 0.42, _JOINT, 1, cv2.LINE_AA)


def _zero_marks(canvas: np.ndarray, config: Config, side: np.ndarray, origin: tuple[int, int],
                px_cm: float) -> None:  # fmt: skip
    """Each actuated pitch joint in the side view: its 0 line and an arc to its home value."""
    joints = config.arm.joints
    home = config.arm.full_values({**config.arm.home(), joints[0].name: 90.0})
    heading = 0.0  # the previous link's angle in the side view [rad], 0 = along +y
    for i, joint in enumerate(joints):
        d = side[i + 1] - side[i]
        if i > 0 and joint.actuated and joint.type == "revolute":
            at = _px(side[i], origin, px_cm)
            _arc(
                canvas,
                at,
                heading,
                math.radians(home[joint.name]),
                f"{joint.name} {home[joint.name]:g}",
            )
        if i > 0 and np.hypot(*d) > 1e-9:
            heading = math.atan2(d[1], d[0])


# ----------------------------------------------------------------------------- views


def render_config(config_path: Path, out_dir: Path, size_px: tuple[int, int] = (1280, 800)) -> Path:
    """Render one config's arm at home with its scene to ``out_dir/view_<stem>.png``."""
    from mearm.sim import SimCamera, World
    from mearm.view import ArmView
    from mearm.vision import Calibration

    config = load_config(config_path)
    model = ArmModel(config.arm)
    world = World.from_config(config)
    frame = SimCamera(config, world).read()
    calibration = Calibration.from_config(config.calibration)
    out = out_dir / f"view_{config_path.stem}.png"
    with ArmView(model, config, port=0) as view:
        view.show_joints(model.home, config.arm.tool.gripper.open_cm)
        view.set_camera_frame(frame, calibration.pixel_to_table)
        view.set_objects(world.table_objects())
        return view.screenshot(out, width_px=size_px[0], height_px=size_px[1])


#: Steps of the expert into a pick-and-place episode: the object in the jaws, rising.
ENV_SHOT_STEP = 60


def render_env(out: Path) -> Path:
    """The pick-and-place environment mid-episode: its render beside its observation."""
    from mearm.envs.twin_env import TwinEnv

    env = TwinEnv("sim_mujoco", task="pick_place", render_mode="rgb_array", expert=True)
    try:
        obs, info = env.reset(seed=0)
        for _ in range(ENV_SHOT_STEP):
            obs, _, done, cut, info = env.step(info["expert_action"])
            if done or cut:
                break
        frame = env.render()
        assert frame is not None
        small = obs["pixels"]["table"]
        scale = frame.shape[0] / small.shape[0]
        size = (round(small.shape[1] * scale), frame.shape[0])
        seen = cv2.resize(small, size, interpolation=cv2.INTER_NEAREST)
        both = np.hstack([frame, np.full((frame.shape[0], 8, 3), 255, np.uint8), seen])
        write_png(out, cv2.cvtColor(both, cv2.COLOR_RGB2BGR), [])
    finally:
        env.close()
    return out


def render_dataset(out: Path) -> Path:
    """One recorded pick-and-place's contact sheet (its first, middle and last frames)."""
    import subprocess
    import tempfile

    from mearm.dataset.contact_sheet import contact_sheet

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "ds"
        config = ROOT / "configs" / "sim_mujoco.yaml"
        subprocess.run(
            [sys.executable, "-m", "mearm.sort", "--config", str(config), "--random", "1",
             "--seed", "0", "--set", "camera.noise_std=0", "--record", str(root), "--quiet"],
            check=True,
        )  # fmt: skip
        contact_sheet(root, out, per_episode=3, max_episodes=1)  # in one step, or an error
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Render the pictures; see the module docstring."""
    parser = ArgumentParser(prog="python tools/screenshots.py", description=__doc__.splitlines()[0])
    parser.add_argument(
        "configs",
        nargs="*",
        type=Path,
        default=[ROOT / "configs" / name for name in REFERENCE_CONFIGS],
        help="views: the configs to render (default: the four reference configs)",
    )
    parser.add_argument(
        "--only", action="append", choices=GROUPS, help="render only this group (repeatable)"
    )
    parser.add_argument(
        "--out",
        type=Path,
        default=OUT_DIR,
        help="folder for the PNGs (default: docs/images); PNGs of the same names there are "
        "replaced, without a --force: the tool redraws the committed pictures, and git keeps "
        "the old ones",
    )
    args = parser.parse_args(argv)
    groups = args.only or list(GROUPS)
    check_output_folder(args.out, "--out")  # a file there, or above it: exit 2, one line
    args.out.mkdir(parents=True, exist_ok=True)
    configs = ROOT / "configs"
    if "twin" in groups:
        for name, (config, azimuth, elevation) in TWIN_SHOTS.items():
            path = render_twin(configs / config, args.out / name, azimuth, elevation)
            print(f"wrote {path} (simulated)", flush=True)
    if "frames" in groups:
        for name, config in FRAME_SHOTS.items():
            print(f"wrote {draw_frames(configs / config, args.out / name)}", flush=True)
    if "views" in groups:
        for path in args.configs:
            print(f"wrote {render_config(path, args.out)}", flush=True)
    if "env" in groups:
        print(f"wrote {render_env(args.out / 'env_pick_place.png')} (simulated)", flush=True)
    if "dataset" in groups:
        print(f"wrote {render_dataset(args.out / 'dataset_sheet.png')} (simulated)", flush=True)
    return 0


if __name__ == "__main__":
    run(main, sys.argv[1:])
