"""Building blocks shared by every config section: strict models, bounded numbers, ranges."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import BaseModel, ConfigDict, Field, model_validator

if TYPE_CHECKING:
    from pydantic_core import ErrorDetails

Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
#: A name used as a key (joint, actuator, colour class): letters, digits, ``_`` and ``-``.
Name = Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_-]{0,39}$")]
Vector3 = tuple[Finite, Finite, Finite]


class Strict(BaseModel):
    """A frozen model that refuses unknown keys."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class Range(Strict):
    """A closed interval [min, max] with min < max."""

    min: Finite
    max: Finite

    @model_validator(mode="after")
    def _ordered(self) -> Range:
        if not self.min < self.max:
            raise ValueError(f"min ({self.min:g}) must be below max ({self.max:g})")
        return self

    def contains(self, value: float, tol: float = 0.0) -> bool:
        """Whether ``min - tol <= value <= max + tol``."""
        return self.min - tol <= value <= self.max + tol


def _shown(value: object) -> str:
    if isinstance(value, (dict, list, tuple)):
        return ""
    text = repr(value)
    return f" (got {text if len(text) <= 60 else text[:57] + '...'})"


def describe_error(err: ErrorDetails) -> str:
    """One line for one pydantic error: the dotted path, what is wrong, the value given."""
    loc = ".".join(str(p) for p in err["loc"]) or "(top level)"
    kind = err["type"]
    if kind == "extra_forbidden":
        return f"{loc}: unknown key (check the spelling; configs/sim.yaml shows every key)"
    if kind == "missing":
        return f"{loc}: required but missing"
    msg = err["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, ") :]
    if msg.startswith("@"):  # a model validator naming the field inside the model
        sub, _, msg = msg[1:].partition(": ")
        loc = f"{loc}.{sub}" if err["loc"] else sub
        return f"{loc}: {msg}"
    return f"{loc}: {msg}{_shown(err.get('input'))}"
