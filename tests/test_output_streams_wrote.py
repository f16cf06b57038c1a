"""Every command names the files it wrote on stdout; stderr stays empty on success.

The rule (docs/getting-started.md, the output paragraph): results and the ``wrote PATH``
lines go on stdout, stderr carries only errors, warnings and notes, and where stdout is
JSON the files written are keys inside it. calibrate-camera, aruco-sheet, charuco-board
and urdf said theirs on stderr; detect
--annotate, bench --out, eval-policy --out/--videos, camera-accuracy --json/--work and
virtual-uno-pulses --json named nothing. Each command runs here in this process, in a
folder of its own, on the real files (camera-accuracy's in the folder of the run the tests
of its --json and --work share). A recording (``--record``) is named on stdout too,
once it is closed after the run, before the sort's summary: the outcome stays stdout's
last line.
"""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import cv2
import pytest
from badinput import ROOT, run_in_process
from conftest import missing_tool
from test_tool_outputs import camera_accuracy_once

from mearm.config import Config, load_config
from mearm.sim import TableRenderer, class_discs
from mearm.sim.virtual_uno import missing_requirements
from mearm.vision import Calibration

#: The twin config whose camera the pose is fitted to, and the walkthrough's intrinsics.
TWIN = ROOT / "configs" / "sim_mujoco_perspective.yaml"
INTRINSICS = ROOT / "configs" / "calibration" / "twin_intrinsics.yaml"


def _table_picture(name: str) -> str:
    """The kinematic rig's camera frame of three of the paper's objects, written as ``name``."""
    config = Config()
    objects = [(o.color, o.x, o.y) for o in config.task.scene[:3]]
    frame = TableRenderer(Calibration.from_config(config.calibration)).render(
        class_discs(config.task.classes, objects)
    )
    cv2.imwrite(name, frame)
    return name


def calibration_points() -> list[str]:
    """Five pixel ↔ table pairs of the built-in calibration (``--point U,V:X,Y`` each)."""
    calibration = Calibration.from_config(Config().calibration)
    pixels = [(0, 0), (640, 0), (640, 480), (0, 480), (320, 240)]
    table = calibration.pixel_to_table(pixels)
    return [a for (u, v), (x, y) in zip(pixels, table, strict=True)
            for a in ("--point", f"{u},{v}:{float(x)!r},{float(y)!r}")]  # fmt: skip


def _homography() -> list[str]:
    shutil.copy(ROOT / "configs" / "lab.yaml", "lab.yaml")
    return ["calibrate-camera", "--config", "lab.yaml", *calibration_points()]


def _pose() -> list[str]:
    from mearm.sim.twin.calibration_scenes import (  # noqa: PLC0415  (MuJoCo: this case)
        SHEET_SIDE_CM,
        default_sheet_layout,
        render_sheet,
    )

    config = load_config(TWIN)
    layout = default_sheet_layout(config)
    cv2.imwrite("sheet.png", render_sheet(config, layout, noise_std=2, seed=0))
    markers = [a for i, (x, y) in layout.items() for a in ("--marker", f"{i}:{x:g},{y:g}")]
    return ["calibrate-camera", "--intrinsics", str(INTRINSICS), "--out", "pose.yaml",
            "--image", "sheet.png", "--marker-side-cm", f"{SHEET_SIDE_CM:g}", *markers,
            "--config", str(TWIN), "--output", "my_twin.yaml"]  # fmt: skip


def _experiment() -> list[str]:
    Path("scene.yaml").write_text("- {color: red, x: -10.99, y: 49.70}\n")
    return ["experiment", "--config", "sim", "--trials", "1", "--scene", "scene.yaml",
            "--log", "trials.jsonl", "--record", "ds", "--record-codec", "h264"]  # fmt: skip


def _virtual_uno(monkeypatch: pytest.MonkeyPatch) -> None:
    """The firmware and its harness built into this test's cache (skipped without the tools)."""
    missing = missing_requirements()
    if missing:
        missing_tool(", ".join(f"{r.what} ({r.package})" for r in missing))
    monkeypatch.setenv("XDG_CACHE_HOME", str(Path("cache").resolve()))


def _gym(_monkeypatch: pytest.MonkeyPatch) -> None:
    """The environments' and the videos' packages (``mearm[gym]``, ``mearm[record]``)."""
    pytest.importorskip("gymnasium")
    pytest.importorskip("av")


