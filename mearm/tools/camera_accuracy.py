r"""Measure where the calibrated camera puts objects in the twin, calibrated by mearm's own tools.

    mearm camera-accuracy --config sim_mujoco_perspective \
        [--set twin.camera.tilt_deg=0] [--heights 1,2.5] [--scenes 5] [--first-seed 0] \
        [--objects 12] [--noise-std 2] [--work DIR] [--json FILE [--force]]

What a user does with a real camera, done with the twin's (a perspective camera with
lens distortion that the software knows nothing about):

1. ``mearm render-calibration`` pictures a ChArUco board at many poses and ArUco markers
   lying on the table (the twin's camera, through its lens, with sensor noise);
2. ``mearm calibrate-intrinsics`` fits the camera matrix and distortion to the boards;
3. ``mearm calibrate-camera --intrinsics`` fits the camera's pose to the markers.

Then, for each object height, seeded random scenes of objects (``random_scene``, seeds
``--first-seed`` …) are
rendered by the twin (the arm hidden, so that nothing but the table, the bins and the
objects is seen), detected with the fitted calibration, and each detection compared with
the object's true position in the physics. Objects the camera does not see whole (cut
by the frame) are left out of the scenes. The paper's model — the blob's centroid
through a homography fitted to the same markers — is scored on the same frames.

Each height must be one whose objects the arm could pick, as a scene is drawn of
pickable objects (:func:`~mearm.task.scene.random_scene`): the pick lies in
``arm.target_box``, and at it the open jaws, to close at the class's grip height (half the
object's height unless ``grip_height_cm`` says), keep their pads above the table (a low
object) and the hand ``task.clearance_cm`` + 0.3 cm clear of the object's top (a tall
one). A height that cannot
is refused before any work (exit 2), the line naming the range of heights the config
allows, worked out from it (``sim_mujoco``: 0.81 … 5.98 cm).

Prints one line per height: objects, mean and largest error [cm], objects missed and
detections extra, and the paper model's figures; where the classes are cubes, a line of
their yaws' errors (modulo 90°) under both models. Exits 1 if the mean or the largest
error exceeds ``--max-mean-cm`` / ``--max-error-cm`` (0.05 / 0.10 cm) or anything was
missed or extra. ``--work DIR`` keeps the pictures and calibrations: a rerun into it
replaces the pictures (render-calibration's ``--force``) and keeps the old
``intrinsics.yaml`` and ``pose.yaml`` as ``.bak``; ``--json`` may not name one of them
(or the config), and an existing ``--json`` is refused unless ``--force``. Each is named
on stdout once written (``wrote FILE``, ``wrote the pictures and calibrations into
DIR/``), also when the figures fail their bounds. Needs SciPy
(``pip install 'mearm[analysis]'``) for the matching.

``--work`` is this command's folder, so that no file of the user's is replaced there:
it must be new, empty, or one this command wrote before. The command marks it
(:data:`WORK_MARKER`, the command's name and every file it left there with its SHA-256)
and refuses, before any work, a folder that holds a file without that mark, or one
changed since (a calibration of the user's copied over ``intrinsics.yaml``, say). After
a run cut short, the files of the names it writes are accepted (it may have been
writing them); any other file is still refused.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import re
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mearm.cli import (
    ArgumentParser,
    add_config_argument,
    check_output_file,
    check_output_folder,
    config_from_args,
    plain_float,
    plain_int,
    positive_number,
    refuse_to_replace,
    run,
    write_text_atomic,
)
from mearm.config import Config
from mearm.errors import MearmError
from mearm.interrupts import Terminated

#: A detection farther than this from every object of its class is extra, and the object
#: missed [cm].
MATCH_CM = 1.0
#: Objects whose outline comes closer than this to the frame's edge are left out [px].
EDGE_PX = 4.0
#: The whole numbers ``--scenes`` (per height), ``--objects`` (per scene) and ``--views``
#: (board pictures for the intrinsics) may be, each (least, most).
SCENES = (1, 100)
OBJECTS = (1, 40)
VIEWS = (6, 60)


#: What ``--heights`` may hold at most, before the config's own range (least, most) [cm].
HEIGHTS_CM = (0.2, 10.0)


def _numbers(text: str) -> list[float]:
    if not text.isascii() or "_" in text:  # float() reads 1_0 and other scripts' digits
        raise MearmError(f"--heights wants plain decimal numbers like 1,2.5, got {text!r}")
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise MearmError(f"--heights wants numbers like 1,2.5, got {text!r}") from None
    lo, hi = HEIGHTS_CM
    if not values or not all(lo <= v <= hi for v in values):
        raise MearmError(f"--heights must be in {lo:g} … {hi:g} cm, got {text!r}")
    if len(set(values)) < len(values):
        raise MearmError(f"--heights names a height twice, got {text!r}: each once")
    return values


class StepFailed(MearmError):
    """A tool this measurement runs on the twin's renders failed: the run's failure (exit 1).

    Its inputs are the renders this run made from accepted options; a tool that refuses
    them (no board found under an unlit lamp) says the measurement could not be made.
    """

    exit_status = 1


def _tool(*argv: str) -> str:
    """Run ``mearm ARGV…`` as a user would; its stdout, or StepFailed with its stderr.

    A Ctrl-C, SIGTERM or SIGHUP that stops this command is passed on to the tool, and the
    tool's end is waited for, so it removes what it was writing (render-calibration's
    hidden staging folder) as it does when stopped by hand; killed outright (what
    :func:`subprocess.run` does on an interrupt), it left that folder in --work.
    """
    proc = subprocess.Popen(
        [sys.executable, "-m", "mearm", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        out, err = proc.communicate()
    except KeyboardInterrupt as exc:
        _stop_tool(proc, exc)
        raise
    if proc.returncode != 0:
        raise StepFailed(
            f"mearm {argv[0]} failed ({proc.returncode}) on the twin's renders (its camera "
            f"and lamp as configured): {err.strip()}"
        )
    return out


def _stop_tool(proc: subprocess.Popen[str], exc: KeyboardInterrupt) -> None:
    """Pass the stop ``exc`` (a Ctrl-C or a stop signal) on to the tool; wait for its end.

    Another stop while it ends is passed on too; the wait goes on (the tool ends on it).
    """
    signum = exc.signum if isinstance(exc, Terminated) else signal.SIGINT
    while True:
        if proc.poll() is None:
            proc.send_signal(signum)
        try:
            proc.communicate()  # its pipes read to the end: a full one would stall it
        except KeyboardInterrupt as again:
            signum = again.signum if isinstance(again, Terminated) else signal.SIGINT
            continue
        return


#: The calibrations --work holds beside render-calibration's pictures (and their backups,
#: ``.bak`` and ``.bak.N``).
_WORK_FILES = re.compile(r"(intrinsics|pose)\.yaml(\.bak(\.\d+)?)?")
#: The file that marks a --work folder as this command's, listing what it wrote there.
WORK_MARKER = ".mearm-camera-accuracy.json"
_COMMAND = "mearm camera-accuracy"


def _own_name(rel: str) -> bool:
    """Whether ``rel`` (a path in --work, ``/``-separated) is a name this command writes."""
    from mearm.tools.render_calibration import _OWN_NAMES

    folder, _, name = rel.rpartition("/")
    temp = re.fullmatch(r"\.(.+)\.[^.]+\.tmp", name)  # an atomic write cut short by a kill
    name = temp.group(1) if temp else name
    if folder == "boards":
        return re.fullmatch(r"board_\d+\.png", name) is not None
    return folder == "" and (
        _OWN_NAMES.fullmatch(name) is not None or _WORK_FILES.fullmatch(name) is not None
    )


def _work_files(work: Path) -> dict[str, str]:
    """Every file under ``work`` but the marker, by path relative to it: its SHA-256.

    A link or anything else that is not a regular file gets a fingerprint no file has,
    so it is never taken for one this command wrote (it writes none).
    """
    files: dict[str, str] = {}
    if not work.is_dir():
        return files
    for path in sorted(work.rglob("*")):
        rel = path.relative_to(work).as_posix()
        if rel == WORK_MARKER or (path.is_dir() and not path.is_symlink()):
            continue
        if path.is_symlink() or not path.is_file():
            files[rel] = "not a regular file"
            continue
        try:
            files[rel] = hashlib.sha256(path.read_bytes()).hexdigest()
        except OSError as exc:
            raise MearmError(f"--work {work}: cannot read {rel}: {exc.strerror or exc}") from None
    return files


def _check_work(work: Path) -> dict[str, str]:
    """Refuse a --work folder holding a file this command did not write; what it recorded.

    A folder that is new or empty is taken; one marked by :data:`WORK_MARKER` must hold
    only the files the marker lists, unchanged (after a run cut short, also files of
    the names this command writes).

    Raises:
        MearmError: a file there is not this command's, or changed since it wrote it.
    """
    marker = work / WORK_MARKER
    present = _work_files(work)
    if not (marker.exists() or marker.is_symlink()):
        if present:
            first = next(iter(present))
            raise MearmError(
                f"--work {work}: holds files camera-accuracy did not write ({first}, "
                f"{len(present)} in all), which this run may replace: give a new or empty "
                "folder, or move them"
            )
        return {}
    retry = "give a new or empty folder, or move the file"
    try:
        mark = json.loads(marker.read_text(encoding="utf-8"))
        if mark["command"] != _COMMAND or not isinstance(mark["files"], dict):
            raise ValueError("not this command's")
        recorded = {str(k): str(v) for k, v in mark["files"].items()}
        finished = mark["finished"] is True
    except (OSError, ValueError, KeyError, TypeError, UnicodeDecodeError):
        raise MearmError(
            f"--work {work}: {WORK_MARKER} is not camera-accuracy's mark: give a new or "
            "empty folder"
        ) from None
    for rel, digest in present.items():
        if recorded.get(rel) == digest or (not finished and _own_name(rel)):
            continue
        why = (
            "was changed since camera-accuracy wrote it, and this run may replace it"
            if rel in recorded
            else "was not written by camera-accuracy (its folder holds only what it wrote)"
        )
        raise MearmError(f"--work {work}: {rel} {why}: {retry}")
    return recorded


def _mark_work(work: Path, files: dict[str, str], *, finished: bool) -> None:
    """Write the marker: this command's folder, and the files it holds (see :func:`_check_work`)."""
    mark = {"command": _COMMAND, "finished": finished, "files": files}
    write_text_atomic(work / WORK_MARKER, json.dumps(mark, indent=1, sort_keys=True) + "\n")


