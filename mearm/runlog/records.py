"""The run-log records: one pydantic model per line type, and :func:`parse_record`.

The format is described in :mod:`mearm.runlog`; format-1 lines are converted to these
models by :mod:`mearm.runlog.format1`.
"""

from __future__ import annotations

import functools
import json
import math
from collections.abc import Callable, Mapping
from datetime import datetime
from importlib import metadata
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from mearm.config import Config
from mearm.config.base import MAX_ANGLE_DEG, MAX_LENGTH_CM
from mearm.runlog.format1 import upgrade_v1_record

#: The format this mearm writes.
FORMAT_VERSION = 2
#: The formats it reads; older ones are converted to the current records on reading.
READABLE_FORMATS: tuple[int, ...] = (1, 2)

#: Distributions whose versions go into every header (key → PyPI name).
VERSIONED_PACKAGES: dict[str, str] = {
    "numpy": "numpy",
    "pinocchio": "pin",
    "mink": "mink",
    "mujoco": "mujoco",
    "opencv": "opencv-python-headless",
    "pydantic": "pydantic",
    "pyserial": "pyserial",
    "scipy": "scipy",
    "matplotlib": "matplotlib",
}

#: Largest magnitude of a length in a record [cm]: ten times the config's physical range
#: (a position, an error between two positions, an error's norm all fit well inside).
#: Past it a value is not a measurement (1e308 cm overflows the analysis' squares).
MAX_RECORD_CM = 10 * MAX_LENGTH_CM
#: Largest magnitude of a joint value [deg or cm]: a turn is 360°, a slide at most
#: the physical range.
MAX_RECORD_JOINT = max(MAX_ANGLE_DEG, MAX_LENGTH_CM)
#: Longest time in a record [s] (about 11.6 days).
MAX_RECORD_S = 1e6
#: Largest count in a record (iterations, attempts, objects, routes).
MAX_RECORD_COUNT = 10**9
#: Longest reason a route gives for its failure, one line [characters] (mearm's are < 100).
MAX_WHY_CHARS = 1000

_Cm = Annotated[float, Field(ge=-MAX_RECORD_CM, le=MAX_RECORD_CM, allow_inf_nan=False)]
_NonNegativeCm = Annotated[float, Field(ge=0, le=MAX_RECORD_CM, allow_inf_nan=False)]
_Seconds = Annotated[float, Field(ge=0, le=MAX_RECORD_S, allow_inf_nan=False)]
_JointValue = Annotated[
    float, Field(ge=-MAX_RECORD_JOINT, le=MAX_RECORD_JOINT, allow_inf_nan=False)
]
_Count = Annotated[int, Field(ge=0, le=MAX_RECORD_COUNT)]
_Name = Annotated[str, Field(min_length=1)]
Vec3 = tuple[_Cm, _Cm, _Cm]
#: Joint values by joint name, in chain order: deg for a revolute joint, cm for a
#: prismatic one.
JointValues = dict[_Name, _JointValue]
_Joints = Annotated[JointValues, Field(min_length=1)]

#: Largest allowed |error_cm − (ee_cm − target_cm)| on any axis [cm].
ERROR_CONSISTENCY_CM = 1e-6


class _Record(BaseModel):
    # strict: a string is not an int, 1 is not true, 1.0 is not an iteration count.
    # extra="allow": a later writer may add fields; readers keep them.
    model_config = ConfigDict(extra="allow", frozen=True, strict=True)


class HeaderRecord(_Record):
    """Starts a trial: how it was configured, with what software, and its seed."""

    type: Literal["header"] = "header"
    format: int
    """The format the trial was written in (:data:`READABLE_FORMATS`); its records are
    read into the current models whatever it is."""
    mearm_version: str
    started: str
    """Wall-clock start, ISO 8601 with the UTC offset."""
    config: dict[str, Any]
    """``Config.model_dump(mode="json")`` (a format-1 header's, migrated to the current
    layout on reading); :meth:`load_config` turns it back."""
    versions: dict[str, str | None]
    trial: int | None
    seed: int | None

    @field_validator("format")
    @classmethod
    def _readable(cls, value: int) -> int:
        if value not in READABLE_FORMATS:
            raise ValueError(
                f"format {value} is not supported (this mearm reads formats "
                f"{', '.join(map(str, READABLE_FORMATS))})"
            )
        return value

    @field_validator("started")
    @classmethod
    def _iso(cls, value: str) -> str:
        try:
            datetime.fromisoformat(value)
        except ValueError:
            raise ValueError(f"not an ISO 8601 time: {value!r}") from None
        return value

    def load_config(self) -> Config:
        """The trial's configuration as a :class:`~mearm.config.Config`.

        Raises:
            ConfigError: The stored config does not validate with this version of mearm.
        """
        from mearm.config import config_from_dict

        return config_from_dict(self.config, source="run-log header")


