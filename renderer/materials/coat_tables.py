"""How much light a dielectric coat lets through and traps, tabulated in numpy (the generator of
`coat_table_data.py`; the kernels read that module through `coat.py` and never import this one).

A plastic is a diffuse base under a dielectric coat (`plastic.py`). Light reaches the base only
through the coat, and light the base scatters back is partly reflected down again by the coat's
inner side. For a rough (GGX) coat neither has a closed form, so, as Mitsuba 3's `roughplastic`
does, both are integrated once over the visible normals:

- `transmittance(eta, alpha, mu)`: of light arriving from outside at cosine mu, the fraction that
  a microfacet refracts into the coat and that is not masked on its way in: the integral over
  the normals m visible from w of (1 - F(w.m)) G1(w_t, m), w_t the refracted direction. One
  minus it is the specular lobe's albedo plus what single-scattering GGX loses to masking.
- `internal_reflectance(eta, alpha)`: the cosine-weighted hemispherical average, seen from
  inside (relative index 1 / eta, so with total internal reflection), of the rough reflection's
  albedo: 2 * integral over mu of R(mu) mu. Mitsuba 3 takes this average as the mean over 64
  equally spaced cosines (both ends included), which is 1.3% low at ior 1.5 and alpha 0.1 (its
  rough plastic's base about 2% darker than ours); this file integrates with Gauss-Legendre
  nodes, so that the rough coat's limit at alpha -> 0 is the smooth coat's value (`coat.py`).

Both integrals use the visible-normal parametrisation of Heitz (2018): the map from the unit
square to visible normals has Jacobian 1 / D_w(m), so an integral against D_w(m) dm is a plain
integral over the square, done with a Gauss-Legendre product rule.

A smooth coat's internal reflectance has an exact expression through reciprocity
(`smooth_internal_reflectance`), tabulated finely over the ior alone (1 to 5 in steps of 0.01):
exact, it returns all the light of a white furnace, where Mitsuba's polynomial fit, 0.08% high
at ior 1.5, returns 1.001 of it.

The grids (`IORS`, `ROUGHNESSES`, `COSINES`) are chosen for linear interpolation: ior 1 to 3 in
steps of 0.1, roughness r = sqrt(alpha) 0 to 1 in steps of 1/16 (alpha = r^2 puts more points
where the lobe changes fastest), cosine 0 to 1 in steps of 1/32. Roughness 0 stands for alpha =
ALPHA_FLOOR, whose integrals equal the smooth interface's to about 1e-5.

Regenerate with `python -m renderer.materials.coat_tables` (about a minute); with
`--mitsuba-average` the rough internal reflectance is Mitsuba's, for images that match its
`roughplastic` (see benchmarks/mitsuba_plastic_image.py) at the cost of the smooth limit.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

# Each grid as (first value, step, count).
IOR_GRID = (1.0, 0.1, 21)
ROUGHNESS_GRID = (0.0, 1.0 / 16.0, 17)
COSINE_GRID = (0.0, 1.0 / 32.0, 33)


def _points(grid):
    first, step, count = grid
    return first + step * np.arange(count)


IORS, ROUGHNESSES, COSINES = _points(IOR_GRID), _points(ROUGHNESS_GRID), _points(COSINE_GRID)
# The smooth coat's internal reflectance depends on the ior alone: a fine grid, over more iors.
SMOOTH_IOR_GRID = (1.0, 0.01, 401)
SMOOTH_IORS = _points(SMOOTH_IOR_GRID)
# The width used for roughness 0 (a smooth coat has no GGX lobe to integrate).
ALPHA_FLOOR = 1e-4
# Below this cosine a direction is taken at this cosine: exactly grazing light has no projected
# area, and the integrals' limits there are what interpolation toward 0 needs.
MU_FLOOR = 1e-6


def fresnel(cos_i, eta):
    """Unpolarised Fresnel reflectance and the refracted cosine (>= 0) for cos_i >= 0 and eta the
    index on the incident side over the far side's; 1 (and cosine 0) under total internal
    reflection. Vectorised; the same equations as `fresnel.fresnel_dielectric`."""
    cos_i = np.clip(cos_i, 0.0, 1.0)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin2_t))
    a = eta * cos_i
    with np.errstate(invalid="ignore", divide="ignore"):
        rs = (a - cos_t) / (a + cos_t)
        rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    r = 0.5 * (rs * rs + rp * rp)
    r = np.where(tir | ~np.isfinite(r), 1.0, r)
    return r, np.where(tir, 0.0, cos_t)


def smith_g1(alpha, w, m):
    """Smith's masking for isotropic GGX, 0 where m is not seen from w's side. w, m: (..., 3)."""
    z = np.abs(w[..., 2])
    s = np.sqrt(w[..., 2] ** 2 + alpha * alpha * (w[..., 0] ** 2 + w[..., 1] ** 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.where(z > 0.0, 2.0 * z / (z + s), 0.0)
    return np.where((w * m).sum(axis=-1) * w[..., 2] > 0.0, g, 0.0)


def visible_normals(alpha, w, u1, u2):
    """Heitz (2018) visible-normal sampling for isotropic GGX, vectorised over w (..., 3) and the
    unit-square points u1, u2 (broadcast against w's leading axes)."""
    v = np.stack([alpha * w[..., 0], alpha * w[..., 1], w[..., 2]], axis=-1)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    lensq = v[..., 0] ** 2 + v[..., 1] ** 2
    safe = np.sqrt(np.where(lensq > 0.0, lensq, 1.0))
    t1 = np.where((lensq > 0.0)[..., None],
                  np.stack([-v[..., 1] / safe, v[..., 0] / safe, np.zeros_like(safe)], axis=-1),
                  np.array([1.0, 0.0, 0.0]))
    t2 = np.cross(v, t1)
    r = np.sqrt(u1)
    phi = 2.0 * np.pi * u2
    p1 = r * np.cos(phi)
    p2 = r * np.sin(phi)
    h = 0.5 * (1.0 + v[..., 2])
    p2 = (1.0 - h) * np.sqrt(np.maximum(0.0, 1.0 - p1 * p1)) + h * p2
    pn = np.sqrt(np.maximum(0.0, 1.0 - p1 * p1 - p2 * p2))
    n = p1[..., None] * t1 + p2[..., None] * t2 + pn[..., None] * v
    m = np.stack([alpha * n[..., 0], alpha * n[..., 1], np.maximum(0.0, n[..., 2])], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def _square_rule(nodes: int):
    """Gauss-Legendre nodes and weights of a product rule on the unit square, flattened."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    u1, u2 = np.meshgrid(x, x, indexing="ij")
    w1, w2 = np.meshgrid(w, w, indexing="ij")
    return u1.ravel(), u2.ravel(), (w1 * w2).ravel()


def _views(mu):
    mu = np.maximum(MU_FLOOR, np.asarray(mu, dtype=np.float64))
    return np.stack([np.sqrt(1.0 - mu * mu), np.zeros_like(mu), mu], axis=-1)


def transmittance(eta: float, alpha: float, mu, nodes: int = 32) -> np.ndarray:
    """Fraction of light from outside at cosines `mu` that enters a GGX coat of relative index
    `eta` (inside over outside) and width `alpha`, unmasked (see the module's docstring)."""
    u1, u2, weight = _square_rule(nodes)
    w = _views(mu)[:, None, :]
    m = visible_normals(alpha, w, u1[None, :], u2[None, :])
    cos_wm = (w * m).sum(axis=-1)
    f, cos_t = fresnel(cos_wm, 1.0 / eta)
    # Refraction into the coat about m: -w / eta + (cos_wm / eta - cos_t) m.
    wt = -w / eta + (cos_wm / eta - cos_t)[..., None] * m
    g = smith_g1(alpha, wt, m)
    value = np.where((wt[..., 2] < 0.0) & (cos_wm > 0.0), (1.0 - f) * g, 0.0)
    return value @ weight


def reflectance(eta_incident_over_far: float, alpha: float, mu, nodes: int = 64) -> np.ndarray:
    """Albedo of the GGX reflection (single scattering, unmasked) at cosines `mu` for a relative
    index `eta_incident_over_far` (> 1 from inside, with total internal reflection)."""
    u1, u2, weight = _square_rule(nodes)
    w = _views(mu)[:, None, :]
    m = visible_normals(alpha, w, u1[None, :], u2[None, :])
    cos_wm = (w * m).sum(axis=-1)
    f, _ = fresnel(cos_wm, eta_incident_over_far)
    wr = 2.0 * cos_wm[..., None] * m - w
    g = smith_g1(alpha, wr, m)
    value = np.where((wr[..., 2] > 0.0) & (cos_wm > 0.0), f * g, 0.0)
    return value @ weight


def internal_reflectance(eta: float, alpha: float, mu_nodes: int = 32, nodes: int = 64,
                         mitsuba_average: bool = False) -> float:
    """Cosine-weighted hemispherical average of the coat's reflection seen from inside:
    2 * integral over [0, 1] of R(mu) mu dmu, by Gauss-Legendre on each side of the critical
    cosine sqrt(1 - 1 / eta^2), where a smooth coat's R jumps to 1 (total internal reflection):
    one rule across the jump converges slowly at small alpha.

    `mitsuba_average`: Mitsuba 3's rule instead, twice the mean of R(mu) mu over 64 equally
    spaced cosines (ends included), 1.3% lower at ior 1.5 and alpha 0.1: for comparisons."""
    if mitsuba_average:
        mu = np.maximum(MU_FLOOR, np.linspace(0.0, 1.0, 64))
        return float(2.0 * np.mean(reflectance(eta, alpha, mu, 128) * mu))
    x, w = np.polynomial.legendre.leggauss(mu_nodes)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    critical = np.sqrt(max(0.0, 1.0 - 1.0 / (eta * eta)))
    total = 0.0
    for lo, hi in ((0.0, critical), (critical, 1.0)):
        if hi > lo:
            mu = lo + (hi - lo) * x
            total += (hi - lo) * np.sum(w * mu * reflectance(eta, alpha, mu, nodes))
    return float(2.0 * total)


def smooth_internal_reflectance(eta: float, nodes: int = 64) -> float:
    """A smooth coat's internal reflectance, exactly: light from inside that escapes is, by
    reciprocity, what enters from outside compressed into 1 / eta^2 of the solid angle, so
    R_in = 1 - (1 - R_out) / eta^2, where R_out, the cosine-weighted average of the Fresnel
    reflectance from outside, has a smooth integrand (no total internal reflection)."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    mu, w = 0.5 * (x + 1.0), 0.5 * w
    r_out = 2.0 * np.sum(w * mu * fresnel(mu, 1.0 / eta)[0])
    return float(1.0 - (1.0 - r_out) / (eta * eta))


def build(mitsuba_average: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(transmittance[ior, roughness, cosine], internal_reflectance[ior, roughness]) on the grids;
    `mitsuba_average`: the internal reflectance by Mitsuba 3's rule (see internal_reflectance)."""
    t = np.empty((len(IORS), len(ROUGHNESSES), len(COSINES)))
    r = np.empty((len(IORS), len(ROUGHNESSES)))
    for i, eta in enumerate(IORS):
        for j, rough in enumerate(ROUGHNESSES):
            alpha = max(ALPHA_FLOOR, rough * rough)
            t[i, j] = transmittance(eta, alpha, COSINES)
            r[i, j] = internal_reflectance(eta, alpha, mitsuba_average=mitsuba_average) if eta > 1.0 else 0.0
    return t, r


def _rows(a: np.ndarray) -> str:
    flat = [f"{x:.9g}" for x in a.ravel()]
    return "\n".join("    " + ", ".join(flat[k:k + 8]) + "," for k in range(0, len(flat), 8))


def write(path: Path, mitsuba_average: bool = False) -> None:
    t, r = build(mitsuba_average)
    rule = "Mitsuba 3's mean over 64 cosines" if mitsuba_average else "Gauss-Legendre"
    smooth = np.array([smooth_internal_reflectance(eta) for eta in SMOOTH_IORS])
    path.write_text(
        '"""Generated by `python -m renderer.materials.coat_tables` (see that module): do not edit.\n\n'
        "TRANSMITTANCE[ior, roughness, cosine] and INTERNAL_REFLECTANCE[ior, roughness] of a GGX\n"
        "dielectric coat, on the grids IOR_*, ROUGHNESS_* and COSINE_* (first value, step, count);\n"
        'SMOOTH_INTERNAL_REFLECTANCE[ior] of a smooth coat, on the grid SMOOTH_IOR_*.\n'
        f'The rough internal reflectance averaged over cosines by {rule}."""\n\n'
        "import numpy as np\n\n"
        f"IOR_FIRST, IOR_STEP, IOR_COUNT = {IOR_GRID!r}\n"
        f"ROUGHNESS_FIRST, ROUGHNESS_STEP, ROUGHNESS_COUNT = {ROUGHNESS_GRID!r}\n"
        f"COSINE_FIRST, COSINE_STEP, COSINE_COUNT = {COSINE_GRID!r}\n\n"
        "TRANSMITTANCE = np.array([\n" + _rows(t) + "\n]).reshape(IOR_COUNT, ROUGHNESS_COUNT, COSINE_COUNT)\n\n"
        "INTERNAL_REFLECTANCE = np.array([\n" + _rows(r) + "\n]).reshape(IOR_COUNT, ROUGHNESS_COUNT)\n\n"
        f"SMOOTH_IOR_FIRST, SMOOTH_IOR_STEP, SMOOTH_IOR_COUNT = {SMOOTH_IOR_GRID!r}\n\n"
        "SMOOTH_INTERNAL_REFLECTANCE = np.array([\n" + _rows(smooth) + "\n])\n"
    )


if __name__ == "__main__":
    import argparse

    parser = argparse.ArgumentParser(description="Regenerate coat_table_data.py.")
    parser.add_argument("--mitsuba-average", action="store_true",
                        help="average the rough internal reflectance as Mitsuba 3 does (its images, not the exact integral)")
    write(Path(__file__).with_name("coat_table_data.py"), parser.parse_args().mitsuba_average)
