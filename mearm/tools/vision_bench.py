"""Vision benchmark: ms per 640×480 frame with the paper's 12 objects (paper §4).

    mearm vision-bench [--repeat N] [--seeds N]
    mearm vision-bench --photos DIR [--config C] [--learn | --every-click]

Times, in the same run and interleaved round by round (so a busy machine slows all
alike): the OpenCV detector (:class:`~mearm.vision.detector.ColorDetector`), the same
recipe in plain NumPy/SciPy (:mod:`mearm.vision.paper_recipe`), and the sim camera's
rendering of a frame; prints them next to the paper's 0.263 s (MATLAB R2018a,
i5-2410M). Figures are the best of the rounds (the least disturbed) and the median.
Never asserted: timings depend on the machine. Needs SciPy (the ``dev`` extra).

Next to a plain 8-bit OpenCV recipe (:func:`detect_inrange`: per class ``inRange`` on
OpenCV's HSV, median, label) it times the detector on 12 and 40 objects laid on a grid
(:func:`grid_scene`), and the cost of one more object (the slope from 12 to 40).

It also reports the detector's accuracy on the standard scenes
(:mod:`mearm.sim.kinematic.vision_scenes`): every condition, with and without distractors, several
noise seeds — how many scenes gave exactly the 12 objects with the right classes, and
the worst and mean position error; and how well calibrations recover the rig
(:func:`run_calibration_study`).

A cost per object is a difference of two timings: one that comes out at or under zero
(too few ``--repeat`` rounds, or a busy machine) is no measurement and prints ``—`` with
"below timing resolution" (its value is NaN), never a negative cost.

``--photos DIR`` scores a folder of labelled real photos instead
(:mod:`mearm.tools.photo_bench`): recall and precision per photo, per class and over
all, the detector of ``--config`` and the ``inRange`` recipe side by side; ``--learn``
teaches the detector each source's colours from its first photo that shows all its
classes (one click per class);
``--every-click`` teaches it every way one photo and one click per class can, and prints
the spread of recall and precision (:func:`~mearm.tools.photo_bench.run_click_study`).
A manifest that cannot be scored is refused before any output (exit 2, one line naming
the entry).

The rendered scenes are the paper's rig (``--config`` and ``--set`` are for ``--photos``
only, ``--repeat`` and ``--seeds`` for the rendered scenes only: an option the run would
not read is refused, exit 2); their table ends on a line that labels them simulated.

Scenes are drawn by the simulator's renderer (:mod:`mearm.sim.kinematic.renderer`); this script
sits on top of both layers and imports it where it draws.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from mearm.cli import (
    PLAIN_INTEGER,
    ArgumentParser,
    add_config_argument,
    check_plain_number,
    config_from_args,
    run,
)
from mearm.config import ColorClass, Config
from mearm.errors import InputFileError
from mearm.sim.kinematic.vision_scenes import (
    BASE_OPTIONS,
    CONDITIONS,
    distractors,
    match_detections,
)
from mearm.vision.calibration import Calibration
from mearm.vision.detector import ColorDetector
from mearm.vision.inrange import detect_inrange
from mearm.vision.paper_recipe import detect_reference

#: Timing rounds and noise seeds per scene without ``--repeat`` and ``--seeds``.
REPEAT, SEEDS = 50, 3
PAPER_DETECT_S = 0.263  # paper §4: 12 objects, 640×480, MATLAB
#: Object counts of the per-object rows: the paper's scene and a crowded table.
PEER_COUNTS = (12, 40)


def _times(fns: dict[str, Callable[[], object]], rounds: int) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {k: [] for k in fns}
    for _ in range(rounds):
        for key, fn in fns.items():
            t0 = time.perf_counter()
            fn()
            out[key].append(time.perf_counter() - t0)
    return out


def run_vision_bench(repeat: int = REPEAT) -> list[dict]:
    """Measure and return rows ``{"section", "name", "value", "unit", "note"}``.

    Args:
        repeat: Rounds; each round times every contender once (the OpenCV detector
            ten times, to resolve its short time).
    """
    from mearm.sim.kinematic.renderer import TableRenderer, class_discs

    config = Config()  # the simulated rig: 640×480, paper calibration, default classes
    classes = config.task.classes
    calibration = Calibration.from_config(config.calibration)
    renderer = TableRenderer.from_config(config.camera, calibration)
    discs = class_discs(classes, [(o.color, o.x, o.y) for o in config.task.scene])
    frame = renderer.render(discs)
    detector = ColorDetector(config.vision, calibration, classes)
    found, expected = detector.detect(frame), detect_reference(frame, classes, config.vision)
    same = len(found) == len(expected) == 12 and all(
        a.color == b.color
        and a.area_px == b.area_px
        and np.allclose(a.centroid_px, b.centroid_px, atol=1e-9)
        for a, b in zip(found, expected, strict=True)
    )
    inner = 10

    def opencv() -> None:
        for _ in range(inner):
            detector.detect(frame)

    times = _times(
        {
            "opencv": opencv,
            "numpy": lambda: detect_reference(frame, classes, config.vision),
            "render": lambda: renderer.render(discs, frame_index=1),
        },
        max(1, repeat),
    )
    ms = {k: [1e3 * t for t in v] for k, v in times.items()}
    ms["opencv"] = [t / inner for t in ms["opencv"]]
    best = {k: min(v) for k, v in ms.items()}
    median = {k: statistics.median(v) for k, v in ms.items()}
    scene = "640x480, paper's 12-object layout, sim wood table"
    agree = "same detections as the NumPy/SciPy recipe" if same else "DETECTIONS DIFFER"
    rows = [
        ("detect, OpenCV (best)", best["opencv"], "ms/frame", f"{scene}; {agree}"),
        ("detect, OpenCV (median)", median["opencv"], "ms/frame", ""),
        ("detect, NumPy/SciPy recipe (best)", best["numpy"], "ms/frame",
         "median_filter + label, float64 HSV, whole frame"),
        ("NumPy/SciPy ÷ OpenCV", best["numpy"] / best["opencv"], "x", "same run"),
        ("paper (MATLAB)", 1e3 * PAPER_DETECT_S, "ms/frame", "paper §4, MATLAB R2018a, i5-2410M"),
        ("paper ÷ OpenCV", 1e3 * PAPER_DETECT_S / best["opencv"], "x", "different machines"),
        ("sim camera render (best)", best["render"], "ms/frame",
         "textured table, 12 shaded discs, noise"),
    ]  # fmt: skip
    return [
        {"section": "vision", "name": n, "value": float(v), "unit": u, "note": note}
        for n, v, u, note in rows
    ]


def grid_scene(
    calibration: Calibration,
    classes: Sequence[ColorClass],
    n: int,
    size_px: tuple[int, int] = (640, 480),
    margin_px: float = 40.0,
) -> list[tuple[str, float, float]]:
    """``n`` objects (class, x [cm], y [cm]) on a grid over the frame, classes in turn.

    The grid spans the frame less ``margin_px`` on each side, about 4 columns for 3 rows;
    40 objects of 2 cm on the sim rig's 640×480 frame are about 5 cm apart.
    """
    w, h = size_px
    (x0, y0), (x1, y1) = calibration.pixel_to_table(
        np.array([[margin_px, margin_px], [w - margin_px, h - margin_px]])
    )
    cols = max(1, math.ceil(math.sqrt(n * 4 / 3)))
    rows = max(1, math.ceil(n / cols))
    xs = np.linspace(min(x0, x1), max(x0, x1), cols)
    ys = np.linspace(min(y0, y1), max(y0, y1), rows)
    return [
        (classes[i % len(classes)].name, float(xs[i % cols]), float(ys[i // cols]))
        for i in range(n)
    ]


def _taught_detector(
    config: Config,
    calibration: Calibration,
    frame: np.ndarray,
    objects: Sequence[tuple[str, float, float]],
) -> ColorDetector:
    """The detector with the classes' colours taught by one click each on ``frame``."""
    from mearm.vision.teaching import Sample, teach

    samples = []
    for c in config.task.classes:
        _, x, y = next(o for o in objects if o[0] == c.name)
        (u, v), = calibration.table_to_pixel(np.array([[x, y]]))  # fmt: skip
        samples.append(Sample(c.name, float(u), float(v)))
    taught = teach([frame], samples)
    classes = [
        c.model_copy(update={"learned_colour": taught.colours[c.name]}) for c in config.task.classes
    ]
    vision = config.vision.model_copy(
        update={"reference_bgr": taught.reference_bgr, "work_area_px": taught.work_area_px}
    )
    return ColorDetector(vision, calibration, classes)