def _check_json_not_an_input(args: argparse.Namespace) -> None:
    """Refuse (exit 2) a --json that is the config, or one of the files --work holds."""
    from mearm.cli import refuse_own_inputs
    from mearm.config.files import resolve_config_path
    from mearm.tools.render_calibration import _OWN_NAMES

    config = resolve_config_path(args.config) if args.config else None
    refuse_own_inputs([("--json", args.json)], [("--config", config)])
    if args.work is not None and args.json.resolve().parent == args.work.resolve():
        name = args.json.name
        if (
            _OWN_NAMES.fullmatch(name)
            or _WORK_FILES.fullmatch(name)
            or name in ("boards", WORK_MARKER)
        ):
            raise MearmError(
                f"--json {args.json}: is {name} of --work {args.work}, which this run writes "
                "and reads: write elsewhere"
            )


def _check_outputs(args: argparse.Namespace) -> dict[str, str]:
    """Refuse (exit 2) outputs that cannot be written or must not be; what --work recorded."""
    if args.json is not None:
        check_output_file(args.json, "--json")
    if args.work is not None:
        check_output_folder(args.work, "--work")
    if args.json is not None:
        _check_json_not_an_input(args)
        refuse_to_replace(args.json, "--json", args.force)
    return _check_work(args.work) if args.work is not None else {}


