"""Bad-input corpus: config files and ``--set`` values, over every command that reads a config.

Generated: every numeric field of the config, each given a value below its range, above
it, NaN, ±inf, text and a list; every command × a set of harmful config files (an alias
bomb, 10 000-deep nesting, /dev/zero, a FIFO, duplicate keys, tags, non-UTF-8, ...).
Hand-written: ``--set`` syntax. Hypothesis: arbitrary YAML text and format-1 mappings
end in a one-line ConfigError, never a crash. Each case asserts exit 2, one line on
stderr, no traceback, a time bound and that the files around are intact
(tests/badinput.py).
"""

from __future__ import annotations

import functools
import math
import os
import shutil
import sys
import types
import typing
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import annotated_types as at
import pytest
from badinput import ROOT, check_bad_input, check_bad_input_subprocess, run_in_process
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from mearm import yamlio
from mearm.config import Config, config_from_dict
from mearm.config.migrate import migrate_v1_config
from mearm.exceptions import ConfigError
from mearm.yamlio import MAX_YAML_BYTES, MAX_YAML_DEPTH, load_yaml_text

bad_input = pytest.mark.bad_input

CONFIGS = ROOT / "configs"
FK = ["--joints", "120,93,-132"]

# --------------------------------------------------------------------------- the fields


def _bounds(metadata: typing.Iterable[Any]) -> tuple[float | None, bool, float | None, bool]:
    """(lo, lo_open, hi, hi_open) from annotated-types constraints."""
    lo = hi = None
    lo_open = hi_open = False
    for m in metadata:
        if isinstance(m, at.Ge):
            lo, lo_open = m.ge, False
        elif isinstance(m, at.Gt):
            lo, lo_open = m.gt, True
        elif isinstance(m, at.Le):
            hi, hi_open = m.le, False
        elif isinstance(m, at.Lt):
            hi, hi_open = m.lt, True
        elif hasattr(m, "metadata"):  # a FieldInfo inside Annotated
            sub = _bounds(m.metadata)
            lo, lo_open = (lo, lo_open) if sub[0] is None else (sub[0], sub[1])
            hi, hi_open = (hi, hi_open) if sub[2] is None else (sub[2], sub[3])
    return lo, lo_open, hi, hi_open


def _scalar(annotation: Any, metadata: typing.Iterable[Any]) -> tuple[type, tuple] | None:
    """(int or float, bounds) of a numeric annotation (Optional and Annotated unwrapped)."""
    extra = list(metadata)
    while True:
        origin = typing.get_origin(annotation)
        if origin is typing.Annotated:
            annotation, *more = typing.get_args(annotation)
            extra += more
        elif origin in (typing.Union, types.UnionType):
            args = [a for a in typing.get_args(annotation) if a is not type(None)]
            if len(args) != 1:
                return None
            annotation = args[0]
        else:
            break
    if annotation in (int, float):
        return annotation, _bounds(extra)
    return None


def _tuple_args(annotation: Any) -> tuple[Any, ...]:
    while typing.get_origin(annotation) in (typing.Union, types.UnionType, typing.Annotated):
        args = [a for a in typing.get_args(annotation) if a is not type(None)]
        annotation = args[0]
    return typing.get_args(annotation) if typing.get_origin(annotation) is tuple else ()


def numeric_fields(model: BaseModel, prefix: str = "") -> Iterator[tuple[str, type, tuple]]:
    """Every numeric leaf of a config: (``--set`` path, int or float, bounds).

    Lists of named items contribute their first item and, for joints, the first passive
    one (the others repeat the same fields); the scene its first object.
    """
    for name, info in type(model).model_fields.items():
        value = getattr(model, name)
        path = f"{prefix}{name}"
        if isinstance(value, BaseModel):
            yield from numeric_fields(value, path + ".")
        elif isinstance(value, list):
            picked = value[:1]
            if name == "joints":
                picked += [j for j in value if j.coupling is not None][:1]
            for item in picked:
                if isinstance(item, BaseModel):
                    key = getattr(item, "name", None) or str(value.index(item))
                    yield from numeric_fields(item, f"{path}.{key}.")
        elif isinstance(value, tuple):
            args = _tuple_args(info.annotation)
            for i, arg in enumerate(args):
                inner = _tuple_args(arg)
                if inner:
                    for j, a in enumerate(inner):
                        if (s := _scalar(a, ())) is not None:
                            yield f"{path}.{i}.{j}", *s
                elif (s := _scalar(arg, ())) is not None:
                    yield f"{path}.{i}", *s
        elif isinstance(value, dict):
            args = typing.get_args(info.annotation)
            s = _scalar(args[1], ()) if len(args) == 2 else None
            for key in list(value)[:1]:
                if s is not None:
                    yield f"{path}.{key}", *s
        elif value is None or isinstance(value, (int, float)) and not isinstance(value, bool):
            s = _scalar(info.annotation, info.metadata)
            if s is not None:
                yield path, *s


def _with_offsets() -> Config:
    """The default config with one entry in every mapping, so each has a field."""
    data = Config().model_dump(mode="json")
    data["servo"]["error_model"]["offset_deg"] = {"shoulder": 0.5}
    return config_from_dict(data)


