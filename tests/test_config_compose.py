"""Configs build on others (``extends``) and name their arm (``arm.use``); each arm once."""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
import yaml
from badinput import run_in_process
from built_once import computed_once
from conftest import ROOT

from mearm.config import ArmDescription, Config, DHRow, config_from_dict, load_config
from mearm.config.compose import MAX_EXTENDS, merge, reference_arm
from mearm.data import ARMS_DIR, arm_names
from mearm.exceptions import ConfigError

CONFIGS = ROOT / "configs"


def _write(folder: Path, name: str, text: str) -> Path:
    path = folder / name
    path.write_text(text)
    return path


def dump(name: str) -> dict[str, Any]:
    return load_config(CONFIGS / name).model_dump(mode="json")


def changed(a: Any, b: Any, where: str = "") -> set[str]:
    """The dotted paths at which two dumps differ (lists of mappings item by item)."""
    if isinstance(a, dict) and isinstance(b, dict):
        out: set[str] = set()
        for key in a.keys() | b.keys():
            out |= changed(a.get(key), b.get(key), f"{where}.{key}" if where else key)
        return out
    same_items = isinstance(a, list) and isinstance(b, list) and len(a) == len(b)
    if same_items and all(isinstance(x, dict) for x in a + b):
        pairs = enumerate(zip(a, b, strict=True))
        return set().union(*(changed(x, y, f"{where}.{i}") for i, (x, y) in pairs))
    return set() if a == b else {where}


# ------------------------------------------------------------------ the shipped configs

JOINT_ACCEL = {f"arm.joints.{i}.servo.max_accel_deg_s2" for i in range(3)}
GRIP_HEIGHTS = {f"task.classes.{i}.grip_height_cm" for i in range(3)}
TWIN = {"simulator", "twin.joint_servo", "task.approach_height_cm"}


@pytest.mark.parametrize(
    ("name", "base", "differences"),
    [
        ("lab.yaml", "sim.yaml", {"camera.kind", "servo.backend", "task.scene"}),
        (
            "sim_mujoco.yaml",
            "sim.yaml",
            TWIN | JOINT_ACCEL | GRIP_HEIGHTS,
        ),
        (
            "sim_mujoco_perspective.yaml",
            "sim_mujoco.yaml",
            {"twin.camera", "calibration.model", "calibration.intrinsics_file"}
            | {"calibration.extrinsics_file"},
        ),
        (
            "sim_mujoco_lamp.yaml",
            "sim_mujoco_perspective.yaml",
            {"twin.lamp", "vision.value_min", "vision.shadow_value_min"}
            | {"vision.highlight_saturation_min"},
        ),
        ("sim_mearm_v1_mujoco.yaml", "sim_mearm_v1.yaml", TWIN | JOINT_ACCEL),
        (
            "sim_5dof_mujoco.yaml",
            "sim_5dof.yaml",
            TWIN | {f"arm.joints.{i}.servo.max_accel_deg_s2" for i in range(5)},
        ),
    ],
)
def test_a_config_differs_from_what_it_extends_by_its_own_keys_only(name, base, differences):
    """Each config that extends another is that config with the differences its header lists."""
    assert yaml.safe_load((CONFIGS / name).read_text())["extends"] == base
    assert changed(dump(base), dump(name)) == differences


@pytest.mark.parametrize(
    ("name", "arm"),
    [
        ("sim.yaml", "mearm_paper"),
        ("sim_mearm_v1.yaml", "mearm_v1"),
        ("sim_5dof.yaml", "desk_5dof"),
    ],
)
def test_a_reference_config_has_its_arm_file_unchanged(name, arm):
    """The arm a config names is its file's, validated the same."""
    assert load_config(CONFIGS / name).arm == ArmDescription.model_validate(reference_arm(arm))


def test_the_built_in_arm_is_the_paper_arm_file():
    assert Config().arm == ArmDescription.model_validate(reference_arm("mearm_paper"))