def calibrate(config_path: str, overrides: list[str], work: Path, views: int, noise: float) -> dict:
    """Render the calibration pictures and run the two calibration tools on them."""
    sets = [a for s in overrides for a in ("--set", s)]
    _tool(
        "render-calibration", "--config", config_path, *sets, "--out", str(work),
        "--views", str(views), "--noise-std", str(noise), "--force",
    )  # fmt: skip
    folder = work / "boards"  # a folder: views where too little of the board shows are skipped
    folder.mkdir(exist_ok=True)
    for p in folder.glob("board_*.png"):  # an earlier run's views: not this camera's
        p.unlink()
    for p in work.glob("board_*.png"):
        p.replace(folder / p.name)
    out = _tool(
        "calibrate-intrinsics", "--images", str(folder), "--out", str(work / "intrinsics.yaml"),
        "--camera-id", "twin", "--force",
    )  # fmt: skip
    marker_args = (work / "sheet_markers.txt").read_text().split()
    pose = _tool(
        "calibrate-camera", "--intrinsics", str(work / "intrinsics.yaml"),
        "--out", str(work / "pose.yaml"), "--image", str(work / "sheet.png"), "--force",
        *marker_args,
    )  # fmt: skip
    return {"intrinsics_output": out.strip(), "pose_output": pose.strip(), "markers": marker_args}