def run_detection_peers(repeat: int = REPEAT, counts: Sequence[int] = PEER_COUNTS) -> list[dict]:
    """The detector next to the 8-bit ``inRange`` recipe on grids of ``counts`` objects.

    Rows: µs per frame of each (best of ``repeat`` interleaved rounds of 5 calls), their
    ratio per count, and each one's cost of one more object: the slope between the
    smallest and the largest count [µs/object]. The sim rig's camera (wood, noise),
    calibration and classes.
    """
    from mearm.sim.kinematic.renderer import TableRenderer, class_discs

    config = Config()
    classes = config.task.classes
    calibration = Calibration.from_config(config.calibration)
    renderer = TableRenderer.from_config(config.camera, calibration)
    detector = ColorDetector(config.vision, calibration, classes)
    size = (config.camera.width_px, config.camera.height_px)
    frames = {
        n: renderer.render(class_discs(classes, grid_scene(calibration, classes, n, size)))
        for n in counts
    }
    inner = 5

    def repeated(fn: Callable[[np.ndarray], object], frame: np.ndarray) -> Callable[[], None]:
        def run() -> None:
            for _ in range(inner):
                fn(frame)

        return run

    calls: dict[str, Callable[[], object]] = {}
    found: dict[str, int] = {}
    for n, frame in frames.items():
        recipe = lambda f: detect_inrange(f, classes, config.vision, calibration)  # noqa: E731
        taught = _taught_detector(
            config, calibration, frame, grid_scene(calibration, classes, n, size)
        )
        calls[f"taught/{n}"] = repeated(taught.detect, frame)
        found[f"taught/{n}"] = len(taught.detect(frame))
        calls[f"mearm/{n}"] = repeated(detector.detect, frame)
        calls[f"inRange/{n}"] = repeated(recipe, frame)
        found[f"mearm/{n}"] = len(detector.detect(frame))
        found[f"inRange/{n}"] = len(recipe(frame))
    us = {k: 1e6 * min(v) / inner for k, v in _times(calls, max(1, repeat)).items()}
    note = f"{size[0]}x{size[1]} sim wood table, objects on a grid, best of {repeat} rounds"
    rows = []
    for n in counts:
        seen = f"found {found[f'mearm/{n}']} and {found[f'inRange/{n}']} of {n}"
        rows.append((f"detect {n} objects, mearm", us[f"mearm/{n}"], "µs/frame", f"{note}; {seen}"))
        rows.append(
            (
                f"detect {n} objects, 8-bit inRange recipe",
                us[f"inRange/{n}"],
                "µs/frame",
                "cvtColor + inRange + medianBlur + connectedComponentsWithStats",
            )
        )
        rows.append((f"mearm ÷ inRange, {n} objects", us[f"mearm/{n}"] / us[f"inRange/{n}"], "x",
                     "same run"))  # fmt: skip
        taught_note = f"one click per class; found {found[f'taught/{n}']} of {n}"
        rows.append((f"detect {n} objects, mearm, taught colours", us[f"taught/{n}"], "µs/frame",
                     taught_note))  # fmt: skip
        rows.append((f"mearm taught ÷ inRange, {n} objects", us[f"taught/{n}"] / us[f"inRange/{n}"],
                     "x", "same run"))  # fmt: skip
    lo, hi = min(counts), max(counts)
    if hi > lo:
        for key, label in (("mearm", "mearm"), ("inRange", "8-bit inRange recipe")):
            rows.append(
                per_object_row(f"detect, {label}: per object", us[f"{key}/{lo}"],
                               us[f"{key}/{hi}"], lo, hi, repeat)
            )  # fmt: skip
    return [
        {"section": "vision", "name": n, "value": float(v), "unit": u, "note": note}
        for n, v, u, note in rows
    ]


