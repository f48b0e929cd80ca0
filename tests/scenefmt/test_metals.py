"""The measured metals a conductor may name (scenefmt/metals.py): complete, looked up by symbol or
English name, physically plausible colours, and (where Mitsuba 3 is installed, the `bench` extra)
equal to Mitsuba's own RGB values."""

from __future__ import annotations

import pytest

from scenefmt import metals

REQUIRED = {"gold": "Au", "silver": "Ag", "copper": "Cu", "aluminium": "Al", "chromium": "Cr", "iron": "Fe"}


def normal_reflectance(m):
    """Fresnel reflectance at normal incidence from vacuum, per channel."""
    return [((n - 1) ** 2 + k * k) / ((n + 1) ** 2 + k * k) for n, k in zip(m.eta, m.k)]


def test_required_metals_by_symbol_and_name():
    for name, symbol in REQUIRED.items():
        assert metals.metal(symbol) is metals.metal(name) is metals.metal(name.capitalize()) is metals.METALS[symbol]
    assert metals.metal("aluminum") is metals.METALS["Al"]


def test_every_metal_is_three_positive_channels_with_a_source():
    for symbol, m in metals.METALS.items():
        assert len(m.eta) == len(m.k) == 3
        assert all(isinstance(x, float) and 0.0 < x < 20.0 for x in m.eta + m.k), symbol
        assert m.source and m.name == m.name.lower()


def test_unknown_metal_lists_the_known_ones():
    with pytest.raises(ValueError, match="unknown metal 'unobtainium'.*Au.*gold"):
        metals.metal("unobtainium")
    # Symbols are Mitsuba's spelling, case included: "au" is not a name.
    with pytest.raises(ValueError):
        metals.metal("au")


def test_colours_are_the_metals_colours():
    r = {s: normal_reflectance(m) for s, m in metals.METALS.items()}
    gold, copper, silver, aluminium = r["Au"], r["Cu"], r["Ag"], r["Al"]
    assert gold[0] > gold[1] > gold[2] and gold[0] > 0.9 and gold[2] < 0.45
    assert copper[0] > copper[1] > copper[2] and copper[2] < 0.6
    assert min(silver) > 0.9 and min(aluminium) > 0.85
    # Grey metals reflect 0.4-0.7. Mitsuba's reduction to RGB makes no white-point correction, so
    # they come out a little warm (iron 0.59, 0.50, 0.46), but never blue.
    for s in ("Fe", "Cr", "Ti", "Ni", "W"):
        assert 0.4 < min(r[s]) and max(r[s]) < 0.72 and r[s][0] >= r[s][2] and r[s][0] - r[s][2] < 0.25, (s, r[s])