def _say_calibrated(cal: dict) -> None:
    """Print the calibrations' lines that matter here, each backup a tool kept named first."""
    intrinsics, pose = cal["intrinsics_output"], cal["pose_output"]
    for line in _backups_named(intrinsics):
        print(line)
    print(intrinsics.splitlines()[0] if intrinsics else "")
    for line in [*_backups_named(pose), *pose.splitlines()[1:4]]:
        print(line)


def _backups_named(output: str) -> list[str]:
    """The lines a calibration tool named a backup it kept with (``wrote X.bak (the old X)``)."""
    return [line for line in output.splitlines() if _BACKUP_LINE.match(line)]


#: A tool's line naming a backup (:func:`mearm.cli.backup_written`).
_BACKUP_LINE = re.compile(r"wrote .+\.bak(\.\d+)? \(the old .+\)")


def _paper_homography(work: Path, marker_args: list[str]):  # noqa: ANN202
    from mearm.vision.aruco import calibration_from_markers
    from mearm.vision.image import read_image

    centers: dict[int, tuple[float, float]] = {}
    side = None
    for i, a in enumerate(marker_args):
        if a == "--marker":
            ident, xy = marker_args[i + 1].split(":")
            x_cm, y_cm = (float(v) for v in xy.split(","))
            centers[int(ident)] = (x_cm, y_cm)
        elif a.startswith("--marker-side-cm"):
            side = float(a.split("=")[1]) if "=" in a else float(marker_args[i + 1])
    return calibration_from_markers(read_image(work / "sheet.png"), centers, side_cm=side)


def _scene_config(config: Config, height: float, objects: int) -> Config:
    """The config whose scenes of ``objects`` objects ``height`` cm tall are scored.

    The bins are raised with the objects' height: the twin's bins have walls that hold
    every object, and an object must be released above them; nothing is sorted.
    """
    raise_cm = (objects + 1) * height
    classes = [
        c.model_copy(
            update={"height_cm": height, "bin_cm": (*c.bin_cm[:2], c.bin_cm[2] + raise_cm)}
        )
        for c in config.task.classes
    ]
    return config.model_copy(update={"task": config.task.model_copy(update={"classes": classes})})


#: Points of the camera's field (a grid, a side) where ``--heights`` are tried; of those the
#: arm reaches, the first :data:`PICKS_TRIED` (the tool's room at a pick barely changes
#: across the field).
FIELD_GRID = 9
PICKS_TRIED = 4