FIELDS = list(numeric_fields(_with_offsets()))


def _out_of_range(kind: type, bounds: tuple) -> list[tuple[str, str]]:
    """(label, YAML text) of values each field must refuse."""
    lo, lo_open, hi, hi_open = bounds
    out = [("nan", ".nan"), ("inf", ".inf"), ("-inf", "-.inf"), ("text", "'x1'")]
    out.append(("list", "[1, 2]"))
    if lo is not None:
        below = lo if lo_open else (lo - 1 if kind is int else lo - max(1.0, abs(lo)))
        out.append(("below", repr(below)))
    if hi is not None:
        above = hi if hi_open else (hi + 1 if kind is int else hi + max(1.0, abs(hi)))
        out.append(("above", repr(above)))
    if kind is int:
        out.append(("fraction", "1.5"))
    return out


CASES = [
    pytest.param(path, text, id=f"{path}={label}")
    for path, kind, bounds in FIELDS
    for label, text in _out_of_range(kind, bounds)
]

#: The commands that take --config/--set, with the rest of a valid command line.
COMMANDS: dict[str, list[str]] = {
    "fk": ["fk", *FK],
    "ik": ["ik", "--target", "-10.99,49.70,12.76"],
    "urdf": ["urdf", "--output", "{tmp}/arm.urdf"],
    "detect": ["detect", "--camera", "--json"],
    "sort": ["sort", "--quiet"],
    "preview": ["preview"],
    "experiment": ["experiment", "--trials", "1", "--log", "{tmp}/trials.jsonl"],
    "analyze": ["analyze", "--gains"],
}


def command(name: str, tmp: Path, *extra: str) -> list[str]:
    head, *rest = COMMANDS[name]
    return [head, *extra, *(a.format(tmp=tmp) for a in rest)]


@pytest.fixture(scope="module", autouse=True)
def _imported() -> None:
    """Import every command once, so no case's time bound pays for first imports."""
    for argv in (["fk", "--help"], ["sort", "--help"], ["detect", "--help"], ["ik", "--help"],
                 ["preview", "--help"], ["urdf", "--help"], ["experiment", "--help"],
                 ["analyze", "--help"], ["calibrate-camera", "--help"]):  # fmt: skip
        run_in_process(argv, within_s=60)


def test_every_numeric_field_is_covered() -> None:
    """The generator finds the fields of every section (a new section is not missed)."""
    sections = {path.split(".")[0] for path, _, _ in FIELDS}
    # ``simulator`` is a choice and ``twin`` names servo models: no number in either;
    # ``belt`` is unset by default: test_a_bad_belt_is_refused covers it
    assert sections == set(Config.model_fields) - {"simulator", "twin", "belt"}
    assert len(FIELDS) > 60