def test_each_arm_file_is_named_after_its_arm_and_has_its_urdf():
    """configs/arms/<name>.yaml describes arm <name>; robot_description/ has <name>.urdf."""
    names = arm_names()
    assert names == ["desk_5dof", "mearm_paper", "mearm_v1"]
    for name in names:
        assert reference_arm(name)["name"] == name
    assert sorted(p.stem for p in (ROOT / "robot_description").glob("*.urdf")) == names


def test_set_reaches_a_named_arm():
    """--set changes the arm a config takes by name, after the name is resolved."""
    config = load_config("sim_mearm_v1", ["arm.joints.base.home=100"])
    assert config.arm.joints[0].home == 100.0


# ------------------------------------------------------------------ the merge rule


@pytest.mark.parametrize(
    ("key", "said", "in_python"),
    [("arm.use=desk_5dof", "arm.use: the reference arm a config builds on is named in its file",
      "arm.use: the reference arm a config builds on is named in its file"),
     ("extends=sim", "extends: the config a file builds on is named in the file, not by --set",
      "extends: the config a file builds on is named in the file, not by overrides")],
)  # fmt: skip
def test_set_refuses_the_keys_read_as_the_file_is_composed(
    key: str, said: str, in_python: str
) -> None:
    """``--set arm.use=…`` was "unknown key (… shows every key)", though the docs list
    ``arm.use`` and say any key can be set: it is read before --set applies."""
    with pytest.raises(ConfigError) as err:
        load_config("sim", [key])
    assert str(err.value).startswith(f"overrides: {in_python}")
    out = run_in_process(["fk", "--config", "sim", "--joints", "120,93,-132", "--set", key])
    assert out.code == 2 and out.line.startswith(f"mearm fk: error: --set: {said}")


def test_mappings_merge_key_by_key():
    base = {"a": {"b": 1, "c": {"d": 2, "e": 3}}, "f": 4}
    assert merge(base, {"a": {"c": {"d": 20}}, "g": 5}) == {
        "a": {"b": 1, "c": {"d": 20, "e": 3}},
        "f": 4,
        "g": 5,
    }
    assert base == {"a": {"b": 1, "c": {"d": 2, "e": 3}}, "f": 4}


def test_a_list_and_a_value_replace_null_included():
    base = {"joints": [{"name": "a"}, {"name": "b"}], "x": 1, "y": {"z": 1}}
    assert merge(base, {"joints": [{"name": "c"}]})["joints"] == [{"name": "c"}]
    assert merge(base, {"x": None, "y": None}) == {**base, "x": None, "y": None}


def test_a_mapping_over_named_items_changes_those_items():
    """Keys name items; only those change, the order stays the list's."""
    base = [{"name": "a", "v": {"p": 1, "q": 2}}, {"name": "b", "v": {"p": 3}}]
    assert merge(base, {"b": {"v": {"p": 30}}}, "arm.joints") == [
        {"name": "a", "v": {"p": 1, "q": 2}},
        {"name": "b", "v": {"p": 30}},
    ]


def test_a_mapping_over_named_items_refuses_a_name_not_there():
    with pytest.raises(ConfigError, match=r"arm\.joints\.knee: no item named 'knee'.*names: a, b"):
        merge([{"name": "a"}, {"name": "b"}], {"knee": {"home": 1}}, "arm.joints")


# ------------------------------------------------------------------ arm.use


def test_use_takes_the_arm_and_its_changes(tmp_path):
    path = _write(
        tmp_path,
        "c.yaml",
        "arm:\n  use: mearm_v1\n  joints:\n    base: {dh: {d_cm: 6.0}}\n"
        "  tool: {tcp_above_grip_cm: 0.5}\n",
    )
    arm, reference = load_config(path).arm, load_config("sim_mearm_v1").arm
    assert arm.joints[0].dh.d_cm == 6.0 and arm.tool.tcp_above_grip_cm == 0.5
    assert arm.joints[1:] == reference.joints[1:]
    assert arm.joints[0].servo == reference.joints[0].servo


def test_use_starts_the_arm_afresh_over_an_extended_config(tmp_path):
    """A config that names an arm drops what the config it extends said of its arm."""
    path = _write(tmp_path, "c.yaml", "extends: sim_mujoco.yaml\narm: {use: mearm_v1}\n")
    assert load_config(path).arm == load_config("sim_mearm_v1").arm