def _unpickable(config: Config, height: float, objects: int) -> str | None:
    """Why no object ``height`` cm tall can stand in a scene, or ``None`` if one can.

    A scene's objects are drawn where the arm could pick them
    (:func:`~mearm.task.scene.random_scene`): the pick (the TCP at the class's grip height
    plus ``arm.tool.tcp_above_grip_cm``, and the approach above it) in ``arm.target_box``
    and reached, and the tool at the pick, jaws open, keeping ``task.clearance_cm`` and
    the scene's margin (:data:`~mearm.task.scene.FOOTPRINT_MARGIN_CM`) from the table and
    from the object's top. Tried for each class, alone, at points of the camera's field
    the arm reaches: the draw's own checks, made once instead of in 20000 draws that
    cannot succeed.
    """
    from mearm.kinematics import ArmModel  # noqa: PLC0415  (a few imports: not for --help)
    from mearm.kinematics.collision import TOUCH_M  # noqa: PLC0415
    from mearm.sim.table_collision import collision_model  # noqa: PLC0415
    from mearm.task import scene as layout  # noqa: PLC0415
    from mearm.task.plan import Planner  # noqa: PLC0415

    cfg = _scene_config(config, height, objects)
    diameter = max(2 * c.footprint_radius_cm for c in cfg.task.classes)
    x0, x1, y0, y1 = layout.camera_field_cm(cfg, margin_cm=diameter)
    if not (x0 < x1 and y0 < y1):
        return None  # the draw says what is wrong (no table area for such objects)
    xs, ys = np.meshgrid(np.linspace(x0, x1, FIELD_GRID), np.linspace(y0, y1, FIELD_GRID))
    grid = np.column_stack([xs.ravel(), ys.ravel()])
    model = ArmModel(cfg.arm)
    planner = Planner(cfg, model)
    reach = layout._reach_check(cfg)  # noqa: SLF001  (the draw's test of a pick)
    margin_cm = cfg.task.clearance_cm + layout.FOOTPRINT_MARGIN_CM
    box = cfg.arm.target_box.z_cm
    for cls in cfg.task.classes:
        z = cls.grip_z_cm + cfg.arm.tool.tcp_above_grip_cm
        above = z + (cfg.task.approach_height_cm or 0.0)
        if not (box.contains(z) and box.contains(above)):
            return (
                f"its pick puts the TCP at z = {z:.2f} cm (the grip {cls.grip_z_cm:g} cm up "
                f"plus arm.tool.tcp_above_grip_cm {cfg.arm.tool.tcp_above_grip_cm:g}"
                + (f", and {above:.2f} cm above it" if above != z else "")
                + f"), outside arm.target_box.z_cm [{box.min:g}, {box.max:g}]"
            )
        targets = [planner.pick_target(cls, float(x), float(y)) for x, y in grid]
        points = grid[planner.reaches(targets)]
        table = layout._table_of(cfg, [cls.name])  # noqa: SLF001
        collision = collision_model(cfg, model, clearance_cm=margin_cm, table=table)
        nearest: tuple[float, str, str] | None = None  # the best pick's gap, tool, obstacle
        tried, fits = 0, False
        for x, y in points:
            q = reach(cls, float(x), float(y))
            if q is None:
                continue
            collision.set_world([("o0", cls.name, float(x), float(y))])
            gap, a, b = collision.gap(q, target="o0")
            if gap >= TOUCH_M:
                fits = True
                break
            if nearest is None or gap > nearest[0]:
                nearest = (gap, a, b) if a.startswith("gripper") else (gap, b, a)
            tried += 1
            if tried >= PICKS_TRIED:
                break
        if fits:
            continue
        if nearest is None:
            return f"its pick, the TCP at z = {z:.2f} cm, is reached nowhere in the camera's field"
        gap_cm, part, obstacle = nearest[0] * 100, nearest[1], nearest[2]
        closes = f"at its pick the open jaws close {cls.grip_z_cm:g} cm above the table"
        if obstacle == "table":  # (the table keeps no clearance: the height above it)
            return (
                f"{closes}, but their {part} reaches {cls.grip_z_cm - gap_cm:.2f} cm below "
                "that: onto the table"
            )
        what = "the object's top" if obstacle == "obj_o0" else obstacle
        return (
            f"{closes}, and the {part} comes within {margin_cm:g} cm of {what} "
            f"(task.clearance_cm {cfg.task.clearance_cm:g} + the scene's margin "
            f"{layout.FOOTPRINT_MARGIN_CM:g})"
        )
    return None


