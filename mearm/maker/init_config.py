"""``mearm init-config``: a starter config for one of the reference arms on your rig.

Writes a commented YAML config to start from: a reference config (its notes included) on
the rig you choose, with the next steps to take written at the top. Its arm is a
reference arm, named (``arm: {use: mearm_v1}``; its file, ``configs/arms/mearm_v1.yaml``,
holds the joints, limits, servo calibration and where each number comes from): the
header says how to change what differs on yours. ::

    mearm init-config --list
    mearm init-config --arm mearm_v1 --rig uno my_arm.yaml        # prints the wiring too
    mearm init-config --of my_arm.yaml --arm mearm_v1 --rig sim_mujoco my_twin.yaml
    mearm sort --config my_twin.yaml

The simulated rigs (``sim``, ``sim_mujoco``) write the reference config as it is. The real
rigs (``uno``, ``ssc32``) replace its servo link and camera with a real board and a USB
camera; the pixel-to-table calibration is then the reference's and must be redone for
your camera. The file is checked to load before it is written; an existing file is only
replaced with ``--force``, and kept as ``FILE.bak`` (named on stdout first: ``wrote
FILE.bak (the old FILE)``; not when it already holds what is written, which would replace
the ``.bak`` with a copy). FILE is checked as every command's output is
(:func:`mearm.cli.check_output_file`): a folder on its path that does not exist yet is
made, as by the project's other commands, and the ``wrote`` line names it (``wrote
confgis/my_arm.yaml (made the folder confgis): …``), so a mistyped folder shows at once.
A reference config that builds on
another (``extends``) is copied with its ``extends``, which then names the packaged
config: the starter config is
not written into a folder where a file of that name would be read instead. The real rigs'
header and output carry the arm's wiring (:mod:`mearm.maker.wiring`).

``--of MY_CONFIG`` writes a twin of the maker's own config instead: a file that extends
it (so the arm measured into it is the arm simulated) and replaces only the rig — the
simulated servos, and the simulated camera with the calibration of the reference's
simulated table, whose objects stand in only for a table MY_CONFIG leaves empty
(:func:`render_twin`, :func:`twin_table`). ``--arm`` names the reference arm whose table
that is; it may be left out only when MY_CONFIG's arm is a reference arm by name (``arm:
{use: mearm_v1}`` without a ``name`` of its own). The twin is not written where a config
of MY_CONFIG's chain looks for the file it extends (``sim.yaml`` beside a
``my_arm.yaml`` that extends the packaged ``sim.yaml``): read instead, it would extend
MY_CONFIG, and neither would load (:func:`check_not_shadowing`). MY_CONFIG may be a
packaged config's name (``--of sim``): the twin then extends it by that name, from any
folder (:func:`twin_extends`).
"""

from __future__ import annotations

import math
import os
import re
import shlex
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from mearm import __version__, data
from mearm.cli import (
    EXIT_OK,
    ArgumentParser,
    backup_existing,
    check_output_file,
    invoked_as,
    run,
    write_text_atomic,
)
from mearm.config import Config, SceneObject, config_from_dict, load_config
from mearm.config.compose import EXTENDS_KEY, USE_KEY, expand_config
from mearm.config.defaults import DEFAULT_ARM
from mearm.config.files import resolve_config_path
from mearm.errors import ConfigError, MearmError
from mearm.fileio import backup_path, escaped
from mearm.maker.wiring import Board, wiring_text
from mearm.yamlio import load_yaml_file, load_yaml_text

#: Servo channels the Uno firmware drives (``SERVO_COUNT`` in
#: tools/arduino/mearm_servo/mearm_servo.ino; its ``V`` reply says so too).
UNO_SERVO_COUNT = 5


def reference_config_dir() -> Path:
    """The folder of the reference configs.

    :data:`mearm.data.CONFIGS_DIR`: the checkout's ``configs/`` through its link, or the
    copies an installed wheel ships.

    Raises:
        MearmError: they are not there.
    """
    folder = data.CONFIGS_DIR.resolve()
    if (folder / "sim.yaml").is_file():
        return folder
    raise MearmError(
        f"the reference configs are not installed (looked in {folder}): reinstall mearm"
    )


@dataclass(frozen=True)
class ArmChoice:
    """A reference arm.

    Attributes:
        name: What ``--arm`` takes.
        title: One line for ``--list`` and the file's header.
        sim: Its reference config on the kinematic simulator (file name in configs/).
        twin: Its reference config in the physical twin.
        real: The reference config the real rigs start from.
        arm_file: The reference arm it uses (``configs/arms/<arm_file>.yaml``).
    """

    name: str
    title: str
    sim: str
    twin: str
    real: str
    arm_file: str