def test_unknown_arm_lists_the_known_names(tmp_path):
    path = _write(tmp_path, "c.yaml", "arm: {use: mearm_v2}\n")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    assert str(info.value) == (
        f"{path}: arm.use: no reference arm named 'mearm_v2' "
        "(known: desk_5dof, mearm_paper, mearm_v1)"
    )


@pytest.mark.parametrize("name", ["../sim", "", "arms/mearm_v1", 3, None])
def test_use_takes_only_a_reference_arms_name(name):
    with pytest.raises(ConfigError, match="arm.use: no reference arm named"):
        config_from_dict({"arm": {"use": name}})


# ------------------------------------------------------------------ extends


def test_extends_is_relative_to_the_file(tmp_path):
    (tmp_path / "sub").mkdir()
    _write(tmp_path, "base.yaml", "camera: {table: grey}\ncontroller: {kp: 0.2}\n")
    path = _write(tmp_path / "sub", "c.yaml", "extends: ../base.yaml\ncontroller: {kd: 0.02}\n")
    config = load_config(path)
    assert (config.camera.table, config.controller.kp, config.controller.kd) == ("grey", 0.2, 0.02)


def test_extends_names_a_packaged_config_from_anywhere(tmp_path):
    """A name that is no file beside the config is a packaged config (as --config takes)."""
    path = _write(tmp_path, "c.yaml", "extends: sim_mearm_v1\nservo: {grip_tolerance_cm: 0.5}\n")
    config = load_config(path)
    assert config.servo.grip_tolerance_cm == 0.5
    assert config.model_dump(exclude={"servo"}) == load_config("sim_mearm_v1").model_dump(
        exclude={"servo"}
    )


def test_an_extended_configs_files_stay_relative_to_its_folder(tmp_path):
    """sim_mujoco_perspective's calibration files are found in configs/, not beside c.yaml."""
    path = _write(tmp_path, "c.yaml", "extends: sim_mujoco_perspective.yaml\n")
    calibration = load_config(path).calibration
    assert Path(calibration.intrinsics_file).resolve() == (
        CONFIGS / "calibration" / "twin_intrinsics.yaml"
    )


def test_a_replayed_camera_path_is_relative_to_the_config_not_the_current_folder(tmp_path):
    """``camera: {kind: folder, path: frames}`` was read from the current folder: from
    anywhere but the config's own, ``mearm detect --camera`` said "no such folder". It is
    relative to the file that wrote it, as the calibration files are; through extends
    too; one given by --set to the current folder; a device's path stays as given."""
    cam = tmp_path / "comp" / "cam"
    (cam / "frames").mkdir(parents=True)
    cv2.imwrite(str(cam / "frames" / "f0.png"), np.full((480, 640, 3), 90, np.uint8))
    _write(cam, "cam.yaml", "extends: sim\ncamera: {kind: folder, path: frames}\n")
    child = _write(tmp_path, "child.yaml", "extends: comp/cam/cam.yaml\n")
    for path in (cam / "cam.yaml", child):
        assert Path(load_config(path).camera.path).resolve() == cam / "frames"
    r = run_in_process(["detect", "--config", cam / "cam.yaml", "--camera"], cwd=ROOT)
    assert r.code == 0 and "no such folder" not in r.stderr, r.stderr
    given = load_config(cam / "cam.yaml", ["camera.path=comp/cam/frames"]).camera.path
    assert given == str(Path("comp/cam/frames").absolute())
    device = load_config(cam / "cam.yaml", ["camera.kind=device", "camera.path=video0"])
    assert device.camera.path == "video0"


def test_a_missing_extends_names_the_file_and_the_packaged_configs(tmp_path):
    path = _write(tmp_path, "c.yaml", "extends: nowhere.yaml\n")
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert f"extends: 'nowhere.yaml' is not a file (looked for {tmp_path / 'nowhere.yaml'})" in (
        message
    )
    assert "packaged: lab, sim," in message


