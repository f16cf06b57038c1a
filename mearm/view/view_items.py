"""The records of what the view draws, and their checks at the view's boundary.

Objects on the table (:class:`ViewObject`, the detections) and the physical twin's
bodies (:class:`TwinBody`) arrive as records or plain tuples; each is checked here
(id, class, finite position, unit quaternion) before anything is drawn.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from mearm.config import ColorClass
from mearm.view.errors import ViewInputError

#: Route lines without a colour of their own.
PATH_RGB = 0x202020

_HEX = re.compile(r"^#?([0-9a-fA-F]{6})$")


@dataclass(frozen=True)
class ViewObject:
    """An object as drawn: its id, colour class and table position [cm]."""

    id: str
    class_name: str
    x_cm: float
    y_cm: float


@dataclass(frozen=True)
class HeldObject:
    """An object drawn in the jaws: its colour class and pose, a 4 × 4 [m] flattened."""

    class_name: str
    pose: tuple[float, ...]


@dataclass(frozen=True)
class TwinBody:
    """An object of the physical twin as drawn: its id, colour class and pose.

    Attributes:
        id: The object's id (``red1``, …).
        class_name: Its colour class.
        position_cm: Its body's centre in the base frame [cm], (x, y, z).
        quat: Its orientation (w, x, y, z), unit [-]; the cylinder's axis is the body's z.
    """

    id: str
    class_name: str
    position_cm: tuple[float, float, float]
    quat: tuple[float, float, float, float]


def rgb_int(rgb: tuple[int, int, int]) -> int:
    """A class's ``draw_rgb`` (0–255 each) as 0xRRGGBB."""
    r, g, b = rgb
    return (int(r) << 16) | (int(g) << 8) | int(b)


def color_value(color: str | int | None, argument: str = "color") -> int:
    """A line colour, ``"#RRGGBB"`` or 0xRRGGBB, as an int; ``None``: :data:`PATH_RGB`."""
    if color is None:
        return PATH_RGB
    if isinstance(color, int) and not isinstance(color, bool) and 0 <= color <= 0xFFFFFF:
        return color
    if isinstance(color, str):
        match = _HEX.match(color)
        if match:
            return int(match.group(1), 16)
    raise ViewInputError(argument, color, "a hex string '#RRGGBB' or an int 0xRRGGBB")


def finite_array(value: npt.ArrayLike, argument: str, allowed: str) -> np.ndarray:
    """``value`` as a float array of finite numbers; else a ViewInputError naming ``allowed``."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ViewInputError(argument, value, allowed) from None
    if not np.all(np.isfinite(arr)):
        raise ViewInputError(argument, value, allowed)
    return arr


def view_object(item: Any, classes: dict[str, ColorClass]) -> ViewObject:
    """Validate one object to draw.

    It is a ``(id, class_name, x_cm, y_cm)`` tuple, or anything with an ``id``, a
    ``class_name`` (or ``color``), ``x_cm`` and ``y_cm``.
    """
    if isinstance(item, ViewObject):
        fields = (item.id, item.class_name, item.x_cm, item.y_cm)
    elif all(hasattr(item, a) for a in ("id", "x_cm", "y_cm")) and (
        hasattr(item, "class_name") or hasattr(item, "color")
    ):
        name = item.class_name if hasattr(item, "class_name") else item.color
        fields = (item.id, name, item.x_cm, item.y_cm)
    elif isinstance(item, (tuple, list)) and len(item) == 4:
        fields = tuple(item)
    else:
        raise ViewInputError("objects[...]", item, "(id, class_name, x_cm, y_cm)")
    obj_id, class_name, x, y = fields
    obj_id = _object_id(obj_id)
    if class_name not in classes:
        raise ViewInputError(
            f"class of {obj_id}", class_name, f"one of task.classes: {', '.join(classes)}"
        )
    xy = finite_array((x, y), f"position of {obj_id}", "finite x_cm, y_cm")
    return ViewObject(obj_id, class_name, float(xy[0]), float(xy[1]))


def _object_id(obj_id: Any) -> str:
    if not isinstance(obj_id, str) or not obj_id or "/" in obj_id:
        raise ViewInputError("object id", obj_id, "a non-empty string without '/'")
    return obj_id


def twin_body(item: Any, classes: dict[str, ColorClass]) -> TwinBody:
    """Validate one twin body to draw: ``(id, class_name, position_cm, quat)``."""
    allowed = "(id, class_name, position_cm (x, y, z), quat (w, x, y, z))"
    if isinstance(item, TwinBody):
        fields: tuple[Any, ...] = (item.id, item.class_name, item.position_cm, item.quat)
    elif isinstance(item, (tuple, list)) and len(item) == 4:
        fields = tuple(item)
    else:
        raise ViewInputError("objects[...]", item, allowed)
    obj_id = _object_id(fields[0])
    class_name = fields[1]
    if class_name not in classes:
        raise ViewInputError(
            f"class of {obj_id}", class_name, f"one of task.classes: {', '.join(classes)}"
        )
    pos = finite_array(fields[2], f"position of {obj_id}", "3 finite numbers [cm]")
    if pos.shape != (3,):
        raise ViewInputError(f"position of {obj_id}", fields[2], "3 finite numbers [cm]")
    quat = finite_array(fields[3], f"orientation of {obj_id}", "a quaternion (w, x, y, z)")
    norm = float(np.linalg.norm(quat)) if quat.shape == (4,) else 0.0
    if norm < 1e-9:
        raise ViewInputError(f"orientation of {obj_id}", fields[3], "a quaternion (w, x, y, z)")
    quat = quat / norm
    return TwinBody(
        obj_id,
        str(class_name),
        (float(pos[0]), float(pos[1]), float(pos[2])),
        (float(quat[0]), float(quat[1]), float(quat[2]), float(quat[3])),
    )
