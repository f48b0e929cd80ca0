"""The rare-path prior: when a scene can hide light from every estimate made of its samples.

Light that reaches a matte surface only through glass or a mirror from a small, very bright light
(a caustic of the sun through a glass sphere, a lamp inside a glass fixture) is found only by the
rare path whose bounce happens to leave in just the right direction: light sampling cannot aim
at it through a delta lobe. At a few dozen samples per pixel most such pixels hold not one of
those paths, and then nothing in the film can tell: the samples' spread, the batches and the
peaks all look like a light-tailed image, and the error is several times the estimate
(docs/error_estimate.md: on `sky_spheres` at 16 spp about a third of the renders held no caustic
sample at all, and their true error was twice the estimate). The film-based warnings
(error_estimate.py) catch the renders that did find a few such paths; this prior says, from
the scene alone, that the others may exist.

The rule: the scene has a sharp surface (materials.table.sharp_rows: glass, near-mirror metals,
narrow microfacet lobes) and a light whose radiance is at least RADIANCE_RATIO times the image's
mean value (the environment map's brightest texel or an emitter's brightest colour), and the
render holds fewer than TRUSTED_SAMPLES samples per pixel. Measured at 48 px against converged
references (tests/test_error_coverage.py): the shipped scenes with such a light are sky_spheres and
material_spheres (the sun of the sky map, about 1,400 times their mean) and the benchmark's
caustic_glass (1,200 times); every Cornell box holds its lamp at 85-95 times its mean, final_scene
at 16, and no other scene has an emitter above its mean by more than 20. On sky_spheres the
estimate agrees with the true error from 256 samples per pixel on (0.32 against 0.35).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

RADIANCE_RATIO = 300.0
TRUSTED_SAMPLES = 256


@dataclass(frozen=True)
class RarePathPrior:
    """What the scene holds that can hide rare bright paths: the brightest radiance a light sends
    and what it is, in words."""

    peak_radiance: float
    light: str  # "the environment map's brightest texels" or "an emitter"

    def warning(self, image_mean: float, samples: int) -> Optional[str]:
        """The sentence to show for a render of `samples` samples per pixel whose image has mean
        value `image_mean`; None when the prior does not apply."""
        if samples >= TRUSTED_SAMPLES or not (image_mean > 0) or self.peak_radiance < RADIANCE_RATIO * image_mean:
            return None
        return (f"light can reach this scene's matte surfaces through glass or mirrors from {self.light} "
                f"({self.peak_radiance / image_mean:,.0f} times the image's mean): paths that find it are rare, and at "
                f"{samples} samples per pixel many pixels may hold none, so the error may be several times the "
                f"estimate; trust it from {TRUSTED_SAMPLES} samples per pixel on")


def rare_path_prior(flat) -> Optional[RarePathPrior]:
    """The prior of a flat scene (compile.compile_scene), or None when it has no sharp surface or no light."""
    from .lights import LIGHT_KIND, LIGHT_RADIANCE, SUN_LIGHT
    from .materials import emitting_rows
    from .materials.table import emission_rows, sharp_rows
    from .textures import texture_peak

    if not sharp_rows(flat.mat_i, flat.mat_f).any():
        return None
    candidates = []
    if flat.env_rgb.size:
        candidates.append((float(np.max(flat.env_rgb)), "the environment map's brightest texels"))
    suns = flat.light_i[:, LIGHT_KIND] == SUN_LIGHT
    if suns.any():  # a small, bright disc that sharp surfaces show only to the paths that find it
        candidates.append((float(np.max(flat.light_f[suns, LIGHT_RADIANCE:LIGHT_RADIANCE + 3])), "the sun's disc"))
    if len(flat.mat_i):
        emits = np.zeros(len(flat.mat_i), np.bool_)
        emitting_rows(flat.mat_i, emits)
        rows, factors = emission_rows(flat.mat_i, flat.mat_f)
        for mat in np.nonzero(emits)[0]:
            peak = factors[mat] * texture_peak(flat.tex_i, flat.tex_f, flat.texels, int(rows[mat]))
            candidates.append((float(peak), "an emitter"))
    candidates = [c for c in candidates if np.isfinite(c[0]) and c[0] > 0]
    if not candidates:
        return None
    peak, light = max(candidates)
    return RarePathPrior(peak, light)


def image_mean(film) -> float:
    """The mean value of the film's image, over pixels and channels."""
    return float(np.mean(film.mean())) if film.samples else 0.0