def _allowed_heights(config: Config, objects: int) -> tuple[float, float] | None:
    """The least and most object heights [cm] a scene holds, to 0.01 cm; ``None``: none.

    Between 0.2 and 10 cm; the heights that fit are one range (the jaws come nearer the
    table as the object, and its grip, is lower, the hand nearer its top as it is taller).
    """

    def fits(h: float) -> bool:
        return _unpickable(config, h, objects) is None

    inside = next((h for h in (1.0, 2.5, *np.arange(0.5, 10.01, 0.5)) if fits(h)), None)
    if inside is None:
        return None
    edges = []
    for out in (HEIGHTS_CM[0], HEIGHTS_CM[1]):
        if fits(out):
            edges.append(out)
            continue
        good, bad = inside, out
        while abs(good - bad) > 1e-3:
            mid = (good + bad) / 2
            good, bad = (mid, bad) if fits(mid) else (good, mid)
        # the first whole hundredth past the edge that fits (the next one, inward, does)
        step = 0.01 if out < inside else -0.01
        edge = (math.ceil if out < inside else math.floor)(round(bad * 100, 6)) / 100
        if edge == bad or not fits(edge):
            edge = round(edge + step, 2)
        edges.append(edge)
    return edges[0], edges[1]


def _check_heights(config: Config, config_name: str, heights: list[float], objects: int) -> None:
    """Refuse, before any work, a height of which no scene can be drawn (exit 2)."""
    for height in heights:
        why = _unpickable(config, height, objects)
        if why is None:
            continue
        allowed = _allowed_heights(config, objects)
        fit = (
            f"heights {allowed[0]:g} … {allowed[1]:g} cm fit"
            if allowed is not None
            else "no height in 0.2 … 10 cm fits"
        )
        raise MearmError(
            f"--heights {height:g}: no object {height:g} cm tall can stand in the scenes "
            f"(drawn pickable): {why}; with {config_name} {fit}"
        )


