"""Declared table layouts: every column of every flat table named once, with its width and meaning.

A table row (or a row kind of a table whose rows differ by kind, as primitives do) is a
`Layout`: an ordered list of `Column`s. Flattening writes a row by column name
(`MATERIAL_F.row(fuzz=0.3)`), and the kernels read it through integer constants taken from
the same declaration by name (`MAT_FUZZ = MATERIAL_F.offset("fuzz")`), which Numba compiles
in as literals. So a column's position is written down in one place only, and a misspelt name
fails at import, not as a wrong number in an image.

This module declares the vocabulary and imports no category: each category imports it to
declare its own layouts, and `renderer/declared_tables.py` lists them all for the docs
(`python -m renderer.declared_tables` prints what `docs/architecture.md` shows).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence


@dataclass(frozen=True)
class Column:
    name: str
    width: int  # how many values: 1 for a scalar, 3 for a point or colour, 9 for a 3x3 matrix
    meaning: str


class Layout:
    """The columns of one kind of row, in order; `width` is the row's length (at least theirs)."""

    def __init__(self, name: str, dtype: str, columns: Sequence[Column], width: int | None = None):
        self.name = name
        self.dtype = dtype
        self.columns = tuple(columns)
        self._offsets: dict[str, int] = {}
        at = 0
        for column in self.columns:
            if column.name in self._offsets:
                raise ValueError(f"{name}: column {column.name!r} declared twice")
            self._offsets[column.name] = at
            at += column.width
        self.used = at
        self.width = at if width is None else width
        if self.used > self.width:
            raise ValueError(f"{name}: {self.used} values do not fit in a row of {self.width}")

    def offset(self, name: str) -> int:
        """The first value of column `name`."""
        try:
            return self._offsets[name]
        except KeyError:
            raise KeyError(f"{self.name} has no column {name!r}; it has {', '.join(self._offsets)}") from None

    def offsets(self, *names: str) -> tuple[int, ...]:
        return tuple(self.offset(name) for name in names)

    def row(self, **values) -> list:
        """A row with the named columns set (scalars or sequences of the column's width), zeros elsewhere."""
        row = [0] * self.width if self.dtype.startswith("int") else [0.0] * self.width
        for name, value in values.items():
            at = self.offset(name)
            width = next(c.width for c in self.columns if c.name == name)
            if width == 1:
                row[at] = value
            else:
                if len(value) != width:
                    raise ValueError(f"{self.name}.{name}: {width} values expected, got {len(value)}")
                row[at:at + width] = value
        return row

    def array(self, count: int, /, **columns):
        """A numpy array of `count` rows with the named columns set from arrays (or scalars)
        of shape (count,) or (count, width), zeros elsewhere: many rows at once, by name."""
        import numpy as np

        out = np.zeros((count, self.width), self.dtype)
        for name, values in columns.items():
            at = self.offset(name)
            width = next(c.width for c in self.columns if c.name == name)
            values = np.asarray(values)
            out[:, at:at + width] = values.reshape(count, width) if values.ndim else values
        return out

    def shares(self, other: "Layout", *names: str) -> None:
        """Assert that columns `names` sit at the same place in both layouts (kernels read them
        without looking at the row's kind)."""
        for name in names:
            if self.offset(name) != other.offset(name):
                raise ValueError(f"{self.name}.{name} and {other.name}.{name} must share a place")

    def describe(self) -> list[str]:
        """Markdown table rows: columns, their places and meanings."""
        lines = []
        for column in self.columns:
            at = self._offsets[column.name]
            where = f"{at}" if column.width == 1 else f"{at}:{at + column.width}"
            lines.append(f"| `{self.name}` | {where} | `{column.name}` | {column.meaning} |")
        return lines


def describe_all(layouts: Iterable[Layout]) -> str:
    lines = ["| table (row kind) | values | column | meaning |", "|---|---|---|---|"]
    for layout in layouts:
        lines += layout.describe()
    return "\n".join(lines)