def per_object_row(
    name: str, lo_us: float, hi_us: float, lo: int, hi: int, repeat: int
) -> tuple[str, float, str, str]:
    """The cost of one more object: the slope from ``lo`` objects (``lo_us`` a frame) to ``hi``.

    A difference of two timings: one at or under zero is the rounds' noise, not a cost,
    and is no figure (NaN) with "below timing resolution" in its note, never a negative
    cost printed as a measurement.
    """
    slope = (hi_us - lo_us) / (hi - lo)
    note = f"slope from {lo} to {hi} objects"
    if slope > 0:
        return name, slope, "µs/object", note
    why = (
        f"below timing resolution: {hi} objects timed no slower than {lo} ({hi_us:.1f} vs "
        f"{lo_us:.1f} µs/frame, best of {repeat} rounds; more --repeat may resolve it)"
    )
    return name, float("nan"), "µs/object", f"{why}; {note}"


def run_vision_accuracy(seeds: int = SEEDS) -> list[dict]:
    """Accuracy rows on the standard scenes (sim rig, default classes)."""
    from mearm.sim.kinematic.renderer import TableRenderer, class_discs

    config = Config()
    calibration = Calibration.from_config(config.calibration)
    detector = ColorDetector.from_config(
        config.vision, config.calibration, config.camera, config.task.classes
    )
    objects = [(o.color, o.x, o.y) for o in config.task.scene]
    discs = class_discs(config.task.classes, objects)
    errors, scenes, exact = [], 0, 0
    for options in CONDITIONS.values():
        for extras in ((), distractors()):
            for seed in range(seeds):
                opts = BASE_OPTIONS | options | {"seed": options.get("seed", 0) + seed}
                frame = TableRenderer(calibration, extras=extras, **opts).render(discs)
                err = match_detections(detector.detect(frame), objects, calibration)
                scenes += 1
                if err is not None:
                    exact += 1
                    errors.extend(err.tolist())
    note = f"{len(CONDITIONS)} conditions x (with, without distractors) x {seeds} seeds"
    worst = max(errors) if errors else float("nan")
    mean = sum(errors) / len(errors) if errors else float("nan")
    rows = [
        ("scenes with exactly the 12 objects", exact, f"of {scenes}", note),
        ("worst position error", worst, "cm", "over every object of those scenes"),
        ("mean position error", mean, "cm", ""),
    ]
    return [
        {"section": "vision", "name": n, "value": float(v), "unit": u, "note": note}
        for n, v, u, note in rows
    ]