#: id → (the command line, made in the test's folder; what it needs first, or None; the
#: lines that must be on stdout, each a regular expression matched by a whole line).
Needs = Callable[[pytest.MonkeyPatch], None]
CASES: dict[str, tuple[Callable[[], list[str]], Needs | None, list[str]]] = {
    "aruco-sheet": (
        lambda: ["aruco-sheet", "--output", "markers.png"],
        None,
        [re.escape("wrote markers.png: print at 100 % and check the 5 cm bar")],
    ),
    "charuco-board": (
        lambda: ["charuco-board", "--output", "board.png"],
        None,
        [re.escape("wrote board.png: print at 100 % and check the 5 cm bar and the 3 cm squares")],
    ),
    "urdf": (
        lambda: ["urdf", "--config", "sim", "--output", "arm.urdf"],
        None,
        [re.escape("wrote arm.urdf")],
    ),
    "calibrate-camera": (_homography, None, [re.escape("wrote the calibration into lab.yaml")]),
    "calibrate-camera-pose": (
        _pose,
        None,
        [
            re.escape("wrote the camera pose to pose.yaml"),
            re.escape(f"pointed my_twin.yaml at {INTRINSICS} and pose.yaml"),
        ],
    ),
    "detect": (
        lambda: ["detect", _table_picture("table.png"), "--annotate", "found.png"],
        None,
        [re.escape("wrote found.png")],
    ),
    "bench": (
        lambda: ["bench", "--only", "motion", "--repeat", "1", "--out", "out/bench.json"],
        None,
        [re.escape("wrote out/bench.json")],
    ),
    "eval-policy": (
        lambda: (
            "eval-policy --jobs 1 --episodes 1 --env-option obs_type=state "
            "--out scores/pp.json --videos 1"
        ).split(),
        _gym,
        [
            re.escape("wrote scores/videos/episode_000_seed_0.mp4"),
            re.escape("wrote scores/pp.json"),
        ],
    ),
    "virtual-uno-pulses": (
        lambda: ["virtual-uno-pulses", "--commands", "3", "--json", "pulses.json"],
        _virtual_uno,
        [re.escape("wrote pulses.json")],
    ),
}
#: The cases that take a second or more (a render, a sort, a measurement, a build).
HEAVY = {
    "calibrate-camera-pose",
    "bench",
    "eval-policy",
    "virtual-uno-pulses",
}


@pytest.mark.parametrize(
    "case",
    [pytest.param(c, marks=pytest.mark.heavy) if c in HEAVY else c for c in CASES],
)
def test_a_command_names_what_it_wrote_on_stdout(
    case: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Exit 0, each file written named by a line of stdout, and nothing on stderr."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    make_argv, needs, said = CASES[case]
    if needs is not None:
        needs(monkeypatch)
    out = run_in_process(make_argv(), within_s=60)
    assert out.code == 0, out.stdout + out.stderr
    assert out.stderr == "", out.stderr
    lines = out.stdout.splitlines()
    for pattern in said:
        assert any(re.fullmatch(pattern, line) for line in lines), (pattern, out.stdout)
    if case == "bench":  # the run still ends with its targets' line (docs/benchmarks.md)
        assert lines[-1].startswith("targets: "), out.stdout


@pytest.mark.heavy
def test_camera_accuracy_names_what_it_wrote_on_stdout(
    tmp_path_factory: pytest.TempPathFactory,
) -> None:
    """As each case above, on the run of camera-accuracy at its quickest that the tests of
    its --json and --work read too (``--json ca.json --work work``, run in this process)."""
    out = camera_accuracy_once(tmp_path_factory)
    assert out.code == 0, out.stdout + out.stderr
    assert out.stderr == "", out.stderr
    lines = out.stdout.splitlines()
    for said in ("wrote ca.json", "wrote the pictures and calibrations into work/"):
        assert said in lines, (said, out.stdout)
    assert (out.folder / "ca.json").is_file() and (out.folder / "work").is_dir()


@pytest.mark.heavy
def test_bench_json_names_its_out_inside_the_json(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--json --out: stdout is one JSON document whose ``out`` is the file written; the file
    holds the rows without that key; stderr has only the targets' line, as before."""
    monkeypatch.chdir(tmp_path)
    out = run_in_process(
        ["bench", "--only", "motion", "--repeat", "1", "--json", "--out", "bench.json"],
        within_s=60,
    )
    assert out.code == 0, out.stderr
    shown = json.loads(out.stdout)  # the whole of stdout: nothing loose beside the JSON
    assert shown["out"] == "bench.json"
    written = json.loads(Path("bench.json").read_text())
    assert "out" not in written
    assert {k: v for k, v in shown.items() if k != "out"} == written
    assert out.stderr.splitlines() == [written["targets"]["summary"]]


def test_detect_json_keeps_stdout_json_and_notes_its_pictures_on_stderr(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--json --annotate on two images: stdout holds the two JSON lists alone (one line
    each, as ever); the two pictures are named on stderr, one line each."""
    monkeypatch.chdir(tmp_path)
    image = _table_picture("table.png")
    out = run_in_process(["detect", image, image, "--json", "--annotate", "found.png"])
    assert out.code == 0, out.stderr
    found = [json.loads(line) for line in out.stdout.splitlines()]
    assert [len(f) for f in found] == [3, 3]
    assert out.stderr.splitlines() == ["wrote found-0.png", "wrote found-1.png"]
    assert Path("found-0.png").is_file() and Path("found-1.png").is_file()


@pytest.mark.heavy
@pytest.mark.parametrize(
    "make_argv",
    [
        lambda: "sort --config sim --random 1 --seed 0 --record ds --record-codec h264".split(),
        _experiment,
    ],
    ids=["sort", "experiment"],
)
def test_a_recording_is_named_on_stdout_before_the_outcome(
    make_argv: Callable[[], list[str]], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The dataset is named on stdout once closed, as every file written is, and the
    outcome still ends it; stderr does not name it again."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("MUJOCO_GL", "egl")
    out = run_in_process(make_argv(), within_s=60)
    assert out.code == 0, out.stdout + out.stderr
    assert out.stdout.splitlines()[-1].startswith("sorted 1 of 1 objects"), out.stdout
    assert re.search(r"^wrote ds/ \(1 episode, \d+ frames\)$", out.stdout, re.M), out.stdout
    assert "recorded" not in out.stderr, out.stderr
