"""Bad-input corpus: scene files (``--scene``) for ``sort`` and ``experiment``.

A scene file is read as a config is (mearm.yamlio: no special files, size, depth,
aliases, tags, duplicate keys), then each entry is validated: a class name and x, y
within the table's physical range. Every case: exit 2, one line, nothing written.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from badinput import check_bad_input, check_bad_input_subprocess, run_in_process

from mearm.config.sections import MAX_SCENE_OBJECTS

bad_input = pytest.mark.bad_input

OBJ = "{color: red, x: -10.99, y: 49.70}"

#: name → (file contents, words the one line must hold).
BAD_SCENES: dict[str, tuple[str | bytes, str]] = {
    "mapping": ("color: red\nx: 0\ny: 40\n", "a scene is a list of {color, x, y} entries"),
    "scalar": ("12\n", "a scene is a list"),
    "string": ("red at the left\n", "a scene is a list"),
    "empty": ("", "empty scene"),
    "empty_list": ("[]\n", "no objects: nothing to sort"),
    "comments_only": ("# layout to come\n", "empty scene"),
    "null": ("~\n", "empty scene"),
    "list_of_numbers": ("[1, 2, 3]\n", "[0]"),
    "list_of_lists": ("- [red, 0, 40]\n", "[0]"),
    "missing_color": ("- {x: 0, y: 40}\n", "[0.color]"),
    "missing_x": ("- {color: red, y: 40}\n", "[0.x]"),
    "extra_key": ("- {color: red, x: 0, y: 40, z: 3}\n", "[0.z]"),
    # in a config's task.scene's words: it was "Extra inputs are not permitted" and
    # "[0.color]: Field required (got {...})"
    "colour_for_color": (
        "- {colour: red, x: 0, y: 40}\n",
        "[0.color]: required but missing; [0.colour]: unknown key; did you mean color?",
    ),
    "yaw_for_yaw_deg": ("- {color: red, x: 0, y: 40, yaw: 30}\n", "did you mean yaw_deg?"),
    "unknown_class": ("- {color: purple, x: 0, y: 40}\n", "'purple' is not a class"),
    "color_number": ("- {color: 7, x: 0, y: 40}\n", "[0.color]"),
    "color_bad_name": ("- {color: '../etc', x: 0, y: 40}\n", "[0.color]"),
    "color_long": ("- {color: " + "r" * 5000 + ", x: 0, y: 40}\n", "[0.color]"),
    "x_nan": ("- {color: red, x: .nan, y: 40}\n", "[0.x]"),
    "x_inf": ("- {color: red, x: .inf, y: 40}\n", "[0.x]"),
    "y_minus_inf": ("- {color: red, x: 0, y: -.inf}\n", "[0.y]"),
    "x_huge": ("- {color: red, x: 1e308, y: 40}\n", "[0.x]"),
    "x_past_range": ("- {color: red, x: 1000.5, y: 40}\n", "[0.x]"),
    "y_text": ("- {color: red, x: 0, y: forty}\n", "[0.y]"),
    # the value said once: it was "expected a number, got true (got True)"
    "x_bool": ("- {color: red, x: true, y: 40}\n", "[0.x]: expected a number, got true\n"),
    "y_list": ("- {color: red, x: 0, y: [40]}\n", "[0.y]"),
    "x_long_int": ("- {color: red, x: " + "9" * 5000 + ", y: 40}\n", "a number too long"),
    "second_entry_bad": (f"- {OBJ}\n- {{color: red, x: 0}}\n", "[1.y]"),
    "too_many": (
        "[" + ", ".join([OBJ] * (MAX_SCENE_OBJECTS + 1)) + "]\n",
        f"a scene holds at most {MAX_SCENE_OBJECTS}",
    ),  # fmt: skip
    "alias_bomb": (
        "- &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n"
        + "".join(
            f"- &a{i} [" + ", ".join([f"*a{i - 1}" if i else "*a"] * 10) + "]\n" for i in range(6)
        ),
        "aliases counted expanded",
    ),  # fmt: skip
    "deep": ("[" * 10_000 + "]" * 10_000 + "\n", "nested deeper than"),
    "duplicate_key": ("- {color: red, x: 0, x: 1, y: 40}\n", "duplicate key 'x'"),
    "python_tag": ("- !!python/object:builtins.dict {color: red}\n", "is not allowed"),
    "latin1": ("- {color: r\xe9d, x: 0, y: 40}\n".encode("latin-1"), "not UTF-8 text"),
    "nul": (b"- {color: red, x: 0, y: 40}\n\x00", "control characters are not allowed"),
    "malformed": ("- {color: red, x: 0, y: 40\n", "malformed YAML"),
    "two_documents": (f"- {OBJ}\n---\n- {OBJ}\n", "a second document"),
    "too_large": ("# x\n" * (300_000), "too large"),
}


@pytest.fixture(scope="module")
def scenes(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("bad_scenes")
    paths = {}
    for name, (content, _) in BAD_SCENES.items():
        p = d / f"{name}.yaml"
        p.write_bytes(content.encode() if isinstance(content, str) else content)
        paths[name] = p
    os.mkfifo(d / "fifo.yaml")
    paths["fifo"] = d / "fifo.yaml"
    (d / "folder.yaml").mkdir()
    paths["folder"] = d / "folder.yaml"
    paths["dev_zero"] = Path("/dev/zero")
    paths["missing"] = d / "missing.yaml"
    return paths


SPECIAL = {
    "fifo": "not a regular file",
    "folder": "is a directory",
    "dev_zero": "not a regular file",
    "missing": "scene file not found",
}
ALL_SCENES = {**{k: v[1] for k, v in BAD_SCENES.items()}, **SPECIAL}


@pytest.fixture(scope="module", autouse=True)
def _imported() -> None:
    for argv in (["sort", "--help"], ["experiment", "--help"]):
        run_in_process(argv, within_s=60)


@bad_input
@pytest.mark.parametrize("name", list(ALL_SCENES))
@pytest.mark.heavy
def test_sort_refuses_a_bad_scene(name: str, scenes: dict[str, Path], tmp_path: Path) -> None:
    """sort --scene FILE: refused before the rig starts; the run log is not created."""
    log = tmp_path / "run.jsonl"
    out = check_bad_input(
        ["sort", "--scene", scenes[name], "--log", log, "--quiet"],
        within_s=2,
        keep=[scenes["empty"].parent],
    )
    assert ALL_SCENES[name] in out.stderr  # a "\n" in the words: they end the line
    assert not log.exists()


#: The harmful ones, for experiment too.
FOR_EXPERIMENT = ("mapping", "empty", "unknown_class", "x_nan", "too_many", "alias_bomb", "deep",
                  "duplicate_key", "latin1", "fifo", "dev_zero", "folder", "missing")  # fmt: skip


@bad_input
@pytest.mark.parametrize("name", FOR_EXPERIMENT)
def test_experiment_refuses_a_bad_scene(name: str, scenes: dict[str, Path], tmp_path: Path) -> None:
    """experiment --scene FILE: refused before the first trial."""
    log = tmp_path / "trials.jsonl"
    out = check_bad_input(
        ["experiment", "--scene", scenes[name], "--log", log, "--trials", "2"],
        within_s=2,
        keep=[scenes["empty"].parent],
    )
    assert ALL_SCENES[name] in out.line


@bad_input
@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--random", "-1"], f"N must be 1 to {MAX_SCENE_OBJECTS}, got -1"),
        (["--random", str(MAX_SCENE_OBJECTS + 1)], f"N must be 1 to {MAX_SCENE_OBJECTS}, got"),
        (["--random", "99999999999999999999"], f"N must be 1 to {MAX_SCENE_OBJECTS}, got"),
        (["--random", "3", "--seed", "-1"], "the seed must be in [0, 4294967295]"),
        (["--random", "3", "--seed", str(2**32)], "the seed must be in [0, 4294967295]"),
        (["--random", "3", "--seed", "9" * 400], "the seed must be in"),
        (["--random", "x"], "--random: must be a plain integer"),
        (["--random", "1e3"], "--random: must be a plain integer"),
        (["--random", "3", "--scene", "x.yaml"], "not allowed with argument"),
        (["--random", "3", "--set", "camera.kind=device"], "not 'sim'"),
        (["--random", "5", "--set", "camera.width_px=16", "--set", "camera.height_px=16",
          "--set", "calibration.image_size_px=[16, 16]"],  # else refused for its size
         "the camera sees no table area"),
        (["--random", "5", "--set", "task.classes.red.diameter_cm=100"],
         "task.classes.red.diameter_cm"),  # wider than the open jaws: refused at load
        (["--random", str(MAX_SCENE_OBJECTS), "--set", "task.classes.red.diameter_cm=3"],
         "could not place"),
    ],
)  # fmt: skip
@pytest.mark.heavy
def test_sort_refuses_a_bad_random_scene(args: list[str], words: str) -> None:
    """--random N --seed S out of range, or no room for the objects: exit 2, one line."""
    out = check_bad_input(["sort", "--quiet", *args], within_s=5)
    assert words in out.line


@bad_input
@pytest.mark.parametrize("name", ["alias_bomb", "deep", "dev_zero", "too_large"])
@pytest.mark.heavy
def test_harmful_scene_ends_fast_in_a_real_process(name: str, scenes: dict[str, Path]) -> None:
    out = check_bad_input_subprocess(
        ["sort", "--scene", scenes[name], "--quiet"], within_s=2, keep=[scenes["empty"].parent]
    )
    assert ALL_SCENES[name] in out.line


#: The paper's twelve objects, as a scene file's entries.
PAPER = "".join(
    f"- {{color: {c}, x: {x}, y: {y}}}\n"
    for c, x, y in (("red", -10.99, 49.70), ("red", -0.75, 53.72), ("red", -0.40, 42.01),
                    ("red", 8.08, 46.71), ("green", -8.31, 53.81), ("green", -4.57, 47.58),
                    ("green", 5.15, 53.38), ("green", 11.74, 42.88), ("blue", -10.08, 44.03),
                    ("blue", 2.03, 48.57), ("blue", 6.93, 41.11), ("blue", 12.15, 51.86))
)  # fmt: skip

#: name → (the thirteenth object, words the one line must hold). Before, the sort left
#: each of these out and printed "sorted 12 of 12 objects" with exit 0.
LYING_SCENES: dict[str, tuple[str, str]] = {
    "behind the base": ("{color: red, x: 0, y: -20}", "[12] (red at x 0, y -20 cm): outside "
                        "the camera's view of the table"),
    "beside the base (y = 0)": ("{color: red, x: 30, y: 0}", "[12] (red at x 30, y 0 cm): "
                                "outside the camera's view"),
    "5 m away": ("{color: blue, x: 500, y: 40}", "[12] (blue at x 500, y 40 cm): outside the "
                 "camera's view of the table (640x480 px through calibration): the whole "
                 "object must be seen (centres within x -19.4…18.4, y 30.1…57.9 cm are)"),
    "half out of view": ("{color: red, x: 0, y: 58.5}", "outside the camera's view"),
    "on the base plate": ("{color: red, x: 1, y: 0}", "[12] (red at x 1, y 0 cm): not on the "
                          "table: it stands on the arm's base plate"),
    "on another object": ("{color: green, x: -0.4, y: 43}", "[12] (green at x -0.4, y 43 cm): "
                          "overlaps "),
    "inside a bin": ("{color: red, x: -17, y: 45}", "[12] (red at x -17, y 45 cm): inside "
                     "green's bin (a 6.6 cm square, walls included"),
}  # fmt: skip


@bad_input
@pytest.mark.parametrize("name", LYING_SCENES)
def test_sort_refuses_a_scene_it_could_not_see_whole(name: str, tmp_path: Path) -> None:
    """An object off the table, out of view, on another or in a bin: exit 2 naming it."""
    obj, words = LYING_SCENES[name]
    scene = tmp_path / "scene.yaml"
    scene.write_text(PAPER + f"- {obj}\n")
    log = tmp_path / "run.jsonl"
    out = check_bad_input(["sort", "--scene", scene, "--log", log, "--quiet"], keep=[scene])
    assert (str(scene) + words if words.startswith("[") else words) in out.line
    if name == "on another object":
        assert out.line.endswith(
            f"{scene}[2] (red at x -0.4, y 42.01 cm): centres must be at least 2 cm apart"
        )
    assert not log.exists()


@bad_input
@pytest.mark.parametrize("command", ["sort", "experiment"])
def test_a_configured_scene_that_lies_is_refused(command: str, tmp_path: Path) -> None:
    """The config's own table (task.scene) is checked as a scene file is."""
    if command == "sort":
        argv = ["sort", "--set", "task.scene=[{color: red, x: 0, y: -20}]", "--quiet"]
        out = check_bad_input(argv)
        assert out.line.endswith("task.scene[0] (red at x 0, y -20 cm): outside the camera's "
                                 "view of the table (640x480 px through calibration): the "
                                 "whole object must be seen (centres within x -19.4…18.4, "
                                 "y 30.1…57.9 cm are)")  # fmt: skip
    else:
        scene = tmp_path / "scene.yaml"
        scene.write_text(PAPER + "- {color: red, x: 0, y: -20}\n")
        log = tmp_path / "trials.jsonl"
        out = check_bad_input(["experiment", "--scene", scene, "--log", log, "--trials", "2"])
        assert f"{scene}[12] (red at x 0, y -20 cm): outside" in out.line
        assert not log.exists()


def test_the_paper_layout_and_random_scenes_pass_the_check() -> None:
    """What the project ships and draws is a scene the sort sees whole."""
    from mearm.config import load_config
    from mearm.task import check_scene, random_scene

    for name in ("sim", "sim_4colours", "sim_mujoco_perspective", "sim_paper_arm"):
        config = load_config(name)
        check_scene(config, config.task.scene)
    config = load_config("sim")
    for seed in range(3):
        check_scene(config, random_scene(config, 12, seed=seed), "--random")