@pytest.mark.parametrize("value", ["", "  ", 3, ["sim.yaml"], None])
def test_extends_must_name_a_file(tmp_path, value):
    path = _write(tmp_path, "c.yaml", yaml.safe_dump({"extends": value}))
    with pytest.raises(ConfigError, match="extends: expected a config file's path or name"):
        load_config(path)


def test_a_config_extending_itself_is_refused(tmp_path):
    path = _write(tmp_path, "a.yaml", "extends: a.yaml\n")
    with pytest.raises(ConfigError, match=r"the configs extend each other \(a.yaml -> a.yaml\)"):
        load_config(path)


def test_a_loop_of_extends_is_refused_naming_it(tmp_path):
    _write(tmp_path, "a.yaml", "extends: b.yaml\n")
    _write(tmp_path, "b.yaml", "extends: c.yaml\n")
    _write(tmp_path, "c.yaml", "extends: a.yaml\n")
    with pytest.raises(ConfigError) as info:
        load_config(tmp_path / "a.yaml")
    assert str(info.value) == (
        f"{tmp_path / 'c.yaml'}: extends: the configs extend each other "
        "(a.yaml -> b.yaml -> c.yaml -> a.yaml)"
    )


def test_a_chain_longer_than_the_bound_is_refused(tmp_path):
    for i in range(MAX_EXTENDS + 1):
        _write(tmp_path, f"c{i}.yaml", f"extends: c{i + 1}.yaml\n")
    _write(tmp_path, f"c{MAX_EXTENDS + 1}.yaml", "{}\n")
    with pytest.raises(ConfigError, match=f"more than {MAX_EXTENDS} configs in one chain"):
        load_config(tmp_path / "c0.yaml")
    assert load_config(tmp_path / "c2.yaml") == Config()


def test_a_bad_extended_file_is_named(tmp_path):
    _write(tmp_path, "base.yaml", "- a list\n")
    with pytest.raises(ConfigError, match=r"base.yaml: top level must be a mapping"):
        load_config(_write(tmp_path, "c.yaml", "extends: base.yaml\n"))
    _write(tmp_path, "base.yaml", "controller: {kpp: 1}\n")
    base = re.escape(str(tmp_path / "base.yaml"))
    with pytest.raises(ConfigError, match=rf"^{base}: controller.kpp: unknown key"):
        load_config(tmp_path / "c.yaml")  # the file the key is written in (test_config_provenance)


@pytest.mark.heavy
def test_a_loop_exits_2_with_one_line_from_the_cli(tmp_path):
    _write(tmp_path, "a.yaml", "extends: b.yaml\n")
    _write(tmp_path, "b.yaml", "extends: a.yaml\n")
    r = run_in_process(["fk", "--config", tmp_path / "a.yaml", "--joints", "120,93,-132"])
    assert r.code == 2 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "the configs extend each other" in lines[0], r.stderr
    assert "Traceback" not in r.stderr


@pytest.mark.heavy
def test_an_unknown_arm_exits_2_with_one_line_from_the_cli(tmp_path):
    path = _write(tmp_path, "c.yaml", "arm: {use: meArm}\n")
    r = run_in_process(["fk", "--config", path, "--joints", "120,93,-132"])
    assert r.code == 2 and r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "known: desk_5dof, mearm_paper, mearm_v1" in lines[0], r.stderr


# ------------------------------------------------------------------ each arm written once

#: Where the project writes arms (tests build their own on purpose).
SCANNED = ("configs", "mearm", "docs", "tools", "README.md")
_FENCED_YAML = re.compile(r"^```ya?ml\n(.*?)^```", re.M | re.S)
Signature = tuple[tuple[str, tuple[float, ...]], ...]


def signature(joints: list[Any]) -> Signature | None:
    """A joint list as (name, DH row) pairs, or ``None`` if it is not one."""
    try:
        return tuple(
            (str(j["name"]), tuple(DHRow.model_validate(j["dh"]).model_dump().values()))
            for j in joints
        )
    except (KeyError, TypeError, ValueError):
        return None


def _lists_in(value: Any) -> Iterator[list[Any]]:
    if isinstance(value, dict):
        for v in value.values():
            yield from _lists_in(v)
    elif isinstance(value, list):
        yield value
        for v in value:
            yield from _lists_in(v)


