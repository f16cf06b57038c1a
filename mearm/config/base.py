"""Building blocks shared by every config section: strict models, bounded numbers, ranges.

Every number a config holds is finite and bounded by physical sense (a hobby arm on a
table), so that nothing the validator accepts can overflow, hang or exhaust memory later.
"""

from __future__ import annotations

import reprlib
from typing import TYPE_CHECKING, Annotated, Any

from pydantic import BaseModel, ConfigDict, Field, GetCoreSchemaHandler, model_validator
from pydantic_core import PydanticCustomError, core_schema

if TYPE_CHECKING:
    from pydantic_core import ErrorDetails

Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
#: A name used as a key (joint, actuator, colour class): letters, digits, ``_`` and ``-``.
Name = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_-]{0,39}$")]

#: Largest length, position or distance anywhere in a config [cm]: 10 m, far beyond any
#: hobby arm, table or bin.
MAX_LENGTH_CM = 1000.0
#: Largest angle [deg]: one turn either way (DH offsets and twists, revolute limits).
MAX_ANGLE_DEG = 360.0
#: Seeds are unsigned 32-bit integers (NumPy takes them; run logs store them as JSON).
MAX_SEED = 2**32 - 1
#: Longest path or port name [characters] (Linux's PATH_MAX).
MAX_PATH_CHARS = 4096

#: A length, position or offset [cm], within ±:data:`MAX_LENGTH_CM`.
Length = Annotated[float, Field(ge=-MAX_LENGTH_CM, le=MAX_LENGTH_CM, allow_inf_nan=False)]
#: A positive length [cm], at most :data:`MAX_LENGTH_CM`.
PositiveLength = Annotated[float, Field(gt=0, le=MAX_LENGTH_CM, allow_inf_nan=False)]
#: A length ≥ 0 [cm], at most :data:`MAX_LENGTH_CM`.
NonNegativeLength = Annotated[float, Field(ge=0, le=MAX_LENGTH_CM, allow_inf_nan=False)]
#: An angle [deg], within ±:data:`MAX_ANGLE_DEG`.
Angle = Annotated[float, Field(ge=-MAX_ANGLE_DEG, le=MAX_ANGLE_DEG, allow_inf_nan=False)]
#: A random seed, 0 … 2³² − 1.
Seed = Annotated[int, Field(ge=0, le=MAX_SEED)]
#: A file or device path: no NUL byte, at most :data:`MAX_PATH_CHARS` characters.
PathText = Annotated[str, Field(min_length=1, max_length=MAX_PATH_CHARS, pattern=r"^[^\x00]*$")]
#: A point or direction [cm], each coordinate a :data:`Length`.
Vector3 = tuple[Length, Length, Length]


#: A field's ``json_schema_extra`` key listing the words it takes besides its type's
#: values (its validator turns them into one), for the reference's type column.
SPELLINGS = "mearm_spellings"
#: A field's ``json_schema_extra`` key listing what its validator enforces beyond the
#: bounds its type carries (``odd``), for the reference's allowed values.
RULES = "mearm_rules"
#: The error type of a boolean given for a number (:func:`_refuse_bool`).
NOT_A_NUMBER = "number_not_bool"


def _refuse_bool(value: Any) -> Any:
    """``value``, unless it is a boolean: pydantic's lax mode would read ``true`` as 1."""
    if value is True or value is False:
        got = "true" if value else "false"
        raise PydanticCustomError(NOT_A_NUMBER, "expected a number, got {got}", {"got": got})
    return value


#: The keys of a core schema that hold the schemas it validates with.
_INNER = ("schema", "items_schema", "keys_schema", "values_schema", "lax_schema",
          "strict_schema", "json_schema", "python_schema")  # fmt: skip


def _numbers_refuse_bool(node: Any, model: type) -> Any:
    """``node`` (a core schema) with every int and float schema refusing a boolean.

    Only the lax number schemas change (strict ones would also refuse ``"1e3"``, which
    YAML 1.1 reads as a string), and only ``model``'s own: a nested model's schema is
    its own class's, changed when that class was built. Wrapped schemas are left alone,
    so a schema seen again is not wrapped twice.
    """
    if not isinstance(node, dict):
        return node
    kind = node.get("type")
    if kind in ("int", "float") or (
        kind == "literal" and all(type(v) in (int, float) for v in node["expected"])
    ):  # a literal of numbers (``direction: 1``) takes ``true`` too, as ``true == 1``
        return core_schema.no_info_before_validator_function(_refuse_bool, node)
    if kind == "model" and node.get("cls") is not model:
        return node
    if kind == "function-before" and node["function"].get("function") is _refuse_bool:
        return node
    for key in _INNER:
        if key in node:
            node[key] = _numbers_refuse_bool(node[key], model)
    if kind == "model-fields":
        for field in node["fields"].values():
            field["schema"] = _numbers_refuse_bool(field["schema"], model)
    elif kind in ("tuple", "chain"):
        key = "items_schema" if kind == "tuple" else "steps"
        node[key] = [_numbers_refuse_bool(item, model) for item in node[key]]
    elif kind == "union":
        node["choices"] = [
            (_numbers_refuse_bool(c[0], model), c[1])
            if isinstance(c, tuple)
            else _numbers_refuse_bool(c, model)
            for c in node["choices"]
        ]
    elif kind == "tagged-union":
        node["choices"] = {k: _numbers_refuse_bool(v, model) for k, v in node["choices"].items()}
    elif kind == "definitions":
        node["definitions"] = [_numbers_refuse_bool(d, model) for d in node["definitions"]]
    return node