@pytest.fixture(scope="module")
def outputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One folder for the output paths of the ~1,100 cases below (a tmp_path each cost 2
    ms): every case is refused before it writes, so it stays empty (each case checks)."""
    return tmp_path_factory.mktemp("outputs")


def assert_nothing_written(outputs: Path) -> None:
    """Nothing in ``outputs``: what a case wrote before its refusal fails that case, and
    is removed, so the cases after it still start from an empty folder."""
    written = sorted(outputs.iterdir())
    for path in written:
        shutil.rmtree(path) if path.is_dir() and not path.is_symlink() else path.unlink()
    assert not written, f"written before the refusal: {written}"


@bad_input
@pytest.mark.parametrize(("path", "text"), CASES)
def test_field_out_of_range_is_refused(path: str, text: str, outputs: Path) -> None:
    """Each numeric field refuses values outside its physical range, NaN, inf and junk."""
    names = list(COMMANDS)
    name = names[sum(map(ord, path + text)) % len(names)]  # spread over the commands
    out = check_bad_input(
        command(name, outputs, "--set", f"{path}={text}"), within_s=3, keep=[CONFIGS]
    )
    assert path.rsplit(".", 1)[0].split(".")[0] in out.line
    assert_nothing_written(outputs)


# --------------------------------------------------------------------------- config files


def _bomb(levels: int = 9) -> str:
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    for i in range(1, levels):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 9) + "]")
    return "\n".join(lines) + "\n"


#: name → (file contents, words the one line must hold).
BAD_FILES: dict[str, tuple[str | bytes, str]] = {
    "alias_bomb": (_bomb(), "aliases counted expanded"),
    "many_merges": (
        "a: &a {x: 1}\nb: {<<: [" + ", ".join(["*a"] * 101) + "]}\n",
        "more than 100 aliases",
    ),
    "many_aliases": ("a: &a 1\nb: [" + ", ".join(["*a"] * 150) + "]\n", "more than 100 aliases"),
    "recursive_alias": ("a: &a [1, *a]\n", "is recursive"),
    "undefined_alias": ("a: *nowhere\n", "names no anchor"),
    "deep_flow": ("a: " + "[" * 10_000 + "]" * 10_000 + "\n", "nested deeper than"),
    "deep_block": ("".join(" " * i + f"k{i}:\n" for i in range(1_000)), "nested deeper than"),
    "deep_mapping": ("a: " + "{b: " * 5_000 + "1" + "}" * 5_000 + "\n", "nested deeper than"),
    "duplicate_top": ("camera: {seed: 1}\ncamera: {seed: 2}\n", "duplicate key 'camera'"),
    "duplicate_nested": ("servo:\n  baud: 9600\n  baud: 115200\n", "duplicate key 'baud'"),
    "duplicate_bool": ("servo:\n  sim_realtime: true\n  sim_realtime: no\n", "duplicate key"),
    "python_tag": ("a: !!python/object/apply:os.system ['true']\n", "tag !!python/object"),
    "binary_tag": ("a: !!binary aGVsbG8=\n", "tag !!binary is not allowed"),
    "local_tag": ("servo: !servo {baud: 9600}\n", "tag !servo is not allowed"),
    "timestamp_tag": ("a: !!timestamp 2024-01-01\n", "tag !!timestamp is not allowed"),
    "set_tag": ("a: !!set {x, y}\n", "tag !!set is not allowed"),
    "empty": ("", "empty config"),
    "comments_only": ("# nothing here\n# at all\n", "empty config"),
    "null_document": ("null\n", "empty config"),
    "document_marker_only": ("---\n", "empty config"),
    "two_documents": ("camera: {}\n---\nservo: {}\n", "a second document"),
    "top_list": ("- 1\n- 2\n", "top level must be a mapping"),
    "top_scalar": ("42\n", "top level must be a mapping"),
    "top_string": ("just some words\n", "top level must be a mapping"),
    "latin1": ("camera:\n  path: caf\xe9\n".encode("latin-1"), "not UTF-8 text"),
    "utf16": ("camera: {}\n".encode("utf-16"), "not UTF-8 text"),
    "nul_bytes": (b"camera: {}\n\x00\x00\x00", "control characters are not allowed"),
    "control_chars": ("camera: {path: \x07\x1b}\n", "control characters are not allowed"),
    "random_bytes": (bytes(range(256)) * 4, "not UTF-8 text"),
    "unclosed_flow": ("controller: {kp: [0.1\n", "malformed YAML"),
    "tab_indent": ("servo:\n\tbaud: 9600\n", "malformed YAML"),
    "unclosed_quote": ("camera: {path: 'abc}\n", "malformed YAML"),
    "key_is_list": ("? [a, b]\n: 1\n", "a key must be a plain value"),
    "long_integer": ("camera: {seed: " + "9" * 5_000 + "}\n", "a number too long"),
    "too_large": ("# padding\n" * (MAX_YAML_BYTES // 10 + 1), "too large"),
    "unknown_key": ("cameraa: {}\n", "cameraa: unknown key"),
    "format1_and_current": ("robot: {}\narm: {}\n", "robot: unknown key"),
    "wrong_section_type": ("servo: [1, 2, 3]\n", "servo"),
    "nan_everywhere": ("controller: {kp: .nan, kd: .nan, tolerance_cm2: .nan}\n", "controller"),
    "huge_list": (
        "task:\n  scene: [" + ", ".join(["{color: red, x: 0, y: 40}"] * 600) + "]\n",
        "task.scene",
    ),  # fmt: skip
    "horizon_in_frame": (
        "calibration:\n  homography: [[0.0625, 0, -20.5], [0, -0.0625, 59], [-0.002, 0, 1]]\n",
        "horizon",
    ),
    "singular_homography": (
        "calibration:\n  homography: [[1, 2, 3], [2, 4, 6], [0, 0, 1]]\n",
        "singular",
    ),
    "huge_frame": ("camera: {width_px: 4096, height_px: 4096}\n", "4K UHD"),
    "even_median": ("vision: {median_kernel: 4}\n", "must be odd"),
    "no_joints": ("arm:\n  joints: []\n", "arm"),
    "extends_itself": ("extends: extends_itself.yaml\n", "the configs extend each other"),
    "extends_nothing": ("extends: nowhere.yaml\n", "'nowhere.yaml' is not a file"),
    "extends_a_list": ("extends: [sim.yaml]\n", "extends: expected a config file's path"),
    "unknown_arm": ("arm: {use: mearm_v9}\n", "known: desk_5dof, mearm_paper, mearm_v1"),
    "arm_path_for_name": ("arm: {use: ../../etc/passwd}\n", "no reference arm named"),
    "change_no_such_joint": (
        "arm: {use: mearm_v1, joints: {knee: {home: 1}}}\n",
        "arm.joints.knee: no item named 'knee'",
    ),
}


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The bad config files, and the special ones: a FIFO, a folder, devices, a link."""
    d = tmp_path_factory.mktemp("bad_configs")
    paths = {}
    for name, (content, _) in BAD_FILES.items():
        p = d / f"{name}.yaml"
        p.write_bytes(content.encode("utf-8") if isinstance(content, str) else content)
        paths[name] = p
    os.mkfifo(d / "fifo.yaml")
    paths["fifo"] = d / "fifo.yaml"
    (d / "folder.yaml").mkdir()
    paths["folder"] = d / "folder.yaml"
    (d / "to_zero.yaml").symlink_to("/dev/zero")
    paths["link_to_dev_zero"] = d / "to_zero.yaml"
    (d / "dangling.yaml").symlink_to(d / "nothing-here.yaml")
    paths["dangling_link"] = d / "dangling.yaml"
    paths["dev_zero"] = Path("/dev/zero")
    paths["dev_null"] = Path("/dev/null")
    paths["dev_urandom"] = Path("/dev/urandom")
    paths["missing"] = d / "missing.yaml"
    return paths