def run_calibration_study(draws: int = 200) -> list[dict]:
    """How well a calibration recovers the rig: noisy point pairs, and rendered markers.

    Four pairs at the field corners with Gaussian noise on the pixels and on the table
    positions: the worst error over the whole field, median and maximum over ``draws``
    draws. Then ArUco markers (4 cm, at the field's corners) drawn into a rendered view
    from a tilted camera: the worst error over the field using the 4 centres, and the
    centres plus the 16 corners.
    """
    from mearm.sim.kinematic.renderer import TableRenderer
    from mearm.vision.aruco import calibration_from_markers, draw_marker_on_table

    lab = Calibration.from_config(Config().calibration)
    u, v = np.meshgrid(np.linspace(0, 639, 41), np.linspace(0, 479, 41))
    grid = np.stack([u.ravel(), v.ravel()], axis=1)
    corners = np.array([[0.0, 0.0], [640.0, 0.0], [640.0, 480.0], [0.0, 480.0]])
    rows = []
    for sigma_px, sigma_cm in ((0.1, 0.01), (0.3, 0.01), (0.3, 0.05)):
        worst = []
        for seed in range(draws):
            rng = np.random.default_rng(seed)
            px = corners + rng.normal(0.0, sigma_px, corners.shape)
            cm = lab.pixel_to_table(corners) + rng.normal(0.0, sigma_cm, corners.shape)
            fit = Calibration.fit(px, cm)
            err = np.linalg.norm(fit.pixel_to_table(grid) - lab.pixel_to_table(grid), axis=1)
            worst.append(float(err.max()))
        label = f"4 pairs, noise {sigma_px:g} px + {sigma_cm:g} cm: field error"
        rows.append((f"{label} (median)", statistics.median(worst), "cm", f"{draws} draws"))
        rows.append((f"{label} (max)", max(worst), "cm", ""))
    tilt = np.array([[1.0, 0.02, 0.0], [0.01, 1.0, 0.0], [1e-5, 2e-5, 1.0]])
    tilted = Calibration(lab.H @ tilt)
    markers = {0: (-17.0, 56.0), 1: (16.0, 56.0), 2: (16.0, 32.0), 3: (-17.0, 32.0)}
    frame = TableRenderer(tilted).render([])
    for marker_id, center in markers.items():
        draw_marker_on_table(frame, tilted, marker_id, center, 4.0)
    for side, what in ((None, "4 centres"), (4.0, "4 centres + 16 corners")):
        fit = calibration_from_markers(frame, markers, side_cm=side)
        err = np.linalg.norm(fit.pixel_to_table(grid) - tilted.pixel_to_table(grid), axis=1)
        rows.append((f"ArUco, tilted camera, {what}: field error (max)", float(err.max()), "cm",
                     "rendered 640x480, 4 cm markers"))  # fmt: skip
    return [
        {"section": "vision", "name": n, "value": float(val), "unit": un, "note": note}
        for n, val, un, note in rows
    ]