@dataclass(frozen=True)
class RigChoice:
    """A rig: what drives the servos and where the frames come from.

    Attributes:
        name: What ``--rig`` takes.
        title: One line for ``--list`` and the file's header.
        servo_block: The config's ``servo:`` section (``None``: the reference's).
        camera_block: The config's ``camera:`` section (``None``: the reference's).
        steps: What to do next, one command or sentence per item; ``{config}`` is the
            written file, ``{arm}`` the reference arm chosen (``--arm``).
    """

    name: str
    title: str
    servo_block: str | None
    camera_block: str | None
    steps: tuple[str, ...]

    @property
    def real(self) -> bool:
        """Whether it drives a real arm (its servo link is replaced)."""
        return self.servo_block is not None


ARMS: dict[str, ArmChoice] = {
    a.name: a
    for a in (
        ArmChoice(
            "paper",
            "the paper's arm (Agustian et al.): base, shoulder and elbow servos, a levelled "
            "wrist, a gripper arm and a gripper",
            "sim.yaml",
            "sim_mujoco.yaml",
            "lab.yaml",
            "mearm_paper",
        ),
        ArmChoice(
            "mearm_v1",
            "the MeArm v1 kit: four SG90 micro servos, acrylic links, a claw",
            "sim_mearm_v1.yaml",
            "sim_mearm_v1_mujoco.yaml",
            "sim_mearm_v1.yaml",
            "mearm_v1",
        ),
        ArmChoice(
            "desk_5dof",
            "a 5-joint desk arm (base, shoulder, elbow, wrist pitch and roll) with a gripper: "
            "six servos",
            "sim_5dof.yaml",
            "sim_5dof_mujoco.yaml",
            "sim_5dof.yaml",
            "desk_5dof",
        ),
    )
}

_REAL_CAMERA = """\
camera:
  kind: device              # a USB camera; mearm find-camera lists them with a snapshot
  device_index: 0           # which one; or path: /dev/v4l/by-id/... (stays the same on replug)
  width_px: 640             # the frame size; the calibration is in pixels of this size
  height_px: 480
  open_timeout_s: 5.0       # opening and the first frame must take no longer
"""

_UNO_SERVO = """\
servo:
  backend: serial           # an Arduino Uno running the mearm firmware (mearm flash)
  port: /dev/ttyACM0        # the board's port: mearm find-port names it
  baud: 115200              # the firmware's baud rate
  rate_hz: 50.0             # commands per second at most (the servos' 50 Hz frame rate)
  ack_timeout_s: 0.5        # every command waits this long for the board's acknowledgement
  banner_timeout_s: 3.0     # opening the port resets the Uno: wait this long for its banner
  retries: 3                # resends of a command that failed its checksum
  # Each servo's channel and pulse calibration (zero_us, us_per_unit, direction) is with
  # its joint in the arm's description; mearm calibrate-servos measures them into a file
  # (calibration_file). The Uno's channels 0..4 are its pins D3, D5, D6, D9 and D10.
"""

_SSC32_SERVO = """\
servo:
  backend: ssc32            # a Lynxmotion SSC-32 or SSC-32U servo controller
  port: /dev/ttyUSB0        # the board's port: mearm find-port --replug finds it
  baud: 9600                # as set on the board (SSC-32 jumpers; SSC-32U: 9600 unless changed)
  rate_hz: 50.0             # commands per second at most; lowered if the baud rate demands
  ack_timeout_s: 0.5        # every query waits this long for the board's answer
  retries: 3                # queries asked again after a lost, late or garbled answer
  # Each servo's channel (0..31) and pulse calibration (zero_us, us_per_unit, direction)
  # is with its joint in the arm's description; mearm calibrate-servos measures them into
  # a file (calibration_file).
"""

#: The camera's calibration step: markers of a printed sheet on the table, seen in a
#: snapshot (docs/maker-path.md shows where they go for each reference arm).
CAMERA_STEP = (
    "mearm aruco-sheet --output sheet.png, lay the markers on the table, then "
    "mearm calibrate-camera --config {config} --image snapshots/camera0.png "
    "--marker-side-cm 4 --marker 0:X,Y --marker 1:X,Y --marker 2:X,Y --marker 3:X,Y"
)

#: The simulated rigs' second step: the maker's own config, simulated as it is.
OWN_CONFIG_STEP = (
    "to simulate your own config as it is: mearm init-config --of MY_CONFIG.yaml "
    "--arm {arm} --rig sim_mujoco MY_TWIN.yaml"
)