SPECIAL: dict[str, str] = {
    "fifo": "not a regular file",
    "folder": "is a directory",
    "link_to_dev_zero": "not a regular file",
    "dangling_link": "config file not found",
    "dev_zero": "not a regular file",
    "dev_null": "not a regular file",
    "dev_urandom": "not a regular file",
    "missing": "config file not found",
}
ALL_FILES = {**{k: v[1] for k, v in BAD_FILES.items()}, **SPECIAL}


@bad_input
@pytest.mark.parametrize("name", list(ALL_FILES))
def test_bad_config_file_is_refused_by_fk(name: str, bad_files: dict[str, Path]) -> None:
    """Every harmful or malformed config file: exit 2, one line saying what is wrong."""
    out = check_bad_input(
        ["fk", "--config", bad_files[name], *FK], within_s=2, keep=[bad_files["empty"].parent]
    )
    assert ALL_FILES[name] in out.line
    assert str(bad_files[name]) in out.line  # the line names the file


#: The files every command is tried with (the harmful ones).
ACROSS = ("alias_bomb", "deep_flow", "dev_zero", "fifo", "folder", "duplicate_top",
          "python_tag", "latin1", "empty", "too_large", "recursive_alias", "top_list")  # fmt: skip


@bad_input
@pytest.mark.parametrize("name", ACROSS)
@pytest.mark.parametrize("cmd", [c for c in COMMANDS if c != "fk"])
def test_every_command_refuses_a_harmful_config(
    cmd: str, name: str, bad_files: dict[str, Path], outputs: Path
) -> None:
    """Each command that reads a config refuses it the same way, before any work."""
    out = check_bad_input(
        command(cmd, outputs, "--config", str(bad_files[name])),
        within_s=2,
        keep=[bad_files["empty"].parent, CONFIGS],
    )
    assert ALL_FILES[name] in out.line
    assert_nothing_written(outputs)  # (no trials.jsonl, no arm.urdf, nothing else)


@bad_input
@pytest.mark.parametrize("name", ACROSS)
def test_calibrate_camera_refuses_a_harmful_config(
    name: str, bad_files: dict[str, Path], tmp_path: Path
) -> None:
    """calibrate-camera reads (and would rewrite) the config: refused, and left as it was."""
    points = ["--point", "0,0:-20.5,59", "--point", "640,0:19.5,59",
              "--point", "640,480:19.5,29", "--point", "0,480:-20.5,29"]  # fmt: skip
    out = check_bad_input(
        ["calibrate-camera", "--config", bad_files[name], *points],
        within_s=2,
        keep=[bad_files["empty"].parent],
    )
    assert ALL_FILES[name] in out.line


# --------------------------------------------------------------------------- --set