def _count(text: str) -> int:
    """An argparse type: a whole number from 1 to 100 000."""
    check_plain_number(text, f"expected a plain whole number ({PLAIN_INTEGER})")
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if not 1 <= n <= 100_000:
        raise argparse.ArgumentTypeError(f"must be from 1 to 100000, got {n}")
    return n


def _require_manifest(folder: Path) -> None:
    """``--photos`` names a folder with its labels' ``manifest.yaml``.

    Raises:
        InputFileError: it does not exist, is a file, or holds no manifest.
    """
    if not folder.is_dir():
        what = "is a file, not a folder" if folder.exists() else "no such folder"
        raise InputFileError(str(folder), f"{what}: give the labelled photos' folder")
    if not (folder / "manifest.yaml").is_file():
        raise InputFileError(str(folder), "no manifest.yaml in it (the labelled photos' list)")


def _print_photos(folder: Path, config: Config, *, learn: bool) -> int:
    from mearm.tools.photo_bench import run_photo_bench

    _require_manifest(folder)
    rows = run_photo_bench(folder, config, learn=learn)  # a bad manifest: before any output
    print(f"{'photos':<28} {'detector':<8} {'found':>5} {'missed':>6} {'false':>5} "
          f"{'recall':>7} {'precision':>9}")  # fmt: skip
    for r in rows:
        rec = "-" if r["recall"] is None else f"{100 * r['recall']:.1f}%"
        pre = "-" if r["precision"] is None else f"{100 * r['precision']:.1f}%"
        print(f"{r['scope']:<28} {r['who']:<8} {r['found']:>5} {r['missed']:>6} {r['false']:>5} "
              f"{rec:>7} {pre:>9}")  # fmt: skip
    _print_scale(config)
    return 0