RIGS: dict[str, RigChoice] = {
    r.name: r
    for r in (
        RigChoice(
            "sim",
            "everything simulated: a kinematic arm, the table rendered from above",
            None,
            None,
            ("mearm sort --config {config}", OWN_CONFIG_STEP),
        ),
        RigChoice(
            "sim_mujoco",
            "the physical twin (MuJoCo): servo, contact and friction models, a rendered "
            "camera (needs the mujoco package)",
            None,
            None,
            ("mearm sort --config {config}", OWN_CONFIG_STEP),
        ),
        RigChoice(
            "uno",
            "an Arduino Uno running the mearm firmware drives the servos; a USB camera",
            _UNO_SERVO,
            _REAL_CAMERA,
            (
                "wire the servos as the table below shows ({maker_path})",
                "mearm find-port --replug (names the Uno's port; set servo.port)",
                "mearm flash --config {config} (puts the firmware on the Uno)",
                "mearm calibrate-servos --config {config} (the horns go on at home first)",
                "mearm find-camera --out snapshots (set camera.device_index or camera.path)",
                CAMERA_STEP,
                "mearm sort --config {config}",
            ),
        ),
        RigChoice(
            "ssc32",
            "a Lynxmotion SSC-32 servo controller drives the servos; a USB camera",
            _SSC32_SERVO,
            _REAL_CAMERA,
            (
                "wire the servos as the table below shows ({maker_path})",
                "mearm find-port --replug (names the board's port; set servo.port)",
                "mearm calibrate-servos --config {config} (the horns go on at home first)",
                "mearm find-camera --out snapshots (set camera.device_index or camera.path)",
                CAMERA_STEP,
                "mearm sort --config {config}",
            ),
        ),
    )
}


def reference_file(arm: ArmChoice, rig: RigChoice) -> str:
    """The reference config (a file name in configs/) the starter config is made from."""
    if rig.real:
        return arm.real
    return arm.twin if rig.name == "sim_mujoco" else arm.sim


@dataclass(frozen=True)
class Block:
    """A top-level section of a YAML file: its key and its text, comments above it included.

    Attributes:
        key: The top-level key (``""`` for the file's header comment).
        text: Its lines, each ending in a newline.
    """

    key: str
    text: str


_TOP_KEY = re.compile(r"^([A-Za-z_][A-Za-z0-9_]*):")


def split_blocks(text: str) -> list[Block]:
    """Cut a YAML file at its top-level keys; comment lines right above a key go with it.

    The first block (key ``""``) is what comes before: the file's header comment.
    """
    lines = text.splitlines(keepends=True)
    blocks: list[Block] = []
    key, start = "", 0
    for i, line in enumerate(lines):
        match = _TOP_KEY.match(line)
        if not match:
            continue
        head = i
        while head > start and lines[head - 1].startswith("#"):
            head -= 1
        blocks.append(Block(key, "".join(lines[start:head])))
        key, start = match.group(1), head
    blocks.append(Block(key, "".join(lines[start:])))
    return [b for b in blocks if b.key or b.text.strip()]


def _commented(text: str) -> str:
    return "".join(f"# {line}".rstrip() + "\n" for line in text.splitlines())


def render_config(arm: ArmChoice, rig: RigChoice, config_name: str) -> str:
    """The starter config's text (see the module docstring).

    Raises:
        MearmError: the arm cannot run on the rig (more servos than the board drives).
    """
    config_name = escaped(config_name)  # a file name that is not UTF-8: YAML is UTF-8 text
    source = reference_file(arm, rig)
    folder = reference_config_dir()
    text = (folder / source).read_text(encoding="utf-8")
    blocks = split_blocks(text)
    if rig.name == "uno":
        _check_uno_channels(arm, text, source)
    arm_name = load_config(folder / source).arm.name
    header = _header(arm, rig, source, config_name, arm_name)
    replaced = {"servo": rig.servo_block, "camera": rig.camera_block} if rig.real else {}
    body: list[str] = []
    for block in blocks:
        if block.key == "":
            body.append(f"# --- the notes of {source}: ---\n" + block.text.rstrip("\n") + "\n\n")
        elif block.key in replaced:
            body.append(replaced.pop(block.key) or "")
            body.append("\n")
        elif rig.real and block.key in ("simulator", "twin"):
            continue
        elif rig.real and block.key == "task" and "bin_height_cm" not in block.text:
            body.append(_with_bins_note(block.text, load_config(folder / source)))
        elif rig.real and block.key == "calibration" and arm.real != "lab.yaml":
            body.append(
                f"# REDO THIS for your camera (mearm calibrate-camera --config {config_name}):\n"
                f"# the homography below is for the simulated camera of {source}.\n" + block.text
            )
        else:
            body.append(block.text)
    for section in replaced.values():  # sections the reference leaves at their defaults
        body.append("\n" + (section or ""))
    return header + "".join(body).rstrip("\n") + "\n"


def _with_bins_note(task_block: str, reference: Config) -> str:
    """The task block with a note on bin heights after its key (a real rig's bins are the maker's).

    The note names each class's highest allowed ``bin_height_cm`` (below the bottom of an
    object released over its bin: :meth:`Config._bins_below_release`).
    """
    tcp_cm = reference.arm.tool.tcp_above_grip_cm
    most = ", ".join(
        f"{c.name} {math.floor((c.bin_cm[2] - tcp_cm - c.grip_z_cm) * 10) / 10:g}"
        for c in reference.task.classes
    )
    first = reference.task.classes[0].name
    note = (
        "  # Your bins' walls: the planner keeps the arm clear of walls tall enough to hold the\n"
        "  # scene's objects of a class stacked, unless the class says how tall its bin is\n"
        f"  # (task.classes.NAME.bin_height_cm, measured; e.g. --set task.classes.{first}."
        "bin_height_cm=2).\n"
        f"  # At most, in cm (below the objects released over it): {most}.\n"
    )
    head, key, rest = task_block.partition("task:\n")
    return head + key + note + rest


