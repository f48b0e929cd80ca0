"""Texture lookup: solid colour, 3-D checker, image (u, v), and Perlin noise forms."""

import math

from numba import njit

from .features import CHECKER, IMAGE, NOISE
from ..layout import NOISE_MARBLE, NOISE_PLAIN, TEX_CHECKER, TEX_IMAGE, TEX_SOLID


@njit(_nrt=False, cache=True, error_model="numpy")
def perlin(perm, vec, q, x, y, z):
    """Gradient noise at (x, y, z) from table set q, in about [-1, 1]; continuous everywhere."""
    fx, fy, fz = math.floor(x), math.floor(y), math.floor(z)
    u, v, w = x - fx, y - fy, z - fz
    i, j, k = int(fx), int(fy), int(fz)
    # Hermite smoothing once, inside the interpolation (the weight vectors use the raw offsets).
    uu, vv, ww = u * u * (3.0 - 2.0 * u), v * v * (3.0 - 2.0 * v), w * w * (3.0 - 2.0 * w)
    accum = 0.0
    for di in range(2):
        for dj in range(2):
            for dk in range(2):
                h = perm[q, 0, (i + di) & 255] ^ perm[q, 1, (j + dj) & 255] ^ perm[q, 2, (k + dk) & 255]
                gx, gy, gz = vec[q, h, 0], vec[q, h, 1], vec[q, h, 2]
                dot = gx * (u - di) + gy * (v - dj) + gz * (w - dk)
                accum += (
                    (di * uu + (1 - di) * (1.0 - uu))
                    * (dj * vv + (1 - dj) * (1.0 - vv))
                    * (dk * ww + (1 - dk) * (1.0 - ww))
                    * dot
                )
    return accum


@njit(_nrt=False, cache=True, error_model="numpy")
def turbulence(perm, vec, q, x, y, z, octaves):
    accum = 0.0
    weight = 1.0
    for _ in range(octaves):
        accum += weight * perlin(perm, vec, q, x, y, z)
        weight *= 0.5
        x, y, z = x * 2.0, y * 2.0, z * 2.0
    return abs(accum)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def texture_value(tex_i, tex_f, texels, noise_perm, noise_vec, t, u, v, p):
    """Colour of texture t at surface coordinates (u, v) and point p."""
    # Checkers choose a child texture: descend iteratively (kernels avoid recursion).
    while CHECKER and tex_i[t, 0] == TEX_CHECKER:
        inv = tex_f[t, 3]
        s = math.floor(inv * p[0]) + math.floor(inv * p[1]) + math.floor(inv * p[2])
        t = tex_i[t, 1] if int(s) % 2 == 0 else tex_i[t, 2]
    kind = tex_i[t, 0]
    if kind == TEX_SOLID:
        return (tex_f[t, 0], tex_f[t, 1], tex_f[t, 2])
    if IMAGE and kind == TEX_IMAGE:
        offset, width, height = int(tex_f[t, 3]), int(tex_f[t, 4]), int(tex_f[t, 5])
        uc = min(1.0, max(0.0, u))
        vc = 1.0 - min(1.0, max(0.0, v))  # image rows run top to bottom
        i = min(width - 1, int(uc * width))
        j = min(height - 1, int(vc * height))
        k = offset + j * width + i
        return (float(texels[k, 0]), float(texels[k, 1]), float(texels[k, 2]))
    if NOISE:  # the only kind left: TEX_NOISE
        scale, form, octaves, q = tex_f[t, 3], int(tex_f[t, 4]), int(tex_f[t, 5]), int(tex_f[t, 6])
        if form == NOISE_PLAIN:
            value = 0.5 * (1.0 + perlin(noise_perm, noise_vec, q, scale * p[0], scale * p[1], scale * p[2]))
        elif form == NOISE_MARBLE:
            value = 0.5 * (1.0 + math.sin(scale * p[2] + 10.0 * turbulence(noise_perm, noise_vec, q, p[0], p[1], p[2], octaves)))
        else:
            value = turbulence(noise_perm, noise_vec, q, scale * p[0], scale * p[1], scale * p[2], octaves)
        return (tex_f[t, 0] * value, tex_f[t, 1] * value, tex_f[t, 2] * value)
    return (tex_f[t, 0], tex_f[t, 1], tex_f[t, 2])  # unreachable: the scene has no noise texture
