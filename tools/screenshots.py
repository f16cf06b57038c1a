"""Render the README's view screenshots: each reference arm at home with its scene.

For every config given (default: the four reference configs) the meshcat view shows the
arm at home, its bins, the scene's objects and the simulated camera's first frame, and
headless Chromium saves it as ``docs/images/view_<config stem>.png``.

Examples::

    python tools/screenshots.py                               # all four reference configs
    python tools/screenshots.py configs/sim_5dof.yaml --out /tmp
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from mearm.cli import ArgumentParser, run
from mearm.config import load_config
from mearm.kinematics import ArmModel
from mearm.sim import SimCamera, World
from mearm.view import ArmView
from mearm.vision import Calibration

ROOT = Path(__file__).resolve().parent.parent
REFERENCE_CONFIGS = ("sim.yaml", "sim_mearm_v1.yaml", "sim_5dof.yaml", "sim_4colours.yaml")
OUT_DIR = ROOT / "docs" / "images"


def render_config(config_path: Path, out_dir: Path, size_px: tuple[int, int] = (1280, 800)) -> Path:
    """Render one config's arm at home with its scene to ``out_dir/view_<stem>.png``."""
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


def main(argv: Sequence[str] | None = None) -> int:
    """Render the screenshots; see the module docstring."""
    parser = ArgumentParser(prog="python tools/screenshots.py", description=__doc__.splitlines()[0])
    parser.add_argument(
        "configs",
        nargs="*",
        type=Path,
        default=[ROOT / "configs" / name for name in REFERENCE_CONFIGS],
        help="configs to render (default: the four reference configs)",
    )
    parser.add_argument("--out", type=Path, default=OUT_DIR, help="folder for the PNGs")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    for path in args.configs:
        print(f"wrote {render_config(path, args.out)}", flush=True)
    return 0


if __name__ == "__main__":
    run(main, sys.argv[1:])