def _header(arm: ArmChoice, rig: RigChoice, source: str, config_name: str, arm_name: str) -> str:
    maker_path = data.doc_page("maker-path.md")
    steps = "".join(
        f"#   {n}. {step.format(config=config_name, maker_path=maker_path, arm=arm.name)}\n"
        for n, step in enumerate(rig.steps, 1)
    )
    wiring = ""
    if rig.real:
        board: Board = "uno" if rig.name == "uno" else "ssc32"
        text = wiring_text(load_config(reference_config_dir() / source).arm, board)
        wiring = "# Wiring (the channels of the arm's description):\n" + _commented(text)
    return (
        f"# mearm config: {arm.name} on the {rig.name} rig.\n"
        f"# Arm: {arm.title}.\n"
        f"# Rig: {rig.title}.\n"
        f"# Written by mearm init-config --arm {arm.name} --rig {rig.name} (mearm "
        f"{__version__}) from configs/{source}.\n"
        "# Every number is yours to change: measure your arm (link lengths, joint limits) and\n"
        f"# calibrate its servos. The arm is the reference arm {arm_name}, by name; its file,\n"
        f"# configs/arms/{arm_name}.yaml, says where each number comes from. Write what\n"
        "# differs on yours under arm:, beside use:, a joint by its name, e.g.\n"
        f"#   arm: {{use: {arm_name}, joints: {{shoulder: {{dh: {{a_cm: 8.2}}}}}}}}\n"
        "# A key left out takes the value of the config this one extends, else its default\n"
        "# (configs/sim.yaml shows them all). Units: cm and degrees unless a key says otherwise.\n"
        f"# Next steps:\n{steps}{wiring}\n"
    )


def _check_uno_channels(arm: ArmChoice, text: str, source: str) -> None:
    config = config_from_dict(load_yaml_text(text, source=source), source=source)
    channels = sorted(_servo_channels(config))
    if channels and channels[-1] >= UNO_SERVO_COUNT:
        raise MearmError(
            f"the {arm.name} arm uses servo channels {', '.join(map(str, channels))}; the Uno "
            f"firmware drives channels 0..{UNO_SERVO_COUNT - 1}: choose --rig ssc32"
        )


def _servo_channels(config: Config) -> set[int]:
    arm = config.arm
    channels = {j.servo.channel for j in arm.joints if j.servo is not None}
    channels |= {a.servo.channel for a in arm.tool.actuators}
    if arm.tool.gripper is not None:
        channels.add(arm.tool.gripper.servo.channel)
    return channels


def arm_of(config: Config) -> ArmChoice:
    """The reference arm a config's arm is (its ``arm.name``).

    Raises:
        MearmError: it is none of them (``--arm`` then names the one to take the table of).
    """
    for choice in ARMS.values():
        if choice.arm_file == config.arm.name:
            return choice
    raise MearmError(
        f"arm {config.arm.name!r} is not a reference arm: give --arm, the one whose simulated "
        f"table (camera, objects) to use ({', '.join(ARMS)})"
    )


def _yaml(data: dict[str, Any]) -> str:
    return yaml.safe_dump(
        data, sort_keys=False, allow_unicode=True, width=88, default_flow_style=None
    )


def twin_extends(of: Path, out: Path) -> str:
    """The twin's ``extends``: the maker's config ``of`` relative to the twin's folder.

    The loader reads ``extends`` relative to the file that holds it; the line that says
    what was written names it the same way, so ``--of ../my_arm.yaml`` reads as it is.
    A packaged config's name (``--of sim``, no such file here) stays that name, which the
    loader reads as the packaged config from any folder.
    """
    if _packaged(of):
        return str(of)
    return os.path.relpath(of.absolute(), out.absolute().parent)


def _packaged(of: Path) -> bool:
    """Whether ``--of`` names a packaged config by its name (no file of that name here)."""
    return resolve_config_path(of) != of


def _servo_limits_on(joints: dict[str, Any], mine: Config) -> dict[str, Any]:
    """The twin reference's ``arm.joints`` servo settings, on the maker's actuated joints.

    The reference names its own joints (``base``, ``shoulder`` …). A maker's joints may be
    named otherwise (then the twin did not load: "no item named 'base'"), or be more (a
    wrist servo, a rail, which then ran with no acceleration limit, the limit that keeps a
    held object in the claw). A servo setting is its shaft's, whatever the joint, so each
    of the maker's actuated joints gets the strictest the reference gives any of its own.
    """
    settings: dict[str, float] = {}
    for entry in joints.values():
        for key, value in (entry.get("servo") or {}).items():
            settings[key] = min(value, settings.get(key, value))
    if not settings:
        return {}
    return {j.name: {"servo": dict(settings)} for j in mine.arm.joints if j.actuated}