class RouteRecord(_Record):
    """One route of the arm to a pick or place point (paper §1 steps 4–5).

    ``final_error_cm`` is the solver's, on ideal kinematics; ``ee_cm`` is where the arm
    really ended (for the simulated arm, the FK of its quantised / noisy joints) and
    ``error_cm = ee_cm − target_cm`` the error the paper's Table 8 measures.
    """

    type: Literal["route"] = "route"
    trial: int | None
    object_id: str = Field(min_length=1)
    color: str = Field(min_length=1)
    """The object's colour class (a name of ``task.classes``)."""
    step: Literal["pick", "place"]
    attempt: int = Field(ge=1, le=MAX_RECORD_COUNT)
    """1 for the first attempt at this object's pick (or place)."""
    target_cm: Vec3
    start_joints: _Joints
    """Every joint of the chain at the start of the route, by name [deg or cm]."""
    end_joints: _Joints
    """Every joint of the chain as commanded at the end of the route, by name [deg or cm]."""
    iterations: _Count
    status: str
    method: Literal["direct", "closed_form", "multi_start", "joint_move"] | None = None
    """How the plan got there: PD-PIJ alone, or its stall recovered by a path to the
    closed-form or a multi-start solution (``None`` in logs written before it existed)."""
    initial_error_cm: _NonNegativeCm
    final_error_cm: _NonNegativeCm
    ee_cm: Vec3
    error_cm: Vec3
    grip_ee_cm: Vec3 | None = None
    """A pick's TCP when the jaws start to close, the arm settled [cm] (``ee_cm`` is on
    arrival); ``None`` on a place, where not measured, or in logs written before it."""
    success: bool
    """Pick: the object was gripped. Place: it landed in its bin."""
    confirmed: bool = True
    """Whether ``success`` was found out: a fault (a link lost, Ctrl-C) before the check
    leaves the route unconfirmed, ``success`` false but no failure, and the analysis
    counts it in no success rate (``true`` in logs written before it)."""
    why_failed: str | None = Field(default=None, max_length=MAX_WHY_CHARS, pattern=r"^[^\r\n]*$")
    """Why a route that ran and was checked did not do its job, one line (a pick: the
    object still where the jaws closed; a place: nothing of its class brought to the bin,
    or where a simulator saw it land); ``None`` when it did, was not checked, or in logs
    written before it."""
    note: str | None = Field(default=None, max_length=MAX_WHY_CHARS, pattern=r"^[^\r\n]*$")
    """What a route that did its job did out of the ordinary, one line (a place whose
    object slipped out of the jaws on the way into its own bin, counted sorted); ``None``
    otherwise and in logs written before it."""
    elapsed_s: _Seconds
    motion_s: _Seconds

    @model_validator(mode="after")
    def _error_is_ee_minus_target(self) -> RouteRecord:
        expected = np.subtract(self.ee_cm, self.target_cm)
        worst = float(np.max(np.abs(np.subtract(self.error_cm, expected))))
        if worst > ERROR_CONSISTENCY_CM:
            raise ValueError(
                f"error_cm {list(self.error_cm)} is not ee_cm − target_cm "
                f"{[round(v, 9) for v in expected.tolist()]} (off by {worst:.3g} cm)"
            )
        return self

    @property
    def error_norm_cm(self) -> float:
        """Euclidean xyz error |ee − target| [cm]."""
        return math.hypot(*self.error_cm)


class SkipRecord(_Record):
    """An object that was not sorted: unreachable, outside the box, retries exhausted."""

    type: Literal["skip"] = "skip"
    trial: int | None
    object_id: str = Field(min_length=1)
    color: str = Field(min_length=1)
    """The object's colour class (a name of ``task.classes``)."""
    target_cm: Vec3 | None
    reason: str


class FaultRecord(_Record):
    """A camera or servo failure, or Ctrl-C: the run stopped here."""

    type: Literal["fault"] = "fault"
    trial: int | None = None
    reason: str
    last_joints: _Joints | None
    """Every joint of the chain at the last confirmed pose, by name [deg or cm], or
    ``None`` when the arm never reported one."""


