"""Display transforms: linear scene radiance to the 8-bit values of a PNG.

A render's pixels are radiance, unbounded above; a screen shows code values 0..255. How one
becomes the other is a choice, made per render (`rt render --display NAME`, the scene's
`image.display`, `rt.render(display=)`), and written into the PNG (film.py's `png_bytes`):

- `gamma2`, the books' and the default: the square root, clamped to [0, 0.999], times 256 and
  truncated. Every PNG rt wrote before display transforms existed used it, bit for bit.
- `srgb`: the sRGB standard's encoding curve (IEC 61966-2-1), radiance clamped to [0, 1] and the
  code value rounded to nearest. It differs from gamma 2 mostly in the shadows (a linear segment
  near black) and in rounding rather than truncating.
- `agx`: a filmic curve after Troy Sobotka's AgX (the view Blender 4 uses by default), in Benjamin
  Wrensch's published fit: a mild desaturating "inset" matrix, log2 encoding over a fixed range
  of 16.5 stops around mid grey, a sixth-degree polynomial fit of AgX's sigmoid, the inverse
  ("outset") matrix, then a 2.2 power display. Highlights roll off smoothly and bright colours
  move toward white instead of clipping to a hue shifted primary.
- `aces`: the ACES reference rendering and sRGB output transforms (RRT + ODT) in Stephen Hill's
  fitted form: a matrix into the ACES working primaries (with the RRT's saturation folded in), a
  rational curve fitted to the RRT+ODT tone scale, a matrix back to sRGB primaries, clamped, then
  the sRGB encoding. ACES darkens mid grey: 0.18 displays as about 0.106 (code 91 against srgb's
  118), as the reference transforms do; raise --exposure to compensate.

Why formulas rather than a colour library: each transform here is a few published lines of
arithmetic on numpy arrays, with no dependency to install, where OpenColorIO or colour-science
would add a large package (and for OpenColorIO a configuration to choose) to every install for
the same curves (docs/display.md, "Why formulas"). The cost is that `agx` and `aces` are fits, not the reference transforms: Wrensch
gives his polynomial's mean squared error against AgX's sigmoid as 3.7e-6; Hill's fit follows the
RRT+ODT tone scale closely over the displayable range, with the hue adjustments of the reference
RRT left out.

Every transform here is total: NaN and negative radiance display as black, +inf as the
brightest value the curve reaches, and no NaN or infinity survives to a code value (gamma2 keeps
the books' arithmetic exactly, and the film holds no NaN: non-finite samples are dropped).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

# The names, in the order messages list them; the scene format's `image.display` accepts the same
# (scenefmt/scene.py: DisplayName; tests/test_display.py keeps the two lists equal).
DISPLAYS = ("gamma2", "srgb", "agx", "aces")
DEFAULT_DISPLAY = "gamma2"

# What each transform is, in a few words: the PNG's metadata and the documentation say it.
DESCRIPTIONS = {
    "gamma2": "the books' gamma 2: sqrt, clamped to [0, 0.999], x256, truncated",
    "srgb": "the sRGB encoding curve (IEC 61966-2-1), clamped to [0, 1], rounded",
    "agx": "AgX filmic curve (Sobotka), Wrensch's polynomial fit, for a 2.2 display, sRGB-encoded",
    "aces": "ACES RRT+ODT for sRGB in Hill's fit, sRGB-encoded",
}


def gamma2(linear: np.ndarray) -> np.ndarray:
    """The books' 8-bit pixels: gamma 2 (the square root), clamped to [0, 0.999], x256, truncated.
    The arithmetic every rt PNG used before there was a choice: changing it changes every image."""
    # NaN shows as black (the film holds none; the cast of a NaN to uint8 is undefined); every other
    # value, infinities included, goes through the books' arithmetic unchanged.
    gamma = np.sqrt(np.clip(np.nan_to_num(linear, nan=0.0), 0.0, None))
    return (256.0 * np.clip(gamma, 0.0, 0.999)).astype(np.uint8)


# The sRGB curve's two pieces meet at this linear value (12.92 x there equals the power piece).
SRGB_KNEE = 0.0031308


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """The sRGB encoding of linear values in [0, 1] (IEC 61966-2-1): a straight line of slope 12.92
    up to the knee, then 1.055 x^(1/2.4) - 0.055. Values outside [0, 1] (and NaN) are clamped first."""
    x = np.clip(np.nan_to_num(np.asarray(linear, dtype=np.float64), nan=0.0), 0.0, 1.0)
    # The power is taken of the knee where x is below it, so no tiny or zero value reaches it.
    power = 1.055 * np.power(np.maximum(x, SRGB_KNEE), 1.0 / 2.4) - 0.055
    return np.where(x <= SRGB_KNEE, 12.92 * x, power)


def to_code8(encoded: np.ndarray) -> np.ndarray:
    """Display-encoded values in [0, 1] as 8-bit codes, rounded to nearest (halves up)."""
    return np.floor(255.0 * np.clip(encoded, 0.0, 1.0) + 0.5).astype(np.uint8)


def srgb(linear: np.ndarray) -> np.ndarray:
    """8-bit sRGB: radiance clamped to [0, 1], encoded by the sRGB curve, rounded."""
    return to_code8(srgb_encode(linear))


# Beyond this radiance both filmic curves are flat to well under one code value (AgX's log range
# ends at 2^4.03 = 16.3; Hill's curve is within 1e-4 of its limit past 1e3), so larger values,
# infinity included, are treated as this one: the arithmetic below then never meets inf - inf.
FILMIC_CEILING = 1.0e4


def _finite_radiance(linear: np.ndarray) -> np.ndarray:
    """Radiance for the filmic curves: NaN and negative values as 0, at most FILMIC_CEILING."""
    x = np.nan_to_num(np.asarray(linear, dtype=np.float64), nan=0.0, posinf=FILMIC_CEILING, neginf=0.0)
    return np.clip(x, 0.0, FILMIC_CEILING)


# --- AgX, in Benjamin Wrensch's minimal form ("Minimal AgX implementation", iolite-engine.com, 2024;
# after Troy Sobotka's AgX, github.com/sobotka/AgX). Matrices as rows acting on column (r, g, b):
# the inset pulls every primary a little toward the others (each row sums to 1, so grey stays grey),
# which makes very bright saturated colours pass through white rather than clip; the outset is its
# inverse, applied after the curve.
AGX_INSET = np.array([
    [0.842479062253094, 0.0784335999999992, 0.0792237451477643],
    [0.0423282422610123, 0.878468636469772, 0.0791661274605434],
    [0.0423756549057051, 0.0784336, 0.879142973793104],
])
AGX_OUTSET = np.array([
    [1.19687900512017, -0.0980208811401368, -0.0990297440797205],
    [-0.0528968517574562, 1.15190312990417, -0.0989611768448433],
    [-0.0529716355144438, -0.0980434501171241, 1.15107367264116],
])
# The log2 range the curve spans, in stops of radiance (mid grey 0.18 sits at about -2.47).
AGX_MIN_EV = -12.47393
AGX_MAX_EV = 4.026069
# Wrensch's sixth-degree polynomial fit of AgX's default contrast sigmoid on [0, 1], highest power
# first (his stated mean squared error: 3.67e-6).
AGX_SIGMOID = (15.5, -40.14, 31.96, -6.868, 0.4298, 0.1191, -0.00232)
# The display the curve's output is meant for: a pure 2.2 power (the sRGB standard's reference display).
AGX_DISPLAY_GAMMA = 2.2


def agx_encode(linear: np.ndarray) -> np.ndarray:
    """AgX's display-encoded values in [0, 1] for an sRGB screen, (..., 3)."""
    x = _finite_radiance(linear) @ AGX_INSET.T
    # Radiance to a position in the log2 range: 0 at AGX_MIN_EV stops and below, 1 at AGX_MAX_EV and above.
    stops = np.clip(np.log2(np.maximum(x, 1e-10)), AGX_MIN_EV, AGX_MAX_EV)
    t = (stops - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV)
    curve = np.polyval(AGX_SIGMOID, t) @ AGX_OUTSET.T
    # The curve's output drives a 2.2 display; as Wrensch's shader does for an sRGB target, it is
    # turned into display light and that light encoded with the sRGB curve.
    shown = np.power(np.clip(curve, 0.0, 1.0), AGX_DISPLAY_GAMMA)
    return srgb_encode(shown)