def _class_settings_on(classes: dict[str, Any], mine: Config) -> dict[str, Any]:
    """The twin reference's ``task.classes`` settings, on the maker's classes.

    The reference sets them by its own classes' names (``red``, ``green``, ``blue``). A
    maker's classes may be named otherwise (``red_cube`` …: then the twin did not load,
    "task.classes.red: no item named 'red'"). A class of a name the reference sets keeps
    the reference's settings; each other class takes those the reference gives all of its
    own alike (the paper arm's twin grips every class at half the object's height,
    ``grip_height_cm: null``, as configs/sim_shapes_mujoco.yaml does its shapes).
    """
    entries = [dict(entry or {}) for entry in classes.values()]
    common = {
        key: value
        for key, value in (entries[0] if entries else {}).items()
        if all(key in entry and entry[key] == value for entry in entries)
    }
    out: dict[str, Any] = {}
    for name in mine.task.class_names:
        settings = dict(classes[name] or {}) if name in classes else dict(common)
        if settings:
            out[name] = settings
    return out


@dataclass(frozen=True)
class TwinTable:
    """The objects on the twin's table (:func:`twin_table`).

    Attributes:
        scene: The twin's ``task.scene``; ``None``: it writes none, and the maker's own
            (in the config it extends) stands.
        own: Whether the objects are the maker's own.
        problem: Why the sort would find none of the maker's classes on it, naming the
            maker's file and key, or ``None``.
    """

    scene: list[SceneObject] | None
    own: bool
    problem: str | None = None


def given_config(of: Path) -> dict[str, Any]:
    """What the maker's config ``of`` and the configs it extends write, merged.

    Not what they leave to the defaults; not validated (``of`` has loaded).
    """
    path = resolve_config_path(of)
    data = expand_config(load_yaml_file(path, what="config"), source=str(of), path=path)
    return dict(data) if isinstance(data, Mapping) else {}


def twin_table(of: Path, arm: ArmChoice, mine: Config) -> TwinTable:
    """The objects on the twin's table: the maker's own, else the reference's simulated ones.

    A maker's config that gives a table of its own (a ``task.scene`` with objects, in it
    or in what it extends) keeps it: its objects are of the maker's classes, where the
    maker's arm reaches. One that gives none (a real rig's ``task.scene: []``, or no
    ``task.scene`` at all) borrows the table of ``arm``'s simulated reference config,
    when that table's objects are all of the maker's classes. When they are not (classes
    of the maker's own, ``ruby`` and ``lime``), the twin would not load with them
    (``'red' is not a class``): its table is empty, and ``problem`` says which key of the
    maker's file to give. A belt brings the objects (the maker's belt, in what it
    extends): no table of them.
    """
    if mine.belt is not None:
        return TwinTable([], own=False)
    task = given_config(of).get("task")
    given = isinstance(task, Mapping) and "scene" in task
    if given and isinstance(task, Mapping) and task["scene"]:
        return TwinTable(None, own=True)
    reference = load_config(reference_config_dir() / arm.sim).task.scene
    colors = list(dict.fromkeys(obj.color for obj in reference))
    if all(color in mine.task.class_names for color in colors):
        return TwinTable(list(reference), own=False)
    problem = (
        f"{of}: task.scene: {'[]' if given else 'none given'}, and the simulated table of "
        f"configs/{arm.sim} holds {', '.join(colors)} objects, not your classes "
        f"({', '.join(mine.task.class_names)}): give task.scene objects of your classes "
        "({color, x, y} in cm) where the arm reaches and the camera sees, or sort with "
        "--random N"
    )
    return TwinTable([], own=False, problem=problem)