SET_CASES = {
    "no_equals": ("camera.seed", "expected dotted.key=value"),
    "empty_key": ("=1", "expected dotted.key=value"),
    "empty_part": ("camera..seed=1", "expected dotted.key=value"),
    "trailing_dot": ("camera.=1", "expected dotted.key=value"),
    "unknown_section": ("nope.x=1", "nope: unknown key"),
    "unknown_field": ("camera.sed=1", "camera.sed: unknown key"),
    "value_not_yaml": ("controller.kp=[0.1", "is not valid YAML"),
    "value_bomb": ("camera.path=" + _bomb(7).replace("\n", ", ").join("{}"), "counted expanded"),
    "value_deep": ("camera.path=" + "[" * 5_000 + "]" * 5_000, "nested deeper than"),
    "value_tag": ("camera.seed=!!python/name:os.system", "is not allowed"),
    "value_dup": ("camera={seed: 1, seed: 2}", "duplicate key"),
    "value_two_docs": ("camera.seed=1\n---\n2", "a second document"),
    "value_long_int": ("camera.seed=" + "9" * 5_000, "a number too long"),
    "key_too_long": ("a" * 300 + "=1", "key too long"),
    "key_too_deep": (".".join(["a"] * 40) + "=1", "key too long"),
    "index_out_of_range": ("arm.joints.9.home=1", "no such item"),
    "negative_index": ("arm.joints.-1.home=1", "no such item"),
    "unicode_digit_index": ("arm.joints.²=1", "no item named"),
    "huge_index": ("arm.joints.99999999999999999999.home=1", "no item named"),
    "unknown_joint": ("arm.joints.knee.home=1", "no item named 'knee'"),
    # a red green (the detector gave such pixels to red, and the sort miscounted)
    "classes_same_to_camera": (
        "task.classes.green.hue_bands_deg=[{lo_deg: 340, hi_deg: 10}]",
        "'red' and 'green' are the same to the camera: both hold hues 340..360 deg",
    ),
    "bracket_index": (
        "task.classes[0].bin_cm=[1, 2, 3]",
        "dotted part, by its index or its name: task.classes.0.bin_cm",
    ),  # fmt: skip
    # named by the name typed, not the list index pydantic sees
    "joint_to_null": ("arm.joints.shoulder=null", "arm.joints.shoulder: is a whole item"),
    "class_to_scalar": ("task.classes.red=7", "task.classes.red: is a whole item"),
    "value_into_scalar": ("camera.seed.x=1", "is a value, not a section"),
    "section_to_scalar": ("camera=3", "camera"),
    "list_to_mapping": ("arm.joints={a: 1}", "arm.joints"),
    "seed_negative": ("camera.seed=-1", "camera.seed"),
    "seed_too_big": ("servo.error_model.seed=4294967296", "servo.error_model.seed"),
    "rate_tiny": ("servo.rate_hz=1e-300", "servo.rate_hz"),
    "rate_huge": ("servo.rate_hz=1e300", "servo.rate_hz"),
    "width_huge": ("camera.width_px=100000", "camera.width_px"),
    "median_huge": ("vision.median_kernel=100001", "vision.median_kernel"),
    "timeout_huge": ("camera.open_timeout_s=1e300", "camera.open_timeout_s"),
    "device_backend": ("camera.device_index=200", "camera.device_index"),
    "path_nul": ('camera.path="a\\0b"', "camera.path"),
    "path_long": ("camera.path=" + "a" * 5_000, "camera.path"),
    "port_empty": ("servo.port=''", "servo.port"),
    "too_many_classes": (
        "task.classes=["
        + ", ".join(
            f"{{name: c{i}, hue_bands_deg: [{{lo_deg: 1, hi_deg: 2}}], draw_rgb: [1, 2, 3], "
            f"bin_cm: [{i}, 40, 20]}}"
            for i in range(40)
        )
        + "]",
        "task.classes",
    ),  # fmt: skip
    "too_many_bands": (
        "task.classes.red.hue_bands_deg=[" + ", ".join(["{lo_deg: 1, hi_deg: 2}"] * 9) + "]",
        "hue_bands_deg",
    ),
    "revolute_limit_past_a_turn": ("arm.joints.base.limits.max=400", "more than a turn"),
    "passive_offset_past_a_turn": ("arm.joints.wrist.coupling.offset=400", "more than a turn"),
    "coupling_huge": ("arm.joints.wrist.coupling.terms.shoulder=1e9", "coupling.terms"),
    "gripper_arm_limit_past_a_turn": ("arm.tool.actuators.gripper_arm.limits.max=720", "turn"),
    "kd_unstable": ("controller.kd=1", "kd = 1 must be below 1"),
    "gains_unstable": ("controller.kp=1.9", "must be below 2"),
    "approach_zero": ("arm.tool.approach_axis=[0, 0, 0]", "non-zero vector"),
    "qp_solver_junk": ("controller.qp_solver='../../etc'", "controller.qp_solver"),
    "pick_retries_huge": ("task.pick_retries=1000000", "task.pick_retries"),
    "scene_color_unknown": ("task.scene=[{color: purple, x: 0, y: 40}]", "not a class"),
    # classes are a colour, a shape of the catalogue, or both
    "shape_unknown": (
        "task.classes.red.shape=hexagon",
        "task.classes.red.shape: no shape 'hexagon'; the catalogue has: cylinder, cube, prism",
    ),
    "class_neither_colour_nor_shape": (
        "task.classes.green.hue_bands_deg=null",
        "task.classes.green: class 'green' has neither a colour nor a shape: give it "
        "hue_bands_deg, a shape (cylinder, cube, prism), or both",
    ),
    "scene_yaw_past_a_turn": ("task.scene.0.yaw_deg=400", "task.scene.0.yaw_deg"),
    # a servo over a combination of joints (arm.joints[].servo.drives)
    "drives_missing_joint": (
        "arm.joints.elbow.servo.drives={terms: {knee: 1}}",
        "arm.joints.elbow.servo.drives.terms: 'knee' is not a joint of this arm",
    ),
    "drives_passive_joint": (
        "arm.joints.elbow.servo.drives={terms: {shoulder: 1, wrist: 1}}",
        "arm.joints.elbow.servo.drives.terms: 'wrist' is a passive joint",
    ),
    "drives_zero_row": (
        "arm.joints.elbow.servo.drives={terms: {shoulder: 0, elbow: 0}}",
        "arm.joints.elbow.servo.drives.terms: every coefficient is 0",
    ),
    "drives_as_another_servo": (
        "arm.joints.elbow.servo.drives={terms: {shoulder: 1}}",
        "arm.joints.elbow.servo.drives: elbow's servo turns shoulder, which depends on what the "
        "servo of shoulder turns",
    ),
    "drives_a_multiple_of_another": (
        "arm.joints.shoulder.servo.drives={terms: {elbow: -2}}",
        "arm.joints.shoulder.servo.drives: shoulder's servo turns -2·elbow, which depends on",
    ),
    "drives_home_past_the_pulse_range": (
        "arm.joints.elbow.servo.drives={terms: {shoulder: 1, elbow: 1}, offset: 300}",
        "arm.joints.elbow.servo.drives: at home its servo's value shoulder + elbow + 300 is 261",
    ),
    "drives_on_the_gripper": (
        "arm.tool.gripper.servo.drives={terms: {elbow: 1}}",
        "arm.tool.gripper.servo.drives: unknown key",
    ),
    "drives_huge": ("arm.joints.elbow.servo.drives={terms: {elbow: 1e9}}", "drives.terms.elbow"),
}


