"""Measured metals by name: the complex index of refraction eta + i k of each, in linear sRGB.

A `conductor` material may name its metal instead of giving `eta` and `k`. The RGB values are
Mitsuba 3's, so that a scene can be rendered by both and agree: Mitsuba 3 (version 3.9.1, its
`scalar_rgb` variant) loads a named conductor from its spectral tables `data/ior/<name>.eta.spd`
and `.k.spd` and reduces each spectrum to linear sRGB with `spectrum_list_to_srgb` (integration
against the CIE 1931 matching functions, no white-point correction); the numbers below are what
`mi.traverse(mi.load_dict({'type': 'conductor', 'material': name}))` reports. Mitsuba's
documentation says those tables are the ones distributed with pbrt, from the Luxpop database,
based on Palik's Handbook of Optical Constants of Solids and on atomic scattering factors
measured by the Center for X-Ray Optics (Berkeley) and the Lawrence Livermore National
Laboratory.

Mitsuba ships no iron or titanium. Their values here are Johnson and Christy's measurements
(Phys. Rev. B 9, 5056, 1974, as tabulated by the refractiveindex.info database) reduced to RGB by
the same Mitsuba function, which reproduces Mitsuba's own gold from its gold table to 1e-6.

Pure Python: the file format's models read it, and nothing here needs numpy.
"""

from __future__ import annotations

from typing import NamedTuple

RGB = tuple[float, float, float]

_MITSUBA = "Mitsuba 3.9.1 preset '{}' (Luxpop tables after Palik; CXRO/LLNL), reduced to RGB by Mitsuba"
_JOHNSON_CHRISTY = ("Johnson & Christy, Phys. Rev. B 9, 5056 (1974), via refractiveindex.info; "
                    "reduced to RGB by Mitsuba 3.9.1's spectrum_list_to_srgb")


class Metal(NamedTuple):
    """One measured metal: its English name, the real (eta) and imaginary (k) parts of its index
    relative to vacuum per linear-sRGB channel, and where the numbers come from."""

    name: str
    eta: RGB
    k: RGB
    source: str


METALS: dict[str, Metal] = {
    "Au": Metal("gold", (0.143036, 0.375307, 1.442045), (3.982997, 2.385556, 1.603359), _MITSUBA.format("Au")),
    "Ag": Metal("silver", (0.155276, 0.116728, 0.138388), (4.828354, 3.122222, 2.146901), _MITSUBA.format("Ag")),
    "Cu": Metal("copper", (0.201005, 0.923750, 1.102215), (3.913262, 2.453045, 2.142090), _MITSUBA.format("Cu")),
    "Al": Metal("aluminium", (1.657501, 0.880405, 0.521244), (9.223811, 6.269502, 4.837004), _MITSUBA.format("Al")),
    "Cr": Metal("chromium", (4.369668, 2.916505, 1.654905), (5.206547, 4.231306, 3.754699), _MITSUBA.format("Cr")),
    "Fe": Metal("iron", (3.514471, 2.769762, 2.301729), (3.695020, 2.786124, 2.492985), _JOHNSON_CHRISTY),
    "Ti": Metal("titanium", (3.275397, 2.379751, 2.024695), (4.572333, 3.224527, 2.727808), _JOHNSON_CHRISTY),
    "Ni": Metal("nickel", (2.367305, 1.663373, 1.467078), (4.498812, 3.050153, 2.345439), _MITSUBA.format("Ni_palik")),
    "W": Metal("tungsten", (4.370817, 3.300246, 2.998407), (3.500641, 2.604874, 2.273233), _MITSUBA.format("W")),
    "Hg": Metal("mercury", (2.398939, 1.440028, 0.909570), (6.327587, 4.371925, 3.421764), _MITSUBA.format("Hg")),
}

# Other spellings a scene may use: English names, and the American "aluminum".
ALIASES: dict[str, str] = {m.name: symbol for symbol, m in METALS.items()}
ALIASES["aluminum"] = "Al"


def names() -> list[str]:
    """Every name `metal` accepts: the symbols, then the English names, each sorted."""
    return sorted(METALS) + sorted(ALIASES)


def metal(name: str) -> Metal:
    """The metal called `name`: an element symbol as Mitsuba spells it ("Au"), or its English name
    in any case ("gold", "Gold"). A ValueError lists the known names otherwise."""
    if name in METALS:
        return METALS[name]
    symbol = ALIASES.get(name.lower())
    if symbol is None:
        raise ValueError(f"unknown metal {name!r}; known: {', '.join(names())}")
    return METALS[symbol]