def render_twin(of: Path, out: Path, arm: ArmChoice, rig: RigChoice, mine: Config) -> str:
    """A config that extends the maker's own ``of`` (loaded: ``mine``), on ``rig``.

    The arm, the classes, the bins and the table stay the maker's (``extends``); the
    servo link and the camera become the simulated ones, the camera's calibration the
    reference's simulated config's, and so its objects where the maker's config gives
    none (:func:`twin_table`). On the twin rig
    the twin reference's own settings (``simulator``, ``twin``, the approach height …)
    are added as that file writes them, its joints' servo limits on the maker's joints
    (:func:`_servo_limits_on`; the built-in arm's, named, when the maker's config writes
    no ``arm``), its class settings on the maker's classes (:func:`_class_settings_on`;
    the built-in classes, written out, when it writes no ``task.classes``).

    Raises:
        MearmError: ``of``'s name is not UTF-8, which ``extends`` cannot name.
    """
    folder = reference_config_dir()
    sim = load_config(folder / arm.sim)
    extends = twin_extends(of, out)
    if escaped(extends) != extends:  # (the name must be the file's own: no escape names it)
        raise MearmError(
            f"--of {of}: the name is not UTF-8 text, which the twin's extends (YAML, UTF-8) "
            "cannot name: rename the file"
        )
    own: dict[str, Any] = {}
    if rig.name == "sim_mujoco":
        twin = load_yaml_text((folder / arm.twin).read_text(encoding="utf-8"), source=arm.twin)
        own = {k: v for k, v in twin.items() if k != EXTENDS_KEY}
        if "joints" in own.get("arm", {}):
            rest = {k: v for k, v in own["arm"].items() if k != "joints"}
            joints = _servo_limits_on(own["arm"]["joints"], mine)
            own["arm"] = {**rest, **({"joints": joints} if joints else {})}
            if not own["arm"]:
                del own["arm"]
        # changes by name merge over what the maker's chain writes; over what it leaves
        # to the defaults, a mapping of changes alone would be all there is
        given = given_config(of)
        if "arm" in own and "arm" not in given:  # the built-in arm, by name
            own["arm"] = {USE_KEY: DEFAULT_ARM, **own["arm"]}
        if "classes" in own.get("task", {}):
            classes: Any = _class_settings_on(own["task"]["classes"], mine)
            given_task = given.get("task")
            if classes and not (isinstance(given_task, Mapping) and "classes" in given_task):
                classes = [  # the built-in classes, written out with the changes
                    {**c.model_dump(mode="json", exclude_defaults=True), **classes.get(c.name, {})}
                    for c in mine.task.classes
                ]
            rest = {k: v for k, v in own["task"].items() if k != "classes"}
            own["task"] = {**rest, **({"classes": classes} if classes else {})}
    if rig.name == "sim_mujoco" and mine.twin.camera is not None:
        # the maker's config set the twin's camera (a twin config of its own): the twin's
        # camera is the reference twin's, as its calibration is (not a tilted lens the
        # homography below knows nothing of)
        ref = load_config(folder / arm.twin).twin.camera
        own["twin"] = {
            **own.get("twin", {}),
            "camera": None if ref is None else ref.model_dump(mode="json", exclude_none=True),
        }
    table = twin_table(of, arm, mine)
    task: dict[str, Any] = {}
    if table.scene is not None:
        task["scene"] = [s.model_dump(mode="json", exclude_defaults=True) for s in table.scene]
    sections: dict[str, Any] = {
        EXTENDS_KEY: extends,
        "simulator": "mujoco" if rig.name == "sim_mujoco" else "kinematic",
        "servo": {"backend": "sim"},
        "camera": sim.camera.model_dump(mode="json", exclude_none=True),
        "calibration": sim.calibration.model_dump(mode="json", exclude_none=True),
        **{k: v for k, v in own.items() if k not in ("simulator", "task")},
    }
    task.update(own.get("task", {}))
    if task:
        sections["task"] = task
    name = shlex.quote(str(out))
    header = (
        f"# mearm config: your {of.name} simulated, on the {rig.name} rig.\n"
        f"# Written by mearm init-config --of {shlex.quote(str(of))} --arm {arm.name} --rig "
        f"{rig.name} (mearm {__version__}).\n"
        f"# It extends {extends}: the arm, the classes and the bins are yours, so what you\n"
        f"# measure into that file is what is simulated here. Only the rig differs: the servos\n"
        "# and the camera are simulated, and the camera's view of the table (its calibration"
        + (", the objects on it" if table.scene is not None and not table.own else "")
        + f")\n# is the one of configs/{arm.sim}"
        + (f", in the physical twin of configs/{arm.twin}" if rig.name == "sim_mujoco" else "")
        + ".\n"
        + (
            f"# The objects on the table are yours: the task.scene of {of.name}.\n"
            if table.own
            else ""
        )
        + f"# Next steps:\n#   1. mearm sort --config {name}\n#   2. mearm jog --config {name}\n\n"
    )
    return escaped(header) + _yaml(sections)  # (a file name that is not UTF-8: escaped)


def check_folder(text: str, out: Path, what: str = "the starter config") -> None:
    """Refuse to write the starter config (``what``) where its ``extends`` would name another file.

    Raises:
        MearmError: ``out``'s folder holds a file of the name it extends (or ``out`` is
            that name), which would be read instead of the packaged config.
    """
    data = load_yaml_text(text, source=str(out))
    name = data.get(EXTENDS_KEY) if isinstance(data, dict) else None
    if isinstance(name, str) and (out.name == name or (out.parent / name).exists()):
        raise MearmError(
            f"{out}: {what} extends the packaged {name}, but a file of that name "
            f"in {out.parent} would be read instead: write it in another folder or name"
        )


