"""Format-1 configs → the current layout: :func:`migrate_v1_config`.

Format 1 (the layout before the arm and the colour classes became data, stored in the
header of every format-1 run log) described one arm, the paper's, by position and three
fixed colours::

    robot:  {dh: [4 rows], joint_limits_deg: {joint1..joint3}, home_deg: [3],
             target_box, gripper: {a4_cm, a5_cm, travel_angle_deg, grip_angle_deg,
             home_angle_deg, pick_height_cm, gripper_arm_limits_deg}}
    vision: {preset, bands, saturation_min, value_min, object_diameter_cm, ...}
    servo:  {joints: {joint1, joint2, joint3, joint5}, gripper: {channel, open_us,
             closed_us}, error_model: {offset_deg: [3], ...}, ...}
    task:   {color_order, bins_cm, pick_retries, scene}

The rules, section by section (a key format 1 left out takes format 1's default, which
is the paper's rig, :func:`~mearm.config.defaults.paper_arm`):

- **arm**: joints named as format 1 numbered them, ``joint1``..``joint4`` (DH rows in
  order); ``joint1``..``joint3`` actuated, with the limits, home and servo calibration
  format 1 gave them (``us_per_deg`` → ``us_per_unit``); ``joint4`` passive,
  ``coupling: {terms: {joint2: -1, joint3: -1}}``. The servo ``joint5`` becomes the tool
  actuator ``gripper_arm`` (limits ``gripper_arm_limits_deg``, home / travel / grip
  angles). The gripper's two pulses become a calibration of its opening that gives
  exactly those pulses: open 4 cm → ``open_us``, closed 1 cm → ``closed_us``.
  ``tcp_above_grip_cm = pick_height_cm − 1.5`` (format 1 gripped 1.5 cm above the
  table). ``a4_cm`` and ``a5_cm`` are dropped (the DH rows already hold a4XY).
- **task.classes**: one class per colour of ``color_order``, in that order, with its bin
  from ``bins_cm``, the hue bands of the old preset (``default`` → the bands of
  :func:`~mearm.config.defaults.default_classes`, ``paper`` →
  :data:`~mearm.config.defaults.PAPER_HUE_BANDS_DEG`) unless ``vision.bands`` names the
  colour, ``draw_rgb`` of the default class of that name (grey if none),
  ``diameter_cm = vision.object_diameter_cm`` and ``grip_height_cm = 1.5``. Scene objects
  of a colour outside ``color_order`` are dropped: format 1 left them on the table, and
  the current layout has no class for them.
- **vision**: the preset's floors written out (``default``: S ≥ 0.4, V ≥ 0.25; ``paper``:
  0.1 and 0.1) unless given; ``preset``, ``bands`` and ``object_diameter_cm`` dropped.
- **servo**: ``joints`` and ``gripper`` move to the arm; ``error_model.offset_deg``
  ``[a, b, c]`` → ``{joint1: a, joint2: b, joint3: c}``.
- camera, calibration and controller are unchanged.

A mapping already in the current layout is returned unchanged (as a copy).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from mearm.config.base import example_file, short_repr
from mearm.config.defaults import (
    PAPER_CLASS_NAMES,
    PAPER_HUE_BANDS_DEG,
    PAPER_LAYOUT,
    default_classes,
    paper_arm,
)
from mearm.errors import ConfigError

#: Format 1 named the chain's joints by DH position: ``joint1``..``joint4``.
V1_JOINT_NAMES: tuple[str, ...] = tuple(f"joint{i}" for i in range(1, 5))
#: The three servo-driven joints of format 1; the fourth followed θ4 = −θ2 − θ3.
V1_ACTUATED: tuple[str, ...] = V1_JOINT_NAMES[:3]
#: Format 1's key of the gripper-arm servo (θ5) under ``servo.joints``.
_V1_TOOL_SERVO = f"joint{len(V1_JOINT_NAMES) + 1}"
#: Format 1's pick height of the end effector [cm], 1.5 + |13·sin(−60°)|.
_V1_PICK_HEIGHT_CM = 12.76
#: Height above the table at which format 1's gripper closed [cm].
_V1_GRIP_HEIGHT_CM = 1.5
#: Format 1's gripper pulses (channel, open, closed) [-, µs, µs].
_V1_GRIPPER = {"channel": 4, "open_us": 1000, "closed_us": 1900}
#: Format 1's object diameter [cm].
_V1_OBJECT_DIAMETER_CM = 2.0
#: Saturation and value floors of format 1's vision presets [-].
_V1_PRESET_FLOORS: dict[str, tuple[float, float]] = {"default": (0.4, 0.25), "paper": (0.1, 0.1)}
_GREY_RGB = [128, 128, 128]

#: Keys that only format 1 has, per section ("" is the top level).
_V1_KEYS: dict[str, tuple[str, ...]] = {
    "": ("robot",),
    "vision": ("preset", "bands", "object_diameter_cm"),
    "servo": ("joints", "gripper"),
    "task": ("color_order", "bins_cm"),
}
#: Keys that only the current layout has, per section.
_V2_KEYS: dict[str, tuple[str, ...]] = {"": ("arm",), "task": ("classes",)}


def _found(data: Mapping[str, Any], keys: dict[str, tuple[str, ...]]) -> list[str]:
    out = []
    for section, names in keys.items():
        node = data if not section else data.get(section)
        if isinstance(node, Mapping):
            out += [f"{section}.{k}" if section else k for k in names if k in node]
    return out


def _v1_markers(data: Mapping[str, Any]) -> list[str]:
    found = _found(data, _V1_KEYS)
    servo = data.get("servo")
    model = servo.get("error_model") if isinstance(servo, Mapping) else None
    if isinstance(model, Mapping) and isinstance(model.get("offset_deg"), list):
        found.append("servo.error_model.offset_deg (a list)")
    return found


def is_v1_config(data: Mapping[str, Any]) -> bool:
    """Whether ``data`` is a format-1 config: it has a key only format 1 has.

    ``robot`` marks every full format-1 config (a run-log header's); a partial file may
    instead set ``vision.preset``, ``vision.bands``, ``vision.object_diameter_cm``,
    ``servo.joints``, ``servo.gripper``, ``task.color_order``, ``task.bins_cm`` or a list
    ``servo.error_model.offset_deg``. A mapping with none of them (``{}`` included)
    means the same in both formats and counts as current.
    """
    return bool(_v1_markers(data))


def migrate_v1_config(data: Mapping[str, Any], *, source: str | None = None) -> dict[str, Any]:
    """Turn a format-1 config mapping into the current layout (rules in the module doc).

    Args:
        data: A config mapping, format 1 or current.
        source: Where it came from, for error messages (a file, ``run-log header``).

    Returns:
        A new mapping in the current layout, for :func:`~mearm.config.config_from_dict`;
        a copy of ``data`` when it is already current.

    Raises:
        ConfigError: ``data`` is not a mapping, mixes format-1 and current keys, or a
            format-1 value cannot be carried over (a section of the wrong type, a colour
            without a bin, equal gripper pulses, an unknown preset).
    """
    if not isinstance(data, Mapping):
        raise ConfigError(source, [f"top level must be a mapping, got {type(data).__name__}"])
    old, new = _v1_markers(data), _found(data, _V2_KEYS)
    if old and new:
        raise ConfigError(
            source,
            [
                f"mixes format-1 keys ({', '.join(old)}) with current ones ({', '.join(new)}); "
                f"write the file in one format ({example_file()} shows the current one)"
            ],
        )
    if not old:
        return copy.deepcopy(dict(data))
    return _Migration(data, source).run()


class _Migration:
    """One format-1 mapping being carried over; errors name the format-1 key."""

    def __init__(self, data: Mapping[str, Any], source: str | None):
        self.data = copy.deepcopy(dict(data))
        self.source = source
        self.template = paper_arm()

    def fail(self, where: str, problem: str) -> ConfigError:
        return ConfigError(self.source, [f"{where}: {problem} (format-1 config)"])

    def mapping(self, value: Any, where: str) -> dict[str, Any]:
        if value is None:
            return {}
        if not isinstance(value, Mapping):
            raise self.fail(where, f"must be a mapping, got {type(value).__name__}")
        return dict(value)

    def sequence(self, value: Any, where: str, length: int) -> list[Any]:
        if not isinstance(value, list | tuple) or len(value) != length:
            raise self.fail(where, f"must be a list of {length} values, got {short_repr(value)}")
        return list(value)

    def run(self) -> dict[str, Any]:
        data = self.data
        robot = self.mapping(data.pop("robot", None), "robot")
        vision = self.mapping(data.pop("vision", None), "vision")
        servo = self.mapping(data.pop("servo", None), "servo")
        task = self.mapping(data.pop("task", None), "task")
        out: dict[str, Any] = {"arm": self.arm(robot, servo)}
        for key in ("camera", "calibration"):
            if key in data:
                out[key] = data.pop(key)
        out["vision"], classes = self.vision(vision, task)
        if "controller" in data:
            out["controller"] = data.pop("controller")
        out["servo"] = self.servo(servo)
        out["task"] = self.task(task, classes)
        out.update(data)  # unknown top-level keys: left for validation to report
        return out

    # ----------------------------------------------------------------- arm

    def calibration(self, value: Any, where: str) -> dict[str, Any]:
        cal = self.mapping(value, where)
        if "us_per_deg" in cal:
            cal["us_per_unit"] = cal.pop("us_per_deg")
        return cal

    def arm(self, robot: dict[str, Any], servo: dict[str, Any]) -> dict[str, Any]:
        template = self.template
        chain = template.joints
        dh = robot.pop("dh", None)
        rows = (
            [j.dh.model_dump(mode="json") for j in chain]
            if dh is None
            else self.sequence(dh, "robot.dh", len(V1_JOINT_NAMES))
        )
        limits = self.mapping(robot.pop("joint_limits_deg", None), "robot.joint_limits_deg")
        home = robot.pop("home_deg", None)
        homes = (
            [j.home for j in chain if j.actuated]
            if home is None
            else self.sequence(home, "robot.home_deg", len(V1_ACTUATED))
        )
        servos = self.mapping(servo.pop("joints", None), "servo.joints")
        joints: list[dict[str, Any]] = []
        for i, name in enumerate(V1_ACTUATED):
            default = chain[i]
            assert default.limits is not None and default.servo is not None
            joints.append(
                {
                    "name": name,
                    "type": "revolute",
                    "dh": rows[i],
                    "limits": limits.pop(name, default.limits.model_dump(mode="json")),
                    "home": homes[i],
                    "servo": self.calibration(
                        servos.pop(name, default.servo.model_dump(mode="json")),
                        f"servo.joints.{name}",
                    ),
                }
            )
        joints.append(
            {
                "name": V1_JOINT_NAMES[3],
                "type": "revolute",
                "dh": rows[3],
                "coupling": {"terms": {V1_ACTUATED[1]: -1.0, V1_ACTUATED[2]: -1.0}},
            }
        )
        if limits:
            raise self.fail(
                "robot.joint_limits_deg",
                f"unknown joints {sorted(limits)}; format 1 has {list(V1_ACTUATED)}",
            )
        tool = self.tool(
            self.mapping(robot.pop("gripper", None), "robot.gripper"),
            servos.pop(_V1_TOOL_SERVO, None),
            self.mapping(servo.pop("gripper", None), "servo.gripper"),
        )
        if servos:
            known = [*V1_ACTUATED, _V1_TOOL_SERVO]
            raise self.fail("servo.joints", f"unknown joints {sorted(servos)}; known: {known}")
        arm: dict[str, Any] = {
            "name": template.name,
            "joints": joints,
            "tool": tool,
            "target_box": robot.pop("target_box", template.target_box.model_dump(mode="json")),
            "closed_form": template.closed_form,
        }
        if robot:
            raise self.fail("robot", f"unknown keys {sorted(robot)}")
        return arm

    def tool(
        self, gripper: dict[str, Any], arm_servo: Any, pulses: dict[str, Any]
    ) -> dict[str, Any]:
        template = self.template.tool
        default_arm = template.actuators[0]
        gripper.pop("a4_cm", None)
        gripper.pop("a5_cm", None)
        pick_cm = gripper.pop("pick_height_cm", _V1_PICK_HEIGHT_CM)
        grip_cm = _V1_GRIP_HEIGHT_CM
        actuator = {
            "name": default_arm.name,
            "servo": self.calibration(
                default_arm.servo.model_dump(mode="json") if arm_servo is None else arm_servo,
                f"servo.joints.{_V1_TOOL_SERVO}",
            ),
            "limits": gripper.pop(
                "gripper_arm_limits_deg", default_arm.limits.model_dump(mode="json")
            ),
            "home": gripper.pop("home_angle_deg", default_arm.home),
            "travel": gripper.pop("travel_angle_deg", default_arm.travel),
            "grip": gripper.pop("grip_angle_deg", default_arm.grip),
        }
        if gripper:
            raise self.fail("robot.gripper", f"unknown keys {sorted(gripper)}")
        out = template.model_dump(mode="json")
        out["gripper"]["servo"] = self.gripper_calibration(
            pulses, template.gripper.open_cm, template.gripper.closed_cm
        )
        out["actuators"] = [actuator]
        out["tcp_above_grip_cm"] = pick_cm - grip_cm if _is_number(pick_cm) else pick_cm
        return out

    def gripper_calibration(
        self, pulses: dict[str, Any], open_cm: float, closed_cm: float
    ) -> dict[str, Any]:
        r"""The calibration of the opening that gives format 1's two pulses exactly.

        .. math:: p(v) = p_0 + s\,k\,v, \quad p(\text{open}) = p_o,\ p(\text{closed}) = p_c

        so :math:`k = |p_c - p_o| / (\text{open} - \text{closed})`, :math:`s` the sign
        of :math:`p_o - p_c` and :math:`p_0 = p_o - s\,k\,\text{open}`.
        """
        given = {**_V1_GRIPPER, **pulses}
        unknown = sorted(set(given) - set(_V1_GRIPPER))
        if unknown:
            raise self.fail("servo.gripper", f"unknown keys {unknown}")
        channel, open_us, closed_us = given["channel"], given["open_us"], given["closed_us"]
        for key, value in (("open_us", open_us), ("closed_us", closed_us)):
            if not _is_number(value):
                raise self.fail(
                    f"servo.gripper.{key}", f"must be a number, got {short_repr(value)}"
                )
        if open_us == closed_us:
            raise self.fail(
                "servo.gripper",
                f"open_us and closed_us are both {open_us} µs: a gripper that does not move "
                "has no calibration",
            )
        direction = 1 if open_us > closed_us else -1
        us_per_cm = abs(open_us - closed_us) / (open_cm - closed_cm)
        return {
            "channel": channel,
            "zero_us": open_us - direction * us_per_cm * open_cm,
            "direction": direction,
            "us_per_unit": us_per_cm,
            "min_us": int(min(600, open_us, closed_us)),
            "max_us": int(max(2400, open_us, closed_us)),
        }

    # ----------------------------------------------------------------- vision, servo, task

    def vision(
        self, vision: dict[str, Any], task: dict[str, Any]
    ) -> tuple[dict[str, Any], list[dict[str, Any]]]:
        preset = vision.pop("preset", None)
        preset = "default" if preset is None else preset
        if not isinstance(preset, str) or preset not in _V1_PRESET_FLOORS:
            raise self.fail(
                "vision.preset", f"{short_repr(preset)} is not a format-1 preset (default, paper)"
            )
        bands = self.mapping(vision.pop("bands", None), "vision.bands")
        diameter_cm = vision.pop("object_diameter_cm", None)
        if diameter_cm is None:
            diameter_cm = _V1_OBJECT_DIAMETER_CM
        for key, floor in zip(
            ("saturation_min", "value_min"), _V1_PRESET_FLOORS[preset], strict=True
        ):
            if vision.get(key) is None:
                vision[key] = floor
        classes = self.classes(task, preset, bands, diameter_cm)
        return vision, classes

    def classes(
        self, task: dict[str, Any], preset: str, bands: dict[str, Any], diameter_cm: Any
    ) -> list[dict[str, Any]]:
        defaults = {c.name: c for c in default_classes()}
        order = task.pop("color_order", None)
        order = list(PAPER_CLASS_NAMES) if order is None else order
        if not isinstance(order, list | tuple) or not order:
            raise self.fail(
                "task.color_order", f"must be a non-empty list, got {short_repr(order)}"
            )
        bins = task.pop("bins_cm", None)
        bins = (
            {c.name: list(c.bin_cm) for c in defaults.values()}
            if bins is None
            else self.mapping(bins, "task.bins_cm")
        )
        out = []
        for name in order:
            if name not in bins:
                raise self.fail("task.bins_cm", f"has no bin for {short_repr(name)}")
            out.append(
                {
                    "name": name,
                    "hue_bands_deg": self.hue_bands(name, preset, bands, defaults),
                    "draw_rgb": list(defaults[name].draw_rgb) if name in defaults else _GREY_RGB,
                    "bin_cm": bins[name],
                    "diameter_cm": diameter_cm,
                    "grip_height_cm": _V1_GRIP_HEIGHT_CM,
                }
            )
        return out

    def hue_bands(
        self, name: str, preset: str, bands: dict[str, Any], defaults: dict[str, Any]
    ) -> Any:
        if name in bands:
            return bands[name]
        if preset == "paper" and name in PAPER_HUE_BANDS_DEG:
            return [{"lo_deg": lo, "hi_deg": hi} for lo, hi in PAPER_HUE_BANDS_DEG[name]]
        if preset == "default" and name in defaults:
            return [b.model_dump(mode="json") for b in defaults[name].hue_bands_deg]
        raise self.fail(
            "vision.bands", f"the {short_repr(preset)} preset has no bands for {short_repr(name)}"
        )

    def servo(self, servo: dict[str, Any]) -> dict[str, Any]:
        if "error_model" in servo:
            model = self.mapping(servo["error_model"], "servo.error_model")
            offsets = model.get("offset_deg")
            if isinstance(offsets, list | tuple):
                values = self.sequence(offsets, "servo.error_model.offset_deg", len(V1_ACTUATED))
                model["offset_deg"] = dict(zip(V1_ACTUATED, values, strict=True))
            servo["error_model"] = model
        return servo

    def task(self, task: dict[str, Any], classes: list[dict[str, Any]]) -> dict[str, Any]:
        names = {c["name"] for c in classes}
        scene = task.pop("scene", None)
        if scene is None:
            scene = [{"color": c, "x": x, "y": y} for c, x, y in PAPER_LAYOUT]
        elif not isinstance(scene, list):
            raise self.fail("task.scene", f"must be a list, got {type(scene).__name__}")
        kept = [
            o
            for o in scene
            if not isinstance(o, Mapping) or "color" not in o or o["color"] in names
        ]
        return {"classes": classes, **task, "scene": kept}


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)