def agx(linear: np.ndarray) -> np.ndarray:
    """8-bit AgX (see agx_encode), rounded."""
    return to_code8(agx_encode(linear))


# --- ACES, in Stephen Hill's fit (BakingLab, ACES.hlsl, 2016; after the Academy's RRT and sRGB ODT).
# Linear sRGB -> XYZ -> D60 white -> ACES AP1 primaries, with the RRT's saturation step folded in:
ACES_IN = np.array([
    [0.59719, 0.35458, 0.04823],
    [0.07600, 0.90834, 0.01566],
    [0.02840, 0.13383, 0.83777],
])
# The ODT's desaturation -> XYZ -> D65 white -> linear sRGB:
ACES_OUT = np.array([
    [1.60475, -0.53108, -0.07367],
    [-0.10208, 1.10813, -0.00605],
    [-0.00327, -0.07276, 1.07602],
])


def aces_tone(v: np.ndarray) -> np.ndarray:
    """Hill's rational fit of the RRT+ODT tone scale, per channel: (v (v + a) - b) / (v (c v + d) + e).
    Its denominator is at least 0.238 for v >= 0, so it is finite for every finite input."""
    return (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081)


def aces_encode(linear: np.ndarray) -> np.ndarray:
    """ACES's display-encoded values in [0, 1] for an sRGB screen, (..., 3)."""
    x = _finite_radiance(linear) @ ACES_IN.T
    shown = np.clip(aces_tone(x) @ ACES_OUT.T, 0.0, 1.0)  # display light, linear sRGB
    return srgb_encode(shown)


def aces(linear: np.ndarray) -> np.ndarray:
    """8-bit ACES (see aces_encode), rounded."""
    return to_code8(aces_encode(linear))


TRANSFORMS: dict[str, Callable[[np.ndarray], np.ndarray]] = {"gamma2": gamma2, "srgb": srgb, "agx": agx, "aces": aces}


def unknown_display(name: object) -> str:
    """The sentence that refuses a display name: what was asked, what exists, and the nearest one."""
    import difflib

    from scenefmt.diagnostics import quote_text

    shown = quote_text(str(name)) if isinstance(name, str) else repr(name)
    close = difflib.get_close_matches(str(name).lower(), DISPLAYS, n=1, cutoff=0.5)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"unknown display transform {shown}: expected {', '.join(DISPLAYS[:-1])} or {DISPLAYS[-1]}{hint}"


def to_display8(linear: np.ndarray, display: str = DEFAULT_DISPLAY) -> np.ndarray:
    """The 8-bit pixels (h, w, 3) uint8 of a linear image (h, w, 3) under the transform named
    `display` (one of DISPLAYS). Raises ValueError, in one sentence, for another name."""
    transform = TRANSFORMS.get(display) if isinstance(display, str) else None
    if transform is None:
        raise ValueError(unknown_display(display))
    return transform(linear)