def check_not_shadowing(of: Path, out: Path) -> None:
    """Refuse to write the twin under a name that ``of``'s chain reads as a file.

    ``extends`` names a file beside the config that holds it, else a packaged config
    (:func:`mearm.config.compose.expand_config`): a twin written where a config of the
    chain looks for the file it extends (``my_arm.yaml`` extends the packaged
    ``sim.yaml``; the twin is ``sim.yaml`` beside it) is read instead of it, and the two
    then extend each other: neither loads. The chain is read as it will be once the
    twin is there, so nothing is written that breaks the maker's own config.

    Raises:
        MearmError: a config of the chain would read ``out``.
    """
    target = out.resolve()
    path = resolve_config_path(of)
    seen: set[Path] = set()
    while path.resolve() not in seen:
        seen.add(path.resolve())
        try:
            read = load_yaml_file(path, what="config")
            name = read.get(EXTENDS_KEY) if isinstance(read, dict) else None
            if not isinstance(name, str) or not name.strip():
                return
            given = path.parent / name
            if given.resolve() == target:
                raise MearmError(
                    f"{out}: {path} extends {name}, which names this file once it is written: "
                    "the two would extend each other and neither would load; write the twin "
                    "under another name or in another folder"
                )
            found = given if given.is_file() else data.packaged_config(name)
        except (OSError, ConfigError):  # the loader says what is wrong with the chain
            return
        if found is None:
            return
        path = found


def check_rendered(text: str, out: Path) -> Config:
    """Validate the starter config's text as the loader will read it from ``out``.

    Raises:
        MearmError: it does not load (a bug in this module, not in the user's input).
    """
    name = str(out)
    try:
        return config_from_dict(load_yaml_text(text, source=name), source=name, path=out)
    except ConfigError as exc:
        raise MearmError(f"the starter config would not load (please report this): {exc}") from None


def list_choices() -> str:
    """The ``--list`` text."""
    width = max(map(len, [*ARMS, *RIGS]))
    arms = "".join(f"  {a.name:<{width}}  {a.title}\n" for a in ARMS.values())
    rigs = "".join(f"  {r.name:<{width}}  {r.title}\n" for r in RIGS.values())
    return f"arms (--arm):\n{arms}rigs (--rig):\n{rigs}"


#: ``--arm`` also takes an arm by its file's name in ``configs/arms/`` (``arm: {use: …}``).
ARM_FILE_NAMES = {"mearm_paper": "paper"}


def _arm_choice(text: str) -> str:
    """``--arm``'s value, an arm file's name (``mearm_paper``) read as its choice."""
    return ARM_FILE_NAMES.get(text, text)


def main(argv: Sequence[str] | None = None) -> int:
    """Write a starter config; see the module docstring."""
    parser = ArgumentParser(
        prog="mearm init-config",
        description="Write a starter config for a reference arm on your rig, or (--of) a "
        "simulated twin of your own config; --list shows the choices.",
        epilog="Exit status: 0 written, 2 bad input (an unknown choice, an arm with more "
        "servos than the board drives, an existing file without --force).",
    )
    parser.add_argument(
        "out", type=Path, nargs="?", metavar="FILE", help="the config file to write"
    )
    parser.add_argument(
        "--arm",
        type=_arm_choice,
        choices=list(ARMS),
        help="the reference arm closest to yours (with --of: the one whose simulated table, "
        "camera and objects the twin uses; default there: the arm your config names)",
    )
    parser.add_argument("--rig", choices=list(RIGS), help="what drives the servos, and the camera")
    parser.add_argument(
        "--of",
        type=Path,
        metavar="MY_CONFIG",
        help="simulate your own config: FILE extends MY_CONFIG (your arm as you measured "
        "it) and runs it on --rig sim or sim_mujoco",
    )
    parser.add_argument("--force", action="store_true", help="replace an existing file")
    parser.add_argument("--list", action="store_true", help="list the arms and rigs and exit")
    args = parser.parse_args(argv)
    if args.list:
        print(list_choices(), end="")
        return EXIT_OK
    needed: list[tuple[str, object]] = [("FILE", args.out)]
    if args.of is None:
        needed.append(("--arm", args.arm))
    needed.append(("--rig", args.rig))
    missing = [f for f, v in needed if not v]
    if missing:
        parser.error(f"needs {', '.join(missing)} (mearm init-config --list shows the choices)")
    out: Path = args.out
    if out.is_dir():
        raise MearmError(f"{out} is a folder: give the config file's name, e.g. {out}/my_arm.yaml")
    if out.exists() and not out.is_file():  # before a "wrote" line: nothing is written there
        raise MearmError(
            f"{out}: not a regular file (a device, FIFO or socket): give the config file's name"
        )
    check_output_file(out, "FILE")  # under a regular file, or in a folder not writable
    if out.exists() and not args.force:
        raise MearmError(f"{out} exists: pass --force to replace it")
    rig = RIGS[args.rig]
    if args.of is not None:
        return _write_twin(args.of, out, args.arm, rig)
    arm = ARMS[args.arm]
    text = render_config(arm, rig, shlex.quote(str(out)))
    check_folder(text, out)
    check_rendered(text, out)
    _keep_old(out, text)
    made = _made_folder(out)
    write_text_atomic(out, text)
    print(f"wrote {out}{made}: the {arm.name} arm on the {rig.name} rig. Next:")
    maker_path = data.doc_page("maker-path.md")
    for n, step in enumerate(rig.steps, 1):
        filled = step.format(config=shlex.quote(str(out)), maker_path=maker_path, arm=arm.name)
        print(f"  {n}. {filled}")
    if rig.real:
        board: Board = "uno" if rig.name == "uno" else "ssc32"
        print(f"Wiring of the {arm.name} arm ({maker_path}):")
        print(wiring_text(load_config(out).arm, board), end="")
    return EXIT_OK


