"""The strict base model every scene-format model derives from, and the value types they share."""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, StringConstraints
from pydantic_core import PydanticCustomError

from .blackbody import MAX_KELVIN, MIN_KELVIN

# Upper bounds that keep a hostile or mistyped file from asking for absurd work.
MAX_IMAGE_SIDE = 32768
MAX_SAMPLES = 1_000_000
MAX_DEPTH = 10_000

# Every number of a scene is 0 or has a magnitude in [MIN_MAGNITUDE, MAX_MAGNITUDE]. Float64 reaches
# 1e308 and 1e-308, but the renderer squares lengths, multiplies three of them (a determinant, a
# cross product's length against a point) and chains up to 16 levels of instance transforms: with
# 50 orders of magnitude on either side of 1, none of that overflows or underflows to 0. No
# physical scene needs more than 1e50 between its largest and its smallest length.
MAX_MAGNITUDE = 1e50
MIN_MAGNITUDE = 1e-50


class StrictModel(BaseModel):
    """Base of all scene models: unknown keys are errors, numbers must be finite."""

    model_config = ConfigDict(
        extra="forbid",
        allow_inf_nan=False,
        validate_default=False,
        frozen=True,
        use_attribute_docstrings=False,
    )


def field_error(field: str, message: str) -> PydanticCustomError:
    """An error from a rule over several fields, to be reported at `field`."""
    return PydanticCustomError("field_rule", message, {"field": field})


def _require_triple(value: Any) -> Any:
    # Give one clear message for a wrong-length vector instead of per-index noise.
    if not isinstance(value, (list, tuple)):
        shown = "a mapping" if isinstance(value, dict) else repr(value)
        raise ValueError(f"expected a list of 3 numbers [x, y, z], found {shown}")
    if isinstance(value, (list, tuple)):
        if len(value) != 3:
            raise ValueError(f"expected a list of 3 numbers, found {len(value)} items")
        for item in value:
            if isinstance(item, bool) or not isinstance(item, (int, float)):
                raise ValueError(f"expected a list of 3 numbers, found {item!r} in it")
            if not math.isfinite(item):
                raise ValueError(f"expected finite numbers, found {item!r}")
    return value


def moderate(value: float) -> float:
    """`value` if it is 0 or of a magnitude in [MIN_MAGNITUDE, MAX_MAGNITUDE]; an error otherwise."""
    if value != 0 and not MIN_MAGNITUDE <= abs(value) <= MAX_MAGNITUDE:
        raise PydanticCustomError(
            "magnitude",
            "expected 0 or a number of magnitude between {low} and {high}",
            {"low": f"{MIN_MAGNITUDE:g}", "high": f"{MAX_MAGNITUDE:g}"},
        )
    return value


Number = Annotated[float, Field(strict=True, allow_inf_nan=False), AfterValidator(moderate)]
"""A finite real number, 0 or of magnitude 1e-50 to 1e50; integers are accepted, strings and booleans are not."""

Vec3 = Annotated[tuple[Number, Number, Number], BeforeValidator(_require_triple)]
"""A point or direction `[x, y, z]`."""

Component = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0), AfterValidator(moderate)]

Color = Annotated[tuple[Component, Component, Component], BeforeValidator(_require_triple)]
"""A linear RGB colour `[r, g, b]`, each component >= 0; emitters may exceed 1."""

Kelvin = Annotated[float, Field(strict=True, allow_inf_nan=False, ge=MIN_KELVIN, le=MAX_KELVIN)]
"""A colour temperature in kelvin, within the range scenefmt.blackbody gives colours for."""

Name = Annotated[
    str,
    StringConstraints(strict=True, pattern=r"^[A-Za-z_][A-Za-z0-9_.\-]*$", min_length=1, max_length=64),
]
"""The name of a definition: a letter or underscore, then letters, digits, `_`, `.` or `-`."""


def vec_length(v: tuple[float, float, float]) -> float:
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


def vec_cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def vec_sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def slot_kind(value: Any) -> str | None:
    """Tell a reference slot's three spellings apart: a name, a colour triple, or an inline definition.

    Used as a pydantic callable discriminator so that an error points at the one
    spelling the user meant instead of listing a failure for each alternative.
    """
    if isinstance(value, str):
        return "name"
    if isinstance(value, (list, tuple)):
        return "color"
    if isinstance(value, (dict, BaseModel)):
        return "inline"
    return None