@bad_input
@pytest.mark.parametrize("name", list(SET_CASES))
def test_bad_set_is_refused(name: str, outputs: Path) -> None:
    """A malformed or out-of-range ``--set``: exit 2, one line naming the key."""
    text, words = SET_CASES[name]
    cmds = list(COMMANDS)
    cmd = cmds[sum(map(ord, name)) % len(cmds)]
    out = check_bad_input(command(cmd, outputs, "--set", text), within_s=2, keep=[CONFIGS])
    assert words in out.line
    assert_nothing_written(outputs)


@bad_input
def test_a_cube_the_open_jaws_cannot_pass_is_refused(outputs: Path) -> None:
    """A cube whose diagonal is as wide as the open jaws: exit 2, one line with both widths."""
    sets = ["--set", "task.classes.red.shape=cube", "--set", "task.classes.red.diameter_cm=3"]
    out = check_bad_input(command("sort", outputs, *sets), within_s=2, keep=[CONFIGS])
    assert (
        "task.classes.red.diameter_cm: a 3 cm cube is 4.24 cm across its diagonal, not less "
        "than the open jaws' 4 cm (arm.tool.gripper.open_cm)"
    ) in out.line


def test_a_cylinder_as_wide_as_the_open_jaws_is_refused(outputs: Path) -> None:
    """A cylinder the open jaws cannot come down around (the kinematic simulator sorted
    one as if they could): exit 2, one line with both widths."""
    sets = ["--set", "task.classes.red.diameter_cm=4"]
    out = check_bad_input(command("sort", outputs, *sets), within_s=2, keep=[CONFIGS])
    assert (
        "task.classes.red.diameter_cm: a 4 cm cylinder is 4 cm across, not less than the open "
        "jaws' 4 cm (arm.tool.gripper.open_cm)"
    ) in out.line


CONVEYOR = ["--config", str(CONFIGS / "sim_conveyor_kinematic.yaml")]


@bad_input
@pytest.mark.parametrize(
    ("sets", "words"),
    [
        (["belt.speed_cm_s=.nan"], "belt.speed_cm_s: Input should be a finite number"),
        (["belt.speed_cm_s=-1"], "belt.speed_cm_s: Input should be greater than or equal to 0"),
        (["belt.speed_cm_s=150"], "belt.speed_cm_s: Input should be less than or equal to 100"),
        # the paper's arm with a base servo of 1 s/60° (60°/s) cannot follow 30 cm/s
        (["arm.joints.base.servo.seconds_per_60deg=1.0", "belt.speed_cm_s=30"],
         "belt.speed_cm_s: 30 cm/s is faster than the arm can follow: at most 24.6 cm/s"),
        (["belt.width_cm=0"], "belt.width_cm: Input should be greater than 0"),
        (["belt.arrivals.count=501"], "belt.arrivals.count: Input should be less than or"),
        (["belt.arrivals.max_gap_s=1"], "belt.arrivals.max_gap_s: 1 s is below min_gap_s"),
    ],
)  # fmt: skip
def test_a_bad_belt_is_refused(sets: list[str], words: str, outputs: Path) -> None:
    """A belt the arm cannot follow, or a belt field out of its range: exit 2, one line
    naming the field and what is allowed."""
    extra = [a for s in sets for a in ("--set", s)]
    out = check_bad_input(command("sort", outputs, *CONVEYOR, *extra), within_s=2, keep=[CONFIGS])
    assert words in out.line


@bad_input
@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--speeds", "150"], "belt.speed_cm_s: Input should be less than or equal to 100"),
        (["--speeds", "1,30", "--set", "arm.joints.base.servo.seconds_per_60deg=1.0"],
         "belt.speed_cm_s: 30 cm/s is faster than the arm can follow: at most 24.6 cm/s"),
        (["--speeds", "fast"], "--speeds: speeds must be comma-separated numbers"),
        (["--config", "sim", "--speeds", "1"], "sim: the config has no belt"),
        # the twin's bins too low for the 12 greens this seed's belt brings: the table's
        # header was printed before the twin refused them
        (["--config", "sim_conveyor", "--set", "belt.arrivals.seed=874001", "--speeds", "1"],
         "class green: an object released at bin_cm z = 24 cm has its bottom"),
    ],
)  # fmt: skip
def test_conveyor_sweep_refuses_a_belt_it_cannot_run(argv, words) -> None:
    """``mearm conveyor-sweep``: every speed is checked before the first run, and the
    twin's scene before the table's header; a speed the arm cannot follow, or a scene the
    twin cannot build, is exit 2, one line, nothing printed of the table."""
    out = check_bad_input(["conveyor-sweep", *argv], within_s=2, keep=[CONFIGS])
    assert words in out.line and out.stdout == ""