def _made_folder(out: Path) -> str:
    """`` (made the folder F)`` when ``out``'s folder does not exist yet, else nothing.

    The write makes the missing folders (``mkdir -p``, as every command's output does);
    the ``wrote`` line says so, so a mistyped folder name is seen, not silently made.
    """
    return "" if out.parent.exists() else f" (made the folder {out.parent})"


def _keep_old(out: Path, text: str) -> None:
    """A config replaced with --force (a maker may have edited it) is kept as ``.bak``.

    Not when it already holds ``text``: a second ``--force`` would replace the ``.bak``,
    the maker's edits, with a copy of the file it writes again
    (:func:`~mearm.cli.backup_existing`, which names the backup on stdout).
    """
    try:
        backup_existing(out, text)
    except OSError as exc:
        raise MearmError(
            f"cannot keep {out} as {backup_path(out)}: {exc.strerror or exc}"
        ) from None


def _write_twin(of: Path, out: Path, arm_name: str | None, rig: RigChoice) -> int:
    if rig.real:
        raise MearmError(
            f"--of simulates your config: give --rig sim or sim_mujoco, not {rig.name}"
        )
    if not _packaged(of) and of.resolve() == out.resolve():
        raise MearmError(f"{out}: write the twin beside {of}, not over it")
    mine = load_config(of)
    check_not_shadowing(of, out)
    arm = ARMS[arm_name] if arm_name else arm_of(mine)
    text = render_twin(of, out, arm, rig, mine)
    name = str(out)
    if _packaged(of):  # its extends names the packaged config: no file of that name there
        check_folder(text, out, "the twin")
    twin = load_yaml_text(text, source=name)
    if not out.parent.exists() and not _packaged(of):  # made on writing: "new/../my_arm.yaml"
        twin[EXTENDS_KEY] = str(of.absolute())  # cannot be read yet
    try:
        config = config_from_dict(twin, source=name, path=out)
    except ConfigError as exc:
        raise MearmError(f"the twin of {of} does not load: {exc}") from None
    _keep_old(out, text)
    made = _made_folder(out)
    write_text_atomic(out, text)
    extends = twin_extends(of, out)
    print(f"wrote {out}{made}: your {of.name} on the {rig.name} rig (it extends {extends}). Next:")
    refused = _sort_refuses(config, twin_table(of, arm, mine), of, out)
    if refused is not None:  # a twin to look at and fix, but "Next: mearm sort" would fail
        prog = invoked_as("python -m mearm.maker.init_config")
        print(f"{prog}: warning: {refused}", file=sys.stderr)
        print(f"  1. change what the warning names, in {of.name} or {shlex.quote(name)}")
        print(f"  2. mearm sort --config {shlex.quote(name)}")
        return EXIT_OK
    print(f"  1. mearm sort --config {shlex.quote(name)}")
    return EXIT_OK


def _sort_refuses(config: Config, table: TwinTable, of: Path, out: Path) -> str | None:
    """Why ``mearm sort`` would refuse the twin ``config`` before it starts, or ``None``.

    The arm given by ``arm: {use: …}`` with the table of another config (the built-in
    paper arm's bins for a MeArm v1) loads, and its sort is refused: a bin out of reach.
    So is a table with nothing of the maker's classes on it (``table``), or one the
    twin's camera, the reference's, does not see whole (the maker's own objects, laid out
    for another camera): named by the file that holds it, the maker's ``of`` or ``out``.
    """
    from mearm.task.check import check_consistency  # noqa: PLC0415  (the kinematics)
    from mearm.task.scene import SceneError, check_scene  # noqa: PLC0415

    problems: list[str] = []
    try:
        check_consistency(config)
    except ConfigError as exc:
        problems += exc.problems
    if table.problem is not None:
        problems.append(table.problem)
    elif config.task.scene:
        try:
            check_scene(config, config.task.scene, f"{of if table.own else out}: task.scene")
        except SceneError as exc:
            problems.append(str(exc))
    if problems:
        return f"mearm sort would refuse it as it is: {'; '.join(problems)}"
    return None


if __name__ == "__main__":
    run(main)
