"""Affine transforms as 3x4 row-major tuples (pure Python, so `rt validate` needs no numpy)."""

from __future__ import annotations

import math
from typing import Sequence

from .transforms import MatrixStep, RotateStep, ScaleStep, TranslateStep

Affine = tuple[tuple[float, float, float, float], tuple[float, float, float, float], tuple[float, float, float, float]]

IDENTITY: Affine = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0))

_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def compose(outer: Affine, inner: Affine) -> Affine:
    """The map `p -> outer(inner(p))`."""
    rows = []
    for r in range(3):
        o = outer[r]
        row = [sum(o[k] * inner[k][c] for k in range(3)) for c in range(3)]
        row.append(sum(o[k] * inner[k][3] for k in range(3)) + o[3])
        rows.append(tuple(row))
    return tuple(rows)  # type: ignore[return-value]


def rotation(axis: Sequence[float] | str, degrees: float) -> Affine:
    """Right-handed rotation by `degrees` about a unit-normalised `axis` (Rodrigues' formula)."""
    x, y, z = _AXES[axis] if isinstance(axis, str) else axis
    n = math.sqrt(x * x + y * y + z * z)
    x, y, z = x / n, y / n, z / n
    theta = math.radians(degrees)
    # Exact values at multiples of 90 degrees keep axis-aligned boxes axis-aligned.
    quarter = degrees / 90.0
    if quarter == round(quarter):
        c, s = ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(round(quarter)) % 4]
    else:
        c, s = math.cos(theta), math.sin(theta)
    t = 1.0 - c
    return (
        (t * x * x + c, t * x * y - s * z, t * x * z + s * y, 0.0),
        (t * x * y + s * z, t * y * y + c, t * y * z - s * x, 0.0),
        (t * x * z - s * y, t * y * z + s * x, t * z * z + c, 0.0),
    )


def step_matrix(step) -> Affine:
    if isinstance(step, TranslateStep):
        tx, ty, tz = step.translate
        return ((1.0, 0.0, 0.0, tx), (0.0, 1.0, 0.0, ty), (0.0, 0.0, 1.0, tz))
    if isinstance(step, RotateStep):
        return rotation(step.rotate.axis, step.rotate.degrees)
    if isinstance(step, ScaleStep):
        sx, sy, sz = (step.scale,) * 3 if isinstance(step.scale, (int, float)) else step.scale
        return ((sx, 0.0, 0.0, 0.0), (0.0, sy, 0.0, 0.0), (0.0, 0.0, sz, 0.0))
    if isinstance(step, MatrixStep):
        return tuple(tuple(float(v) for v in row) for row in step.matrix[:3])  # type: ignore[return-value]
    raise TypeError(f"unknown transform step {step!r}")


def from_steps(steps: Sequence) -> Affine:
    """Compose steps applied first to last into one `world_from_object` map."""
    m = IDENTITY
    for step in steps:
        m = compose(step_matrix(step), m)
    return m


def apply_point(m: Affine, p: Sequence[float]) -> tuple[float, float, float]:
    return tuple(m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3] for r in range(3))  # type: ignore[return-value]


def is_identity(m: Affine) -> bool:
    return m == IDENTITY


# --- 3-vectors as tuples of Python floats ---------------------------------------------------
# Flattening makes a row per shape; numpy's per-call cost on 3-vectors made it several times
# slower than these.

Vec = tuple[float, float, float]


def add(a, b) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(a, s: float) -> Vec:
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def unit(a) -> Vec:
    length = math.sqrt(dot(a, a))
    return (a[0] / length, a[1] / length, a[2] / length)


def linear(m: Affine) -> tuple[Vec, Vec, Vec]:
    """The 3x3 linear part of an affine map, as rows."""
    return tuple(tuple(float(x) for x in row[:3]) for row in m)  # type: ignore[return-value]


def apply_linear(lin, v) -> Vec:
    """lin @ v for a 3x3 matrix given as rows."""
    return tuple(dot(row, v) for row in lin)  # type: ignore[return-value]


def determinant(lin) -> float:
    return dot(lin[0], cross(lin[1], lin[2]))


def similarity_scale(lin) -> float | None:
    """s when lin = s * (an orthogonal matrix), else None: lin^T lin = s^2 I within 1e-9."""
    cols = [tuple(row[k] for row in lin) for k in range(3)]
    s2 = dot(cols[0], cols[0])
    if s2 <= 0:
        return None
    for i in range(3):
        for j in range(3):
            target = s2 if i == j else 0.0
            if not abs(dot(cols[i], cols[j]) - target) <= 1e-12 * s2 + 1e-9 * abs(target):
                return None
    return math.sqrt(s2)
