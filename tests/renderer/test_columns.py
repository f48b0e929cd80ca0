"""Table declarations: rows are written by name, read through the same offsets, and documented."""

from pathlib import Path

import pytest

from renderer.columns import Column, Layout, describe_all
from renderer.declared_tables import declared_layouts
from renderer.materials import MAT_FUZZ, MAT_IOR, MATERIAL_F
from renderer.shapes.spheres import MOVING_SPHERE_F, SPHERE_F

DOC = Path(__file__).resolve().parents[2] / "docs" / "architecture.md"


def test_a_row_is_written_by_name_and_read_at_the_declared_offset():
    row = MATERIAL_F.row(fuzz=0.25, ior=1.5)
    assert row[MAT_FUZZ] == 0.25 and row[MAT_IOR] == 1.5
    row = SPHERE_F.row(center=(1.0, 2.0, 3.0), radius=4.0)
    assert row[SPHERE_F.offset("center"):SPHERE_F.offset("center") + 3] == [1.0, 2.0, 3.0]
    assert len(row) == SPHERE_F.width


def test_misspelt_columns_and_wrong_widths_fail_loudly():
    with pytest.raises(KeyError, match="has no column 'fuz'"):
        MATERIAL_F.row(fuz=0.25)
    with pytest.raises(ValueError, match="3 values expected"):
        SPHERE_F.row(center=(1.0, 2.0))
    with pytest.raises(ValueError, match="declared twice"):
        Layout("t", "float64", [Column("a", 1, ""), Column("a", 1, "")])
    with pytest.raises(ValueError, match="do not fit"):
        Layout("t", "float64", [Column("a", 3, "")], width=2)


def test_kinds_that_share_a_reader_share_the_column():
    assert SPHERE_F.offset("radius") == MOVING_SPHERE_F.offset("radius")
    with pytest.raises(ValueError, match="must share a place"):
        SPHERE_F.shares(MOVING_SPHERE_F, "rotation")


def test_every_layout_fits_its_table_and_the_architecture_doc_lists_them_all():
    layouts = declared_layouts()
    assert all(layout.used <= layout.width for layout in layouts)
    table = describe_all(layouts)
    text = DOC.read_text()
    listed = text.split("<!-- declared tables -->\n", 1)[1].split("\n<!-- /declared tables -->", 1)[0]
    assert listed == table, "docs/architecture.md is stale: paste `python -m renderer.declared_tables` between its markers"