class SummaryRecord(_Record):
    """Closes a trial: what it sorted and how its routes went."""

    type: Literal["summary"] = "summary"
    trial: int | None
    sorted: dict[_Name, _Count]
    """Objects placed in their bin, per colour class (by name)."""
    objects: dict[_Name, _Count] | None = None
    """Objects seen on the table, per class (``None`` in logs written before it existed)."""
    left: dict[str, _Count] | None = None
    """Objects not sorted, per reason (``out_of_reach``, ``pick_failed``, ``fault``, …)."""
    failures: _Count
    skipped: _Count
    routes: _Count
    mean_iterations: Annotated[float, Field(ge=0, le=MAX_RECORD_COUNT, allow_inf_nan=False)] | None
    mean_final_error_cm: _NonNegativeCm | None
    motion_s: _Seconds
    ok: bool
    twin_faults: list[dict[_Name, Any]] | None = None
    """The physical twin's injected faults that struck during the trial (simulated), each
    as ``twin.faults`` gives it (``{"kind": "limp_servo", "at_s": 4.0, "joint": "elbow"}``),
    whether the sort stopped on it or never noticed it (``ok`` then stays true: the run
    ran its course); ``None`` when none struck, on a real rig and in logs written before
    it existed."""


Record = HeaderRecord | RouteRecord | SkipRecord | FaultRecord | SummaryRecord

RECORD_TYPES: dict[str, type[_Record]] = {
    "header": HeaderRecord,
    "route": RouteRecord,
    "skip": SkipRecord,
    "fault": FaultRecord,
    "summary": SummaryRecord,
}


def library_versions() -> dict[str, str | None]:
    """Python's and the main libraries' versions (``None`` for one not installed)."""
    return dict(_library_versions())


@functools.cache
def _library_versions() -> dict[str, str | None]:
    # Reading package metadata costs ~7 ms a package; a run's versions do not change.
    import platform

    versions: dict[str, str | None] = {"python": platform.python_version()}
    for key, dist in VERSIONED_PACKAGES.items():
        try:
            versions[key] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[key] = None
    return versions


def mearm_version() -> str:
    """The installed mearm version (``"unknown"`` when run from an uninstalled tree)."""
    try:
        return metadata.version("mearm")
    except metadata.PackageNotFoundError:
        return "unknown"


def _describe(err: Mapping[str, Any]) -> str:
    loc = ".".join(str(p) for p in err["loc"])
    if err["type"] == "missing":
        return f"field '{loc}' is missing"
    msg = str(err["msg"])
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    if not loc:
        return msg
    return f"field '{loc}': {msg} (got {err.get('input')!r})"


#: Per older format, the conversion of one line's mapping to the current format.
_UPGRADES: dict[int, Callable[[dict[str, Any]], dict[str, Any]]] = {1: upgrade_v1_record}


def _validation_reason(kind: str, exc: ValidationError, fmt: int = FORMAT_VERSION) -> str:
    problems = [_describe(e) for e in exc.errors()]
    more = f" (+{len(problems) - 1} more)" if len(problems) > 1 else ""
    return f"{_label(kind, fmt)}: {problems[0]}{more}"


def _label(kind: str, fmt: int) -> str:
    if fmt == FORMAT_VERSION:
        return f"{kind} record"
    return f"{kind} record (format {fmt}, read as format {FORMAT_VERSION})"


def parse_record(text: str, *, trial_format: int | None = FORMAT_VERSION) -> Record:
    """One line of a run log → its record, in the current format.

    A line's format is its trial's: a header declares it (``format``) and the records
    after it follow it. A format-1 line is converted by
    :func:`~mearm.runlog.format1.upgrade_v1_record` before it is validated.

    Args:
        text: The line, without its newline.
        trial_format: The ``format`` of the header the line follows; ``None`` when no
            header came before it, which only a header may do. A header line ignores it.

    Raises:
        ValueError: The line is not a valid record; the message says why.
    """
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"not valid JSON ({exc.msg}: column {exc.colno})") from None
    except RecursionError:
        raise ValueError("not a record: JSON nested too deeply") from None
    except ValueError:  # an integer of more digits than Python converts
        raise ValueError("not valid JSON (a number too long to read)") from None
    if not isinstance(obj, dict):
        raise ValueError(f"a record must be a JSON object, got {type(obj).__name__}")
    kind = obj.get("type")
    if kind not in RECORD_TYPES:
        raise ValueError(f"unknown record type {kind!r}; known: {sorted(RECORD_TYPES)}")
    if kind == "header":
        fmt = obj.get("format")
        if type(fmt) is not int or fmt not in READABLE_FORMATS:
            raise ValueError(
                f"header format {fmt!r} is not supported (this mearm reads formats "
                f"{', '.join(map(str, READABLE_FORMATS))})"
            )
    elif trial_format is None:
        raise ValueError(f"{kind} record before any header")
    else:
        fmt = trial_format
    if fmt != FORMAT_VERSION:
        try:
            text = json.dumps(_UPGRADES[fmt](obj))
        except ValueError as exc:
            raise ValueError(f"{_label(kind, fmt)}: {exc}") from None
    try:
        return RECORD_TYPES[kind].model_validate_json(text)  # type: ignore[return-value]
    except ValidationError as exc:
        raise ValueError(_validation_reason(kind, exc, fmt)) from None