#: A MeArm v1 whose servos' combinations are dependent in threes: (shoulder + elbow)
#: and 2·(shoulder + elbow); the message names the later one and the one it repeats.
_SHOULDER = "servo: {channel: 1, zero_us: 2255.5, direction: -1, us_per_unit: 11.0, "
_DEPENDENT = (
    f"{_SHOULDER}min_us: 544, max_us: 2400}}\n",
    f"{_SHOULDER}min_us: 544, max_us: 2400, drives: {{terms: {{shoulder: 2.0, elbow: 2.0}}}}}}\n",
)


@bad_input
@pytest.mark.parametrize(
    ("edit", "words"),
    [
        (_DEPENDENT, "arm.joints.elbow.servo.drives: elbow's servo turns shoulder + elbow, which "
                     "depends on what the servo of shoulder turns"),
        (("drives: {terms: {shoulder: 1.0, elbow: 1.0}}", "drives: {terms: {shoulder: 1.0, "
          "gripper: 1.0}}"), "arm.joints.elbow.servo.drives.terms: 'gripper' is not a joint"),
        (("drives: {terms: {shoulder: 1.0, elbow: 1.0}}", "drives: {terms: {wrist: 1.0}}"),
         "arm.joints.elbow.servo.drives.terms: 'wrist' is a passive joint"),
        (("drives: {terms: {shoulder: 1.0, elbow: 1.0}}", "drives: {terms: {}}"),
         "arm.joints.elbow.servo.drives.terms"),
    ],
)  # fmt: skip
def test_a_bad_servo_combination_in_a_file_is_refused(edit, words, tmp_path: Path) -> None:
    """``mearm fk --config`` a MeArm v1 whose elbow servo's ``drives`` is bad: exit 2, one
    line naming the field, before anything is computed."""
    text = (CONFIGS / "arms" / "mearm_v1.yaml").read_text(encoding="utf-8")
    assert edit[0] in text
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace(edit[0], edit[1]), encoding="utf-8")
    out = check_bad_input(["fk", "--config", bad, "--joints", "90,90,-90"], within_s=2)
    assert words in out.line and str(bad) in out.line


# ------------------------------------------------------------- the promise in a real process


@bad_input
@pytest.mark.parametrize(
    ("name", "words"),
    [
        ("alias_bomb", "aliases counted expanded"),
        ("deep_flow", "nested deeper than"),
        ("dev_zero", "not a regular file"),
        ("fifo", "not a regular file"),
        ("too_large", "too large"),
    ],
)
@pytest.mark.heavy
def test_harmful_config_ends_fast_in_a_real_process(
    name: str, words: str, bad_files: dict[str, Path]
) -> None:
    """The issue's cases, through ``python -m mearm``: under 2 s, exit 2, one line."""
    out = check_bad_input_subprocess(
        ["fk", "--config", bad_files[name], *FK], within_s=2, keep=[bad_files["empty"].parent]
    )
    assert words in out.line


@bad_input
@pytest.mark.heavy
def test_deep_set_value_ends_fast_in_a_real_process() -> None:
    """10 000-deep nesting given on the command line, not in a file."""
    out = check_bad_input_subprocess(
        ["sort", "--set", "camera.path=" + "[" * 10_000 + "]" * 10_000], within_s=2
    )
    assert "nested deeper than" in out.line


# --------------------------------------------------------------------------- properties


@bad_input
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(alphabet=st.characters(codec="utf-8"), max_size=200))
def test_any_text_loads_or_is_refused_in_one_line(text: str) -> None:
    """load_yaml_text on any text: plain data, or a ConfigError of one line — nothing else."""
    try:
        data = load_yaml_text(text, source="t.yaml", allow_empty=True)
    except ConfigError as exc:
        assert len(str(exc).splitlines()) == 1
    else:
        assert isinstance(data, (dict, list, str, int, float, bool, type(None)))


_yaml_atoms = st.sampled_from(
    ["[", "]", "{", "}", ":", ",", "- ", "&a ", "*a", "!!str ", "<<: ", "? ", "\n", "  ", "'",
     '"', "#", "a", "1", "---"]
)  # fmt: skip


@bad_input
@settings(max_examples=300, deadline=None)
@given(st.lists(_yaml_atoms, max_size=60).map("".join))
def test_yaml_shaped_text_loads_or_is_refused(text: str) -> None:
    """Text made of YAML's own punctuation: never an exception other than ConfigError."""
    try:
        load_yaml_text(text, source="t.yaml", allow_empty=True)
    except ConfigError as exc:
        assert len(str(exc).splitlines()) == 1


_json = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=20,
)
_v1_keys = st.sampled_from(["robot", "vision", "servo", "task", "camera", "calibration"])