class Strict(BaseModel):
    """A frozen model that refuses unknown keys, and booleans where it takes numbers.

    Pydantic's lax mode reads ``true`` as 1 and ``false`` as 0; a boolean given for a
    number is a mistake (``kp: yes``), refused with the field's name. The check is built
    into the validator once per class (:func:`_numbers_refuse_bool`), not run per field
    in Python.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    @classmethod
    def __get_pydantic_core_schema__(
        cls, source: type[BaseModel], handler: GetCoreSchemaHandler, /
    ) -> core_schema.CoreSchema:
        # called once as the class is built; handler(source) is how pydantic asks it be done
        return _numbers_refuse_bool(handler(source), cls)


class Range(Strict):
    """A closed interval [min, max] with min < max, each within ±:data:`MAX_LENGTH_CM`."""

    min: Length
    max: Length

    @model_validator(mode="after")
    def _ordered(self) -> Range:
        if not self.min < self.max:
            raise ValueError(f"min ({self.min:g}) must be below max ({self.max:g})")
        return self

    def contains(self, value: float, tol: float = 0.0) -> bool:
        """Whether ``min - tol <= value <= max + tol``."""
        return self.min - tol <= value <= self.max + tol


_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxdict, _SHORT.maxlist, _SHORT.maxtuple = 2, 4, 4, 4
_SHORT.maxstring, _SHORT.maxother, _SHORT.maxlong = 60, 60, 40


def short_repr(value: object, limit: int = 80) -> str:
    """A repr of ``value`` of at most ``limit`` characters, cheap for any value.

    Containers are shown to two levels and four items, so a huge or alias-expanded
    value is never rendered in full; an integer too long to print is summarised.
    """
    try:
        text = _SHORT.repr(value)
    except (ValueError, RecursionError):  # an int past Python's 4300-digit str limit
        text = f"<{type(value).__name__}>"
    text = text.replace("\n", " ")
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _loc_part(part: object) -> str:
    text = str(part)
    return text if text.isprintable() and len(text) <= 40 else short_repr(text, 40)


def loc_text(loc: tuple[int | str, ...]) -> str:
    """A pydantic error location as a dotted path.

    A key that is long or holds characters that would break the line is shown by its
    (cut) repr.
    """
    return ".".join(_loc_part(p) for p in loc)


def _shown(value: object) -> str:
    if isinstance(value, (dict, list, tuple)):
        return ""
    return f" (got {short_repr(value, 60)})"


def example_file(arm: str | None = None) -> str:
    """The shipped file that shows every key, as the user can open it.

    ``sim.yaml`` (every section), or with ``arm`` the reference arm's file: in the
    checkout under ``configs/``, from the wheel the copy it ships
    (:func:`mearm.data.shown_path`).
    """
    from mearm.data import ARMS_DIR, CONFIGS_DIR, shown_path  # noqa: PLC0415  (errors only)

    return shown_path(CONFIGS_DIR / "sim.yaml" if arm is None else ARMS_DIR / f"{arm}.yaml")


def describe_error(err: ErrorDetails) -> str:
    """One line for one pydantic error: the dotted path, what is wrong, the value given."""
    loc = loc_text(err["loc"]) or "(top level)"
    kind = err["type"]
    if kind == "extra_forbidden":
        where = example_file("mearm_paper" if loc.startswith("arm.") else None)
        return f"{loc}: unknown key (check the spelling; {where} shows every key)"
    if kind == "missing":
        return f"{loc}: required but missing"
    if kind == NOT_A_NUMBER:
        return f"{loc}: {err['msg']}"
    msg = err["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    if msg.startswith("@"):  # a model validator naming the field inside the model
        sub, _, msg = msg[1:].partition(": ")
        loc = f"{loc}.{sub}" if err["loc"] else sub
        return f"{loc}: {msg}"
    return f"{loc}: {msg}{_shown(err.get('input'))}"
