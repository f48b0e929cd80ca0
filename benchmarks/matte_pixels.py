"""The pixels whose camera rays all land on a surface with a density (`--pixels matte` of
benchmarks/caustics.py).

A pixel whose first hit is the books' glass or metal (a delta BSDF), an emitter or the background
is rendered by the very same estimator in `mis` and `caustics`: the caustic photons land only on
matte surfaces the camera sees directly. Its error is the camera's sampling of what the delta
surface shows, most of all a lamp seen through a glass sphere: a tiny, very bright image that no
integrator changes. Measuring only the matte pixels shows the part of the error that light
transport decides.

The camera rays are made here in numpy as `camera.camera_ray` makes them (jittered in the pixel,
from a point of the lens where the camera has one) and traced by `tracing.probe.probe_rays`.
"""

from __future__ import annotations

import numpy as np

RAYS = 16  # jittered rays per pixel; a pixel is kept only if every one lands on a matte surface
SEED = 4343


def density_materials(mat_i: np.ndarray) -> np.ndarray:
    """Per material row: whether a hit on it has a BSDF part with a density (what the kernel's
    `materials.has_density` answers), decided from the row alone. The books' lambertian, the
    media's isotropic phase and the plastic (its base always has one) do; metal (fuzzed or not),
    dielectric and lights do not. A microfacet family (conductor, rough dielectric, principled)
    has one or not by its parameters at the hit, which a row does not tell: counted as without,
    so a pixel that sees one is never kept by mistake."""
    from renderer.materials.table import ISOTROPIC, LAMBERTIAN, MAT_KIND, PLASTIC

    kinds = mat_i[:, MAT_KIND]
    return (kinds == LAMBERTIAN) | (kinds == ISOTROPIC) | (kinds == PLASTIC)


def camera_rays(cam: np.ndarray, width: int, height: int, rays: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """`rays` jittered camera rays per pixel, pixel (row j, column i) at rows (j * width + i) * rays..,
    as camera.camera_ray casts them: origins and directions (n, 3)."""
    from renderer.camera import CAM_DU, CAM_DV, CAM_LENS_RADIUS, CAM_LENS_U, CAM_LENS_V, CAM_ORIGIN, CAM_PIXEL00

    rng = np.random.default_rng(seed)
    j, i = np.meshgrid(np.arange(height), np.arange(width), indexing="ij")
    # Pixel (j, i) is centred on pixel00 + i du + j dv, as in camera.camera_ray.
    i = np.repeat(i.ravel(), rays) + rng.random(height * width * rays) - 0.5
    j = np.repeat(j.ravel(), rays) + rng.random(height * width * rays) - 0.5
    p00, du, dv = (cam[k:k + 3] for k in (CAM_PIXEL00, CAM_DU, CAM_DV))
    aim = p00 + i[:, None] * du + j[:, None] * dv
    origin = np.broadcast_to(cam[CAM_ORIGIN:CAM_ORIGIN + 3], aim.shape).copy()
    radius = cam[CAM_LENS_RADIUS]
    if radius > 0.0:
        r = radius * np.sqrt(rng.random(len(aim)))
        phi = 2.0 * np.pi * rng.random(len(aim))
        lu, lv = cam[CAM_LENS_U:CAM_LENS_U + 3], cam[CAM_LENS_V:CAM_LENS_V + 3]
        origin += (r * np.cos(phi))[:, None] * lu + (r * np.sin(phi))[:, None] * lv
    return np.ascontiguousarray(origin), np.ascontiguousarray(aim - origin)


def matte_pixels(graph, rays: int = RAYS, seed: int = SEED) -> np.ndarray:
    """Per pixel (rows, columns): whether all `rays` jittered camera rays first hit a surface with
    a density (not a delta BSDF, not an emitter, not the background). A ray that meets a medium
    first is counted as matte: the medium scatters with a density."""
    from renderer.camera import CAM_OPEN
    from renderer.compile import compile_scene
    from renderer.shapes import MEDIUM, PRIM_KIND, PRIM_MATERIAL
    from renderer.tracing.probe import probe_rays

    from renderer.flat import Frame

    flat = compile_scene(graph)
    frame = Frame.of(graph)
    width, height = frame.width, frame.height
    origins, dirs = camera_rays(flat.camera, width, height, rays, seed)
    _, prim, *_ = probe_rays(flat, origins, dirs, float(flat.camera[CAM_OPEN]), 0.0, False)
    hit = prim >= 0
    matte = np.zeros(len(prim), bool)
    rows = prim[hit]
    dense = density_materials(flat.mat_i)
    matte[hit] = dense[flat.prims_i[rows, PRIM_MATERIAL]] | (flat.prims_i[rows, PRIM_KIND] == MEDIUM)
    return matte.reshape(height, width, rays).all(axis=2)