@bad_input
@settings(max_examples=200, deadline=None)
@given(st.dictionaries(_v1_keys, _json, min_size=1, max_size=4), st.booleans())
@example({"vision": {"preset": []}}, True)  # once a TypeError: a list is unhashable
@pytest.mark.heavy
def test_any_format1_mapping_migrates_or_is_refused(data: dict, robot: bool) -> None:
    """migrate_v1_config + validation on arbitrary data: a Config or a ConfigError."""
    if robot:
        data = {"robot": {}, **data}
    try:
        config_from_dict(migrate_v1_config(data, source="header"), source="header")
    except ConfigError as exc:
        assert len(str(exc).splitlines()) == 1


_numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**30), max_value=10**30),
    st.sampled_from([0, -0.0, 1e-300, -1e-300, 5e-324, 1e308, 2**32, 2**63, -(2**63)]),
)


@bad_input
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([p for p, _, _ in FIELDS]), _numbers)
@pytest.mark.heavy
def test_any_number_in_any_field_is_accepted_or_refused_never_a_crash(
    path: str, value: float
) -> None:
    """fk with any number in any field: exit 0 (accepted, and nothing breaks) or 2, one line."""
    if math.isfinite(value):
        text = repr(value)
    else:
        text = ".nan" if value != value else ("-.inf" if value < 0 else ".inf")
    out = run_in_process(["fk", "--set", f"{path}={text}", *FK], within_s=5)
    assert out.code in (0, 2), out.stderr
    assert "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) <= 1


def test_the_depth_cap_leaves_room_for_real_configs() -> None:
    """The caps are far above what the reference configs use."""
    for path in CONFIGS.glob("*.yaml"):
        text = path.read_text(encoding="utf-8")
        assert len(text.encode()) < MAX_YAML_BYTES // 50
        depth = max(len(line) - len(line.lstrip(" ")) for line in text.splitlines()) // 2 + 3
        assert depth < MAX_YAML_DEPTH // 2
    assert sys.getrecursionlimit() > 10 * MAX_YAML_DEPTH


# ------------------------------------------------- mearm's rules, whatever the YAML parser

#: The parsers mearm composes on: libyaml (when PyYAML has it) and PyYAML's own.
PARSERS = {cls.__name__: cls for cls in yamlio._LOADERS}


def _nested(depth: int, shape: str) -> str:
    if shape == "flow":
        return "a: " + "[" * (depth - 1) + "]" * (depth - 1) + "\n"
    if shape == "mapping":
        return "a: " + "{b: " * (depth - 1) + "1" + "}" * (depth - 1) + "\n"
    return "".join(" " * i + f"k{i}:\n" for i in range(depth)) + " " * depth + "1\n"


@pytest.fixture(scope="module")
def nested() -> Callable[[int, str], str]:
    """:func:`_nested`, each text made once for the module: the cases with and without
    libyaml read the same texts (the 10 000-deep block is 50 MB, 0.17 s to make); freed
    with the module's fixtures."""
    return functools.cache(_nested)


@bad_input
@pytest.mark.parametrize("libyaml", [True, False], ids=["as-shipped", "without-libyaml"])
@pytest.mark.parametrize("shape", ["flow", "mapping", "block"])
def test_deep_nesting_is_refused_by_mearms_rule(
    libyaml: bool, shape: str, nested: Callable[[int, str], str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The cap is mearm's: the same line at depth cap + 1 and at 10 000, with or without
    libyaml (whose own limit, in PyYAML 6.0.4, stops a 10 000-deep line first)."""
    if not libyaml:
        monkeypatch.setattr(yamlio, "_LOADERS", (yamlio._ReferenceLoader,))
    load_yaml_text(nested(MAX_YAML_DEPTH, shape), source="ok.yaml")
    for depth in (MAX_YAML_DEPTH + 1, 10_000):
        with pytest.raises(ConfigError) as err:
            load_yaml_text(nested(depth, shape), source="deep.yaml")
        assert str(err.value).startswith("deep.yaml: ")
        assert f"nested deeper than {MAX_YAML_DEPTH} levels" in str(err.value)


@bad_input
@settings(max_examples=300, deadline=None)
@given(st.lists(_yaml_atoms, max_size=60).map("".join))
def test_the_parsers_agree_on_what_they_both_read(text: str) -> None:
    """libyaml is only an accelerator: where both parsers read a text, the data is the same."""
    results = []
    for cls in PARSERS.values():
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(yamlio, "_LOADERS", (cls,))
            try:
                results.append(load_yaml_text(text, source="t.yaml", allow_empty=True))
            except ConfigError:
                results.append(ConfigError)
    if ConfigError not in results:
        assert all(r == results[0] for r in results)


def test_the_parsers_agree_on_every_reference_config(monkeypatch: pytest.MonkeyPatch) -> None:
    texts = [path.read_text(encoding="utf-8") for path in sorted(CONFIGS.rglob("*.yaml"))]
    assert texts
    read = {}
    for name, cls in PARSERS.items():
        monkeypatch.setattr(yamlio, "_LOADERS", (cls,))
        read[name] = [load_yaml_text(text) for text in texts]
    assert all(data == read[next(iter(read))] for data in read.values())
