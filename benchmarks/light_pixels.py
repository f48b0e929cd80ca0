"""The pixels an error measure of light transport leaves out: those that see a light.

A pixel that sees a light directly holds the light's radiance, the same for every integrator.
A pixel that sees one only in part (the light's edge crosses it) is worse: its noise is where in
the pixel the edge falls, which is the camera's sampling of the pixel, not light transport, and
no light sampling changes it. On the 600 x 600 Cornell box the 96 pixels of the lamp's rim whose
mean stays below 1 held 11% of the light-sampled image's squared error. So both are left out:

- every pixel one of whose camera rays met an emitter, found by rendering the image with paths
  one segment long (the camera ray's own hit) at `SPP` samples per pixel;
- every pixel brighter than 1 in the reference, which also takes out a background brighter than
  any lit wall and, on the Cornell box, the sliver of ceiling seen through the 1-unit gap above
  the lamp, which its back lights at about 11.
"""

from __future__ import annotations

import dataclasses

import numpy as np

SPP = 256  # a pixel whose light covers 1% of it is found with probability 1 - 0.99^256 = 92%
SEED = 4242


def sees_light(graph) -> np.ndarray:
    """Per pixel (rows, columns): whether some camera ray of `SPP` met an emitter. The scene's
    background must be black (it is in every scene with lights that the benchmarks use): a ray
    that escapes adds the background, which would count as a light here."""
    from renderer.render import render

    first_hit = dataclasses.replace(graph, image=graph.image.model_copy(update={"max_depth": 1, "integrator": "path"}))
    return render(first_hit, samples=SPP, seed=SEED).film.mean().max(axis=2) > 0.0


def kept_pixels(graph, reference: np.ndarray) -> np.ndarray:
    """The pixels an error measure keeps: those that see no light and are not brighter than 1."""
    return (reference.max(axis=2) <= 1.0) & ~sees_light(graph)