def _print_scale(config: Config) -> None:
    from mearm.tools.photo_bench import object_px_of

    print(f"photos scaled so that objects are {object_px_of(config):.1f} px across "
          "(the config's calibration, at its camera's centre)")  # fmt: skip


def _print_click_study(folder: Path, config: Config) -> int:
    from mearm.tools.photo_bench import run_click_study

    _require_manifest(folder)
    rows = run_click_study(folder, config)  # a source it cannot teach: refused in it
    head = " ".join(f"{q:>7}" for q in ("min", "q10", "median", "max"))
    print(f"{'taught every way':<44} {'teachings':>9} {'refused':>7}  recall {head}  "
          f"precision {head}")  # fmt: skip
    for r in rows:
        rec = " ".join(f"{100 * r['recall'][q]:6.1f}%" for q in ("min", "q10", "median", "max"))
        pre = " ".join(f"{100 * r['precision'][q]:6.1f}%" for q in ("min", "q10", "median", "max"))
        print(f"{r['scope']:<44} {r['teachings']:>9} {r['refused']:>7}  {'':6} {rec}  "
              f"{'':9} {pre}")  # fmt: skip
    _print_scale(config)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Print the vision rows as a table."""
    parser = ArgumentParser(description="The detector's timings and accuracy on rendered scenes.")
    parser.add_argument("--repeat", type=_count, help=f"timing rounds ({REPEAT})")
    parser.add_argument("--seeds", type=_count, help=f"noise seeds per scene ({SEEDS})")
    parser.add_argument(
        "--photos", type=Path, metavar="DIR", help="score the labelled photos of DIR instead"
    )
    parser.add_argument(
        "--learn",
        action="store_true",
        help="with --photos: teach each source from its first photo showing all its classes",
    )
    parser.add_argument(
        "--every-click",
        action="store_true",
        help="with --photos: teach each source every way one photo and one click per class "
        "can, and print the spread of recall and precision",
    )
    add_config_argument(parser)
    args = parser.parse_args(argv)
    for flag, given in (("--learn", args.learn), ("--every-click", args.every_click)):
        if given and args.photos is None:
            parser.error(f"{flag} needs --photos DIR")
    if args.learn and args.every_click:
        parser.error("--learn and --every-click: give one (--every-click teaches every way)")
    # an option the chosen bench does not read would be taken as obeyed: refuse it
    if args.photos is None and (args.config is not None or args.set):
        parser.error(
            "--config and --set apply to --photos only: the rendered scenes are the paper's "
            "rig (configs/sim.yaml)"
        )
    for flag, value in (("--repeat", args.repeat), ("--seeds", args.seeds)):
        if value is not None and args.photos is not None:
            parser.error(f"{flag} applies to the rendered scenes, not to --photos")
    if args.photos is not None and args.every_click:
        return _print_click_study(args.photos, config_from_args(args))
    if args.photos is not None:
        return _print_photos(args.photos, config_from_args(args), learn=args.learn)
    repeat = REPEAT if args.repeat is None else args.repeat
    rows = run_vision_bench(repeat) + run_detection_peers(repeat)
    rows += run_vision_accuracy(SEEDS if args.seeds is None else args.seeds)
    for row in rows + run_calibration_study():
        note = f"  ({row['note']})" if row["note"] else ""
        value = f"{row['value']:9.3f}" if math.isfinite(row["value"]) else f"{'—':>9}"
        print(f"{row['name']:<62} {value} {row['unit']:<9}{note}")
    print("simulated: every scene and marker view above is rendered (the paper's row aside), "
          "not a camera's frame")  # fmt: skip
    return 0


if __name__ == "__main__":
    run(main)
