"""Transform steps. A `transform:` is an ordered list of steps applied first to last.

Each step is a one-key mapping whose key names its kind, so a list reads like the
sentence it stands for: `[{rotate: {axis: y, degrees: 15}}, {translate: [265, 0, 295]}]`
rotates, then moves.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Union

from pydantic import AfterValidator, BaseModel, BeforeValidator, Discriminator, Field, Tag, field_validator, model_validator

from .base import Number, StrictModel, Vec3, vec_length

STEP_KINDS = ("translate", "rotate", "scale", "matrix")


class Rotation(StrictModel):
    """A rotation by `degrees` about `axis`: counter-clockwise when seen from the tip of the axis
    looking back at the origin (right-handed).

    ```yaml
    axis: y
    degrees: 15
    ```
    """

    axis: Union[Literal["x", "y", "z"], Vec3] = Field(
        ...,
        description="`x`, `y`, `z`, or any non-zero vector [x, y, z] through the origin.",
        json_schema_extra={"not": {"const": [0, 0, 0]}},
    )
    degrees: Number = Field(..., description="Angle in degrees.")

    @field_validator("axis", mode="before")
    @classmethod
    def _known_axis(cls, axis: Any) -> Any:
        # One message for both spellings instead of one failure per union member.
        if isinstance(axis, str):
            if axis not in ("x", "y", "z"):
                raise ValueError(f"expected x, y, z or a vector [x, y, z], found {axis!r}")
        elif not isinstance(axis, (list, tuple)):
            raise ValueError(f"expected x, y, z or a vector [x, y, z], found {axis!r}")
        return axis

    @field_validator("axis")
    @classmethod
    def _axis_nonzero(cls, axis: Any) -> Any:
        if not isinstance(axis, str) and vec_length(axis) == 0.0:
            raise ValueError("a rotation axis must not be the zero vector")
        return axis


class TranslateStep(StrictModel):
    """Move by an offset.

    ```yaml
    translate: [265, 0, 295]
    ```
    """

    translate: Vec3 = Field(..., description="Offset added to every point.")


class RotateStep(StrictModel):
    """Rotate about an axis through the origin.

    ```yaml
    rotate: {axis: y, degrees: 15}
    ```
    """

    rotate: Rotation = Field(..., description="Axis and angle of the rotation.")


class ScaleStep(StrictModel):
    """Scale about the origin, uniformly (one number) or per axis ([x, y, z]); no factor may be 0.

    ```yaml
    scale: [1, 2, 1]
    ```
    """

    scale: Union[Number, Vec3] = Field(
        ...,
        description="One factor, or one per axis; negative factors mirror.",
        # `_no_zero_factor`, for the JSON Schema: not 0, and no 0 in the list.
        json_schema_extra={"not": {"anyOf": [{"const": 0}, {"type": "array", "contains": {"const": 0}}]}},
    )

    @field_validator("scale")
    @classmethod
    def _no_zero_factor(cls, scale: Any) -> Any:
        factors = (scale,) if isinstance(scale, (int, float)) else scale
        if any(f == 0 for f in factors):
            raise ValueError("a scale factor of 0 flattens the shape to nothing; use a non-zero factor")
        return scale


class MatrixStep(StrictModel):
    """Any affine map, as 3 rows [a, b, c, tx] (or 4 with a last row [0, 0, 0, 1]) acting on column vectors.

    ```yaml
    matrix: [[1, 0, 0, 0], [0, 1, 0, 2], [0, 0, 1, 0]]
    ```
    """

    matrix: list[Annotated[list[Number], Field(min_length=4, max_length=4)]] = Field(
        ..., min_length=3, max_length=4, description="Rows of the affine matrix, 3 or 4 rows of 4 numbers."
    )

    @model_validator(mode="after")
    def _affine_and_invertible(self) -> "MatrixStep":
        m = self.matrix
        if len(m) == 4 and list(m[3]) != [0, 0, 0, 1]:
            raise ValueError("the 4th row of an affine matrix must be [0, 0, 0, 1]")
        a = [row[:3] for row in m[:3]]
        det = (
            a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
        )
        scale = max(1e-300, max(abs(x) for row in a for x in row)) ** 3
        if not math.isfinite(det) or abs(det) <= 1e-12 * scale:
            raise ValueError("the matrix is singular (determinant 0): it would flatten the shape")
        return self


def step_kind(value: Any) -> str | None:
    """A step's kind is its one key; `None` (an error) when no known key is present."""
    if isinstance(value, BaseModel):
        for kind in STEP_KINDS:
            if kind in type(value).model_fields:
                return kind
        return None
    if isinstance(value, dict):
        for key in value:
            if key in STEP_KINDS:
                return key
    return None


def _one_key(value: Any) -> Any:
    if isinstance(value, dict) and len(value) > 1 and any(k in STEP_KINDS for k in value):
        raise ValueError(
            f"a transform step has exactly one key, found {len(value)}: {', '.join(map(str, value))}; "
            "write each step as its own list item"
        )
    return value


TransformStep = Annotated[
    Union[
        Annotated[TranslateStep, Tag("translate")],
        Annotated[RotateStep, Tag("rotate")],
        Annotated[ScaleStep, Tag("scale")],
        Annotated[MatrixStep, Tag("matrix")],
    ],
    Discriminator(
        step_kind,
        custom_error_type="transform_step",
        custom_error_message="expected a step with one key: translate, rotate, scale or matrix",
    ),
    BeforeValidator(_one_key),
]
"""One transform step: `{translate: ...}`, `{rotate: ...}`, `{scale: ...}` or `{matrix: ...}`."""

Transform = Annotated[list[TransformStep], Field(max_length=256)]
"""An ordered list of transform steps, applied first to last."""


MAX_KEYFRAMES = 64


class Keyframe(StrictModel):
    """Where a moving shape or instance is at one time: its `transform` then, applied after the
    shape's own `transform` (which stays fixed).

    ```yaml
    time: 1
    transform: [{rotate: {axis: y, degrees: 90}}, {translate: [2, 0, 0]}]
    ```
    """

    time: Number = Field(..., description="The time of this keyframe, on the shutter's clock (`shutter.open` .. `shutter.close`).")
    transform: Transform = Field(
        default_factory=list, description="Transform steps, first to last, that place the shape at this time (none: where it stands)."
    )


def _increasing_times(keys: list) -> list:
    for k in range(1, len(keys)):
        if not keys[k].time > keys[k - 1].time:
            raise ValueError(
                f"keyframe times must increase: keyframe {k} is at {keys[k].time:g}, keyframe {k - 1} at {keys[k - 1].time:g}"
            )
    return keys


Motion = Annotated[list[Keyframe], Field(min_length=2, max_length=MAX_KEYFRAMES), AfterValidator(_increasing_times)]
"""Keyframes over the shutter, in increasing time: the placement is interpolated between them
(translation and scale linearly, rotation by quaternion slerp, as pbrt-v4 does) and held before
the first and after the last."""