def _python_value(node: ast.AST) -> Any:
    """A literal, or a call's keywords as a mapping (``Joint(name=…, dh=DHRow(…))``)."""
    if isinstance(node, ast.Call):
        out: dict[Any, Any] = {}
        for kw in node.keywords:
            value = _python_value(kw.value)
            if kw.arg:
                out[kw.arg] = value
            elif isinstance(value, dict):  # **mapping
                out.update(value)
        return out
    if isinstance(node, ast.List):
        return [_python_value(e) for e in node.elts]
    if isinstance(node, ast.Dict):
        return {
            _python_value(k): _python_value(v)
            for k, v in zip(node.keys, node.values, strict=True)
            if k
        }
    try:
        return ast.literal_eval(node)
    except ValueError:
        return None


def joint_lists_in(path: Path) -> Iterator[Signature]:
    """Every joint list written in a file: YAML, YAML blocks of Markdown, Python lists."""
    text = path.read_text(encoding="utf-8")
    documents: list[Any] = []
    if path.suffix == ".py":
        documents = [_python_value(n) for n in ast.walk(ast.parse(text)) if isinstance(n, ast.List)]
    else:
        blocks = _FENCED_YAML.findall(text) if path.suffix == ".md" else [text]
        for block in blocks:
            try:
                documents.append(yaml.safe_load(block))
            except yaml.YAMLError:
                continue
    for document in documents:
        for items in _lists_in(document):
            found = signature(items) if items and all(isinstance(i, dict) for i in items) else None
            if found:
                yield found


def joint_lists_of_the_project() -> dict[str, set[Signature]]:
    """Each scanned file's joint lists, by path relative to the checkout."""
    out = {}
    for top in SCANNED:
        paths = [ROOT / top] if (ROOT / top).is_file() else sorted((ROOT / top).rglob("*"))
        for path in paths:
            if path.suffix in (".yaml", ".yml", ".md", ".py") and path.is_file():
                out[path.relative_to(ROOT).as_posix()] = set(joint_lists_in(path))
    return out


@pytest.fixture(scope="module")
def project_joint_lists(tmp_path_factory: pytest.TempPathFactory) -> dict[str, set[Signature]]:
    """The scan of the whole project, made once per test run (each arm's case reads it)."""
    return computed_once(tmp_path_factory, "joint-lists", joint_lists_of_the_project)


@pytest.mark.parametrize("name", ["desk_5dof", "mearm_paper", "mearm_v1"])
@pytest.mark.heavy
def test_each_reference_arms_joint_list_is_written_in_one_file(name, project_joint_lists):
    """configs/arms/<name>.yaml is the only file of the project that lists its joints."""
    arm = signature(reference_arm(name)["joints"])
    assert arm is not None
    writing = [path for path, arms in project_joint_lists.items() if arm in arms]
    assert writing == [f"configs/arms/{name}.yaml"]


def keywords(row: dict[str, float]) -> str:
    return ", ".join(f"{k}={v}" for k, v in row.items())


def test_the_scan_finds_a_joint_list_in_yaml_markdown_and_python(tmp_path):
    """The scan is real: a copy of an arm's joints is found in each kind of file."""
    joints = reference_arm("mearm_v1")["joints"]
    arm = signature(joints)
    listed = yaml.safe_dump({"arm": {"joints": joints}})
    copies = {
        "copy.yaml": listed,
        "copy.md": f"Some text.\n\n```yaml\n{listed}```\n",
        "copy.py": "JOINTS = [\n"
        + "".join(
            f"    Joint(name={j['name']!r}, dh=DHRow({keywords(j['dh'])})),\n" for j in joints
        )
        + "]\n",
    }
    for name, text in copies.items():
        assert arm in set(joint_lists_in(_write(tmp_path, name, text))), name
    other = signature(reference_arm("mearm_paper")["joints"])
    assert other not in set(joint_lists_in(tmp_path / "copy.yaml"))
    assert (ARMS_DIR / "mearm_v1.yaml").resolve().parent == CONFIGS / "arms"