def score(
    config: Config, work: Path, heights: list[float], scenes: int, objects: int, noise: float,
    marker_args: list[str], first_seed: int = 0,
) -> list[dict]:  # fmt: skip
    """Detect seeded scenes with the fitted calibration; errors per height."""
    from scipy.optimize import linear_sum_assignment

    from mearm.sim.twin.calibration_scenes import render_objects
    from mearm.sim.twin.mjcf import object_ids
    from mearm.task.scene import random_scene
    from mearm.vision.detector import ColorDetector
    from mearm.vision.pinhole import PerspectiveCamera

    camera = PerspectiveCamera.from_files(work / "intrinsics.yaml", work / "pose.yaml")
    paper = _paper_homography(work, marker_args)
    w, h = camera.size_px
    rows = []
    for height in heights:
        cfg = _scene_config(config, height, objects)
        classes = list(cfg.task.classes)
        detector = ColorDetector(cfg.vision, camera, classes)
        paper_detector = ColorDetector(cfg.vision, paper, classes)
        errors: list[float] = []
        paper_errors: list[float] = []
        yaw_errors: dict[bool, list[float]] = {True: [], False: []}  # by: ours?
        missed, extra, n = 0, 0, 0
        for seed in range(first_seed, first_seed + scenes):
            scene = []
            for o in random_scene(cfg, objects, seed=seed):
                c = cfg.task.class_named(o.color)
                outline = camera.silhouette_px((o.x, o.y), c.diameter_cm / 2, height)
                if np.all((outline >= EDGE_PX) & (outline <= (w - 1 - EDGE_PX, h - 1 - EDGE_PX))):
                    scene.append(o)
            cfg_s = cfg.with_scene(scene)
            frame, truth = render_objects(cfg_s, noise_std=noise, seed=seed)
            true = [(o.color, truth[i]) for o, i in zip(scene, object_ids(cfg_s), strict=True)]
            n += len(true)
            for det, errs in ((detector, errors), (paper_detector, paper_errors)):
                found = det.detect(frame)
                cost = np.full((len(true), len(found)), 1e6)
                for i, (color, xy) in enumerate(true):
                    for j, d in enumerate(found):
                        if d.color == color and d.table_cm is not None:
                            cost[i, j] = float(np.hypot(*(d.table_cm - xy)))
                ii, jj = linear_sum_assignment(cost)
                good = cost[ii, jj] <= MATCH_CM
                errs.extend(cost[ii, jj][good].tolist())
                for i, j in zip(ii[good], jj[good], strict=True):
                    yaw = found[j].yaw_deg
                    if yaw is not None and scene[i].yaw_deg is not None:
                        off = (yaw - scene[i].yaw_deg + 45.0) % 90.0 - 45.0
                        yaw_errors[det is detector].append(abs(off))
                if det is detector:
                    missed += len(true) - int(good.sum())
                    extra += len(found) - int(good.sum())
        e, p = np.array(errors), np.array(paper_errors)
        yaws: dict[str, float | None] = {}
        for ours, key in ((True, "yaw"), (False, "paper_yaw")):
            y = np.array(yaw_errors[ours])
            yaws[f"{key}_cubes"] = len(y)
            yaws[f"{key}_mean_deg"] = float(y.mean()) if len(y) else None
            yaws[f"{key}_max_deg"] = float(y.max()) if len(y) else None
        rows.append(
            {
                "height_cm": height,
                "objects": n,
                "mean_cm": float(e.mean()) if len(e) else float("nan"),
                "max_cm": float(e.max()) if len(e) else float("nan"),
                "missed": missed,
                "extra": extra,
                "paper_mean_cm": float(p.mean()) if len(p) else float("nan"),
                "paper_max_cm": float(p.max()) if len(p) else float("nan"),
                **yaws,
            }
        )
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    """Calibrate in the twin and score the detections; 1 if not within the bounds."""
    parser = ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    add_config_argument(parser, default="sim_mujoco")  # (it measures the twin's camera)
    parser.add_argument(
        "--heights", type=str, default="1,2.5",
        help="object heights [cm], each in 0.2 … 10 and one the config's arm could pick (the "
        "scenes are drawn pickable): the pick in arm.target_box, the open jaws' pads, "
        "closing at the grip height, above the table, and the hand task.clearance_cm + "
        "0.3 cm clear of the object's top. One that is not is refused before any work, "
        "with the range the config allows (sim_mujoco: 0.81 … 5.98)",
    )  # fmt: skip
    parser.add_argument("--scenes", type=plain_int, default=5, help="scenes per height (1 … 100)")
    parser.add_argument("--first-seed", type=plain_int, default=0, help="seed of the first scene")
    parser.add_argument("--objects", type=plain_int, default=12, help="objects per scene (1 … 40)")
    parser.add_argument(
        "--views", type=plain_int, default=15, help="board views for the intrinsics (6 … 60)"
    )
    parser.add_argument(
        "--noise-std", type=plain_float, default=2.0, help="sensor noise [8-bit levels]"
    )
    parser.add_argument(
        "--work", type=Path,
        help="keep the pictures and calibrations here: a new or empty folder, or one this "
        f"command wrote before (it marks it, {WORK_MARKER}); a folder holding any other "
        "file, or one of its files changed since, is refused so that nothing of yours is "
        "replaced. A rerun replaces the pictures; the old intrinsics.yaml and pose.yaml "
        "are kept as .bak",
    )  # fmt: skip
    parser.add_argument(
        "--json", type=Path, help='write the figures here (marked "simulated": true)'
    )
    parser.add_argument("--force", action="store_true", help="replace an existing --json")
    parser.add_argument(
        "--max-mean-cm", type=positive_number(1e-6, 1000, "cm"), default=0.05,
        help="exit 1 when a height's mean error is above this [cm] (0.05)",
    )  # fmt: skip
    parser.add_argument(
        "--max-error-cm", type=positive_number(1e-6, 1000, "cm"), default=0.10,
        help="exit 1 when any object's error is above this [cm] (0.10)",
    )  # fmt: skip
    args = parser.parse_args(argv)
    recorded = _check_outputs(args)  # before the work: the measurement takes minutes
    heights = _numbers(args.heights)
    for flag, value, (lo, hi) in (
        ("--scenes", args.scenes, SCENES),
        ("--objects", args.objects, OBJECTS),
        ("--views", args.views, VIEWS),
    ):
        if not lo <= value <= hi:
            raise MearmError(f"{flag} must be a whole number in {lo} … {hi}, got {value}")
    if not 0 <= args.first_seed <= 1_000_000:
        raise MearmError(f"--first-seed must be in 0 … 1000000, got {args.first_seed}")
    if not 0 <= args.noise_std <= 50:
        raise MearmError(f"--noise-std must be in 0 … 50, got {args.noise_std:g}")
    try:
        import scipy  # noqa: F401
    except ImportError:
        raise MearmError(
            "camera-accuracy needs SciPy to match detections: pip install 'mearm[analysis]'"
        ) from None
    config = config_from_args(args)
    if config.simulator != "mujoco":
        raise MearmError(
            f"{args.config}: simulator is {config.simulator!r}; "
            "this needs the twin (simulator: mujoco, e.g. --config sim_mujoco)"
        )
    _check_heights(config, str(args.config), heights, args.objects)  # before minutes of work
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="mearm-accuracy-") as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        if args.work is not None:  # claimed before anything is written into it
            _mark_work(work, recorded, finished=False)
        cal = calibrate(str(args.config), list(args.set or []), work, args.views, args.noise_std)
        _say_calibrated(cal)
        rows = score(
            config, work, heights, args.scenes, args.objects, args.noise_std, cal["markers"],
            args.first_seed,
        )  # fmt: skip
    print(f"{'height':>7} {'objects':>7} {'mean cm':>8} {'max cm':>7} {'missed':>6} {'extra':>5}"
          f"   paper model: {'mean cm':>7} {'max cm':>7}")  # fmt: skip
    ok = True
    for r in rows:
        print(
            f"{r['height_cm']:>7g} {r['objects']:>7d} {r['mean_cm']:>8.4f} {r['max_cm']:>7.4f} "
            f"{r['missed']:>6d} {r['extra']:>5d}                {r['paper_mean_cm']:>7.4f} "
            f"{r['paper_max_cm']:>7.4f}"
        )
        if r["yaw_cubes"]:
            paper = (
                f"paper model: mean {r['paper_yaw_mean_deg']:.2f}°, "
                f"max {r['paper_yaw_max_deg']:.2f}° ({r['paper_yaw_cubes']} cubes)"
                if r["paper_yaw_cubes"]
                else "paper model: none"
            )
            print(
                f"{'':>7} cubes' yaw (mod 90°): mean {r['yaw_mean_deg']:.2f}°, max "
                f"{r['yaw_max_deg']:.2f}° ({r['yaw_cubes']} cubes); {paper}"
            )
        ok &= r["mean_cm"] <= args.max_mean_cm and r["max_cm"] <= args.max_error_cm
        ok &= r["missed"] == 0 and r["extra"] == 0
    print(f"({time.perf_counter() - t0:.0f} s; simulated: the twin's rendered camera)")
    if args.json:
        # the figures are the twin's: the file says so as the printed table does
        record = {"simulated": True, "rows": rows, "calibration": cal}
        text = json.dumps(record, indent=2) + "\n"
        write_text_atomic(args.json, text)
        print(f"wrote {args.json}")
    if args.work is not None:  # what it holds now is this command's (checked, then written)
        _mark_work(args.work, _work_files(args.work), finished=True)
        print(f"wrote the pictures and calibrations into {args.work}/")
    if not ok:
        print(
            f"{parser.prog}: camera accuracy NOT within mean {args.max_mean_cm:g} cm, max "
            f"{args.max_error_cm:g} cm, nothing missed or extra",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    run(main)
