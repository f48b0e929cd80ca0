"""Media whose density varies: a 3-D grid of values or Perlin noise, and how rays cross them.

A varying medium is a MEDIUM primitive like a constant one (media.py: its boundary, its serial
number, its phase function's material row); its row's `field` column points at its density
field, laid out in `bnd_f` after the boundary rows so that the trees' walks need no new table:

- a header of FIELD_F (three rows of PRIM_WIDTH values): the kind (FIELD_GRID, FIELD_NOISE), the
  density scale, the grid's box and cell counts, the coarse majorant grid's cell counts, the map
  from the tree's space into the medium's own (the shape's space, where `bounds` is given), the
  noise's parameters, and the first rows of the data;
- the data, PRIM_WIDTH values a row: a grid's values in C order of (nx, ny, nz), then its
  majorant cells, each the largest density (scale included) any point of the cell can have under
  either interpolation; or a noise field's Perlin lattice (3 x 256 permutation entries, 256 x 3
  gradient components), whose one majorant is an analytic bound of the noise.

Free flight is delta tracking (Woodcock) and the transmittance of a shadow ray is ratio tracking,
both against the majorant of the cell of the coarse grid the ray is in, cell by cell along a 3-D
DDA: an empty cell (majorant 0) is crossed at no cost, and a thin one with few tentative
collisions. Both are unbiased for any majorant at least the density; a looser one costs only
time. (This is the null-scattering formulation with a piecewise-constant majorant, as pbrt-v4's
`DDAMajorantIterator`, with the null events' weights folded in: delta tracking accepts a real
collision with probability density / majorant, ratio tracking multiplies 1 - density / majorant,
and plays Russian roulette once the product is small.)

Random numbers come from the path's key at dimensions `base + k`, k counting the draws, `base`
mixed from (bounce, instance, medium) as a constant medium's, and the shadow ray's from a
different salt, so neither depends on the threads or on the order the trees are visited in.
"""

import math

import numpy as np

from . import target
from .columns import Column, Layout
from .numerics.rng import uniform
from .target import uint64

# Same width as prims_f and bnd_f (shapes.PRIM_WIDTH), written here to stay below the shapes.
ROW = 16
FIELD_GRID = 0
FIELD_NOISE = 1
INTERP_NEAREST = 0
INTERP_TRILINEAR = 1
# Values of the grid per majorant cell along each side: coarse enough that the majorant grid is
# small (64^3 values -> 8^3 cells), fine enough that a cloud's empty margins are cells of their own.
MAJORANT_BLOCK = 8
# A walk never takes more tentative collisions than this (a majorant far above the density in a
# long segment); past it, free flight says the ray passes and ratio tracking stops multiplying.
# Reached only by a majorant 10^4 times too loose over a whole segment.
MAX_STEPS = 1 << 20
# Ratio tracking plays Russian roulette once its estimate falls below ROULETTE_BELOW, keeping
# the ray with probability ROULETTE_KEEP (and dividing by it), as pbrt-v4 does (0.05, 0.25).
ROULETTE_BELOW = 0.05
ROULETTE_KEEP = 0.25
# Perlin noise is in [-sqrt 3, sqrt 3]: each corner's gradient is a unit vector and its offset at
# most sqrt 3 long, and the noise blends them with weights that sum to 1.
PERLIN_BOUND = math.sqrt(3.0)

FIELD_F = Layout("bnd_f field", "float64", [
    Column("kind", 1, "FIELD_GRID or FIELD_NOISE"),
    Column("interpolation", 1, "grid: INTERP_NEAREST or INTERP_TRILINEAR"),
    Column("scale", 1, "density per unit value of the grid or the noise"),
    Column("lo", 3, "grid: the box's min corner, in the medium's space"),
    Column("hi", 3, "grid: the box's max corner"),
    Column("cells", 3, "grid: values along x, y and z"),
    Column("blocks", 3, "grid: majorant cells along x, y and z (1, 1, 1 for noise)"),
    Column("majorant", 1, "the largest density anywhere (scale included): a noise field's one majorant"),
    Column("medium_from_tree", 12, "3x4 row-major map from the tree's space to the medium's"),
    Column("noise_scale", 1, "noise: spatial frequency"),
    Column("noise_form", 1, "noise: textures.NOISE_PLAIN, NOISE_TURBULENCE or NOISE_MARBLE"),
    Column("octaves", 1, "noise: octaves of turbulence and marble"),
    Column("data", 1, "bnd_f row of the first value (grid) or of the Perlin lattice (noise)"),
    Column("majorants", 1, "grid: bnd_f row of the first majorant cell"),
], 3 * ROW)
(F_KIND, F_INTERP, F_SCALE, F_LO, F_HI, F_CELLS, F_BLOCKS, F_MAJORANT, F_XFORM, F_NOISE_SCALE, F_NOISE_FORM, F_OCTAVES,
 F_DATA, F_MAJORANTS) = FIELD_F.offsets("kind", "interpolation", "scale", "lo", "hi", "cells", "blocks", "majorant",
                                        "medium_from_tree", "noise_scale", "noise_form", "octaves", "data", "majorants")
HEADER_ROWS = FIELD_F.width // ROW

# The noise forms' codes, as textures.NOISE_FORMS (kept equal by a test; not imported: the
# textures module sits beside this one, and the field needs only the three numbers).
NOISE_PLAIN, NOISE_TURBULENCE, NOISE_MARBLE = 0, 1, 2


# --- flattening (numpy) -----------------------------------------------------------------------


def _rows(values: np.ndarray) -> np.ndarray:
    """`values` (1-D) padded with zeros to whole rows of ROW."""
    flat = np.ascontiguousarray(values, np.float64).ravel()
    rows = -(-len(flat) // ROW)
    out = np.zeros(rows * ROW)
    out[:len(flat)] = flat
    return out.reshape(rows, ROW)


def grid_majorants(values: np.ndarray, block: int = MAJORANT_BLOCK) -> np.ndarray:
    """The majorant cells of a grid (nx, ny, nz): cell c holds the largest value among the grid's
    values of its block and their 26 neighbours, so that it bounds the density at every point of
    the cell under nearest and under trilinear interpolation (which blends the values of the
    cell centres around a point, at most one value beyond the block)."""
    v = np.asarray(values, np.float64)
    padded = np.pad(v, 1, mode="edge")
    nx, ny, nz = v.shape
    grown = np.zeros_like(v)
    for dx in range(3):
        for dy in range(3):
            for dz in range(3):
                np.maximum(grown, padded[dx:dx + nx, dy:dy + ny, dz:dz + nz], out=grown)
    bx, by, bz = (-(-n // block) for n in v.shape)
    full = np.zeros((bx * block, by * block, bz * block))
    full[:nx, :ny, :nz] = grown
    return full.reshape(bx, block, by, block, bz, block).max(axis=(1, 3, 5))


def noise_bound(form: str, octaves: int) -> float:
    """The largest value the noise texture's field of `form` can take: plain 0.5 (1 + noise),
    turbulence |sum of octaves 2^-k noise|, marble 0.5 (1 + sin)."""
    if form == "plain":
        return 0.5 * (1.0 + PERLIN_BOUND)
    if form == "marble":
        return 1.0
    return PERLIN_BOUND * (2.0 - 2.0 ** (1 - octaves))


def field_rows(model, grid, medium_from_tree, first_row: int, perlin_tables) -> np.ndarray:
    """The bnd_f rows of a varying medium's field (header then data), placed from row `first_row`:
    `model` a scenefmt GridMedium (with its checked array `grid`) or NoiseMedium,
    `medium_from_tree` the 3x4 map from the tree's space to the shape's, `perlin_tables(seed)`
    the noise texture's lattice."""
    xform = np.asarray(medium_from_tree, np.float64).reshape(12)
    data_row = first_row + HEADER_ROWS
    # Slightly above the largest density, so that an interpolated value rounded up by an ulp
    # never exceeds its majorant (a ratio would then leave [0, 1]).
    lift = 1.0 + 1e-9
    if model.type == "grid":
        values = np.ascontiguousarray(grid, np.float64)
        majorants = grid_majorants(values) * model.density * lift
        data = _rows(values)
        header = FIELD_F.row(
            kind=FIELD_GRID, interpolation=INTERP_TRILINEAR if model.interpolation == "trilinear" else INTERP_NEAREST,
            scale=model.density, lo=list(model.bounds[0]), hi=list(model.bounds[1]), cells=list(values.shape),
            blocks=list(majorants.shape), majorant=float(majorants.max()), medium_from_tree=xform, data=data_row,
            majorants=data_row + len(data))
        body = np.concatenate([data, _rows(majorants)])
    else:
        from .textures import NOISE_FORMS

        perm, vec = perlin_tables(model.seed)
        lattice = np.concatenate([perm.astype(np.float64).ravel(), vec.ravel()])
        header = FIELD_F.row(
            kind=FIELD_NOISE, scale=model.density, blocks=[1, 1, 1],
            majorant=noise_bound(model.form, model.octaves) * model.density * lift, medium_from_tree=xform,
            noise_scale=model.scale, noise_form=NOISE_FORMS[model.form], octaves=model.octaves, data=data_row,
            majorants=data_row)
        body = _rows(lattice)
    return np.concatenate([np.array(header, np.float64).reshape(HEADER_ROWS, ROW), body])


def field_bytes(model, grid) -> int:
    """Bytes a varying medium's field takes in bnd_f (for the memory estimate's check)."""
    if model.type == "grid":
        cells = int(np.prod(np.shape(grid)))
        blocks = int(np.prod([-(-n // MAJORANT_BLOCK) for n in np.shape(grid)]))
        return 8 * (cells + blocks) + FIELD_F.width * 8
    return 8 * (3 * 256 + 256 * 3) + FIELD_F.width * 8


# --- the kernels ------------------------------------------------------------------------------


@target.device
def at(bnd_f, row, k):
    """Value k of the values laid out from bnd_f row `row` on, ROW a row."""
    return bnd_f[row + k // ROW, k % ROW]


@target.device
def head(bnd_f, h, k):
    """Column k of the field header at bnd_f row h."""
    return bnd_f[h + k // ROW, k % ROW]


@target.device
def to_medium(bnd_f, h, p, w):
    """Point (w = 1) or vector (w = 0) p, from the tree's space into the medium's."""
    return (head(bnd_f, h, F_XFORM + 0) * p[0] + head(bnd_f, h, F_XFORM + 1) * p[1] + head(bnd_f, h, F_XFORM + 2) * p[2]
            + w * head(bnd_f, h, F_XFORM + 3),
            head(bnd_f, h, F_XFORM + 4) * p[0] + head(bnd_f, h, F_XFORM + 5) * p[1] + head(bnd_f, h, F_XFORM + 6) * p[2]
            + w * head(bnd_f, h, F_XFORM + 7),
            head(bnd_f, h, F_XFORM + 8) * p[0] + head(bnd_f, h, F_XFORM + 9) * p[1] + head(bnd_f, h, F_XFORM + 10) * p[2]
            + w * head(bnd_f, h, F_XFORM + 11))


@target.device
def grid_value(bnd_f, data, nx, ny, nz, i, j, k):
    """The grid's value [i, j, k], its indices clamped into the grid (edge values hold out)."""
    i = min(max(i, 0), nx - 1)
    j = min(max(j, 0), ny - 1)
    k = min(max(k, 0), nz - 1)
    return at(bnd_f, data, (i * ny + j) * nz + k)


@target.device
def grid_density(bnd_f, h, x, y, z):
    """The grid's density at (x, y, z) of the medium's space, scale included; 0 outside its box."""
    nx, ny, nz = int(head(bnd_f, h, F_CELLS)), int(head(bnd_f, h, F_CELLS + 1)), int(head(bnd_f, h, F_CELLS + 2))
    gx = (x - head(bnd_f, h, F_LO)) / (head(bnd_f, h, F_HI) - head(bnd_f, h, F_LO)) * nx
    gy = (y - head(bnd_f, h, F_LO + 1)) / (head(bnd_f, h, F_HI + 1) - head(bnd_f, h, F_LO + 1)) * ny
    gz = (z - head(bnd_f, h, F_LO + 2)) / (head(bnd_f, h, F_HI + 2) - head(bnd_f, h, F_LO + 2)) * nz
    # Written so that NaN (never expected) also reads as outside.
    if not (0.0 <= gx <= nx and 0.0 <= gy <= ny and 0.0 <= gz <= nz):
        return 0.0
    data = int(head(bnd_f, h, F_DATA))
    scale = head(bnd_f, h, F_SCALE)
    if head(bnd_f, h, F_INTERP) == INTERP_NEAREST:
        return scale * grid_value(bnd_f, data, nx, ny, nz, int(gx), int(gy), int(gz))
    # Values sit at cell centres: blend the eight around the point.
    fx, fy, fz = gx - 0.5, gy - 0.5, gz - 0.5
    i, j, k = int(math.floor(fx)), int(math.floor(fy)), int(math.floor(fz))
    tx, ty, tz = fx - i, fy - j, fz - k
    c00 = grid_value(bnd_f, data, nx, ny, nz, i, j, k) * (1.0 - tz) + grid_value(bnd_f, data, nx, ny, nz, i, j, k + 1) * tz
    c01 = grid_value(bnd_f, data, nx, ny, nz, i, j + 1, k) * (1.0 - tz) + grid_value(bnd_f, data, nx, ny, nz, i, j + 1, k + 1) * tz
    c10 = grid_value(bnd_f, data, nx, ny, nz, i + 1, j, k) * (1.0 - tz) + grid_value(bnd_f, data, nx, ny, nz, i + 1, j, k + 1) * tz
    c11 = (grid_value(bnd_f, data, nx, ny, nz, i + 1, j + 1, k) * (1.0 - tz)
           + grid_value(bnd_f, data, nx, ny, nz, i + 1, j + 1, k + 1) * tz)
    c0 = c00 * (1.0 - ty) + c01 * ty
    c1 = c10 * (1.0 - ty) + c11 * ty
    return scale * (c0 * (1.0 - tx) + c1 * tx)


@target.device
def lattice_perlin(bnd_f, data, x, y, z):
    """textures.perlin on the lattice copied into bnd_f from row `data` (permutations, then gradients)."""
    fx, fy, fz = math.floor(x), math.floor(y), math.floor(z)
    u, v, w = x - fx, y - fy, z - fz
    i, j, k = int(fx), int(fy), int(fz)
    uu, vv, ww = u * u * (3.0 - 2.0 * u), v * v * (3.0 - 2.0 * v), w * w * (3.0 - 2.0 * w)
    accum = 0.0
    for di in range(2):
        for dj in range(2):
            for dk in range(2):
                h = (int(at(bnd_f, data, (i + di) & 255)) ^ int(at(bnd_f, data, 256 + ((j + dj) & 255)))
                     ^ int(at(bnd_f, data, 512 + ((k + dk) & 255))))
                g = 768 + 3 * h
                dot = (at(bnd_f, data, g) * (u - di) + at(bnd_f, data, g + 1) * (v - dj)
                       + at(bnd_f, data, g + 2) * (w - dk))
                accum += ((di * uu + (1 - di) * (1.0 - uu)) * (dj * vv + (1 - dj) * (1.0 - vv))
                          * (dk * ww + (1 - dk) * (1.0 - ww)) * dot)
    return accum


@target.device
def lattice_turbulence(bnd_f, data, x, y, z, octaves):
    accum = 0.0
    weight = 1.0
    for _ in range(octaves):
        accum += weight * lattice_perlin(bnd_f, data, x, y, z)
        weight *= 0.5
        x, y, z = x * 2.0, y * 2.0, z * 2.0
    return abs(accum)


@target.device
def noise_density(bnd_f, h, x, y, z):
    """The noise field's density at (x, y, z) of the medium's space: the noise texture's value
    there (textures.texture_value's three forms) times the scale, clamped to [0, majorant]."""
    data = int(head(bnd_f, h, F_DATA))
    s = head(bnd_f, h, F_NOISE_SCALE)
    form = int(head(bnd_f, h, F_NOISE_FORM))
    octaves = int(head(bnd_f, h, F_OCTAVES))
    if form == NOISE_PLAIN:
        value = 0.5 * (1.0 + lattice_perlin(bnd_f, data, s * x, s * y, s * z))
    elif form == NOISE_MARBLE:
        value = 0.5 * (1.0 + math.sin(s * z + 10.0 * lattice_turbulence(bnd_f, data, x, y, z, octaves)))
    else:
        value = lattice_turbulence(bnd_f, data, s * x, s * y, s * z, octaves)
    return min(max(value * head(bnd_f, h, F_SCALE), 0.0), head(bnd_f, h, F_MAJORANT))


@target.device
def field_density(bnd_f, h, p):
    """The density of the field with header row h at point p of the medium's space."""
    if head(bnd_f, h, F_KIND) == FIELD_GRID:
        return grid_density(bnd_f, h, p[0], p[1], p[2])
    return noise_density(bnd_f, h, p[0], p[1], p[2])


@target.device
def box_span(o, d, lo0, lo1, lo2, hi0, hi1, hi2, t0, t1):
    """The part of (t0, t1) where o + t d is inside the box; enter >= leave when none."""
    enter, leave = t0, t1
    for a in range(3):
        lo = lo0 if a == 0 else lo1 if a == 1 else lo2
        hi = hi0 if a == 0 else hi1 if a == 1 else hi2
        if d[a] == 0.0:
            if not (lo <= o[a] <= hi):
                return 1.0, 0.0
            continue
        ta, tb = (lo - o[a]) / d[a], (hi - o[a]) / d[a]
        if ta > tb:
            ta, tb = tb, ta
        enter = max(enter, ta)
        leave = min(leave, tb)
    return enter, leave


@target.device
def track(bnd_f, h, o_tree, d_tree, t0, t1, speed, key, base, ratio):
    """Delta tracking (ratio False) or ratio tracking (ratio True) of the field with header row h
    along the ray o_tree + t d_tree of the tree's space, for t in (t0, t1) (already clipped to
    the medium's boundary), `speed` = |d_tree|: densities are per unit length of the tree's
    space. Returns (t, transmittance): delta tracking's t is where the ray scatters (inf if it
    passes) and its transmittance 1; ratio tracking's t is inf and its transmittance an
    unbiased estimate of exp(-optical depth). Random numbers: uniform(key, base + k)."""
    o = to_medium(bnd_f, h, o_tree, 1.0)
    d = to_medium(bnd_f, h, d_tree, 0.0)
    tr = 1.0
    n = uint64(0)
    if head(bnd_f, h, F_KIND) == FIELD_GRID:
        bx, by, bz = int(head(bnd_f, h, F_BLOCKS)), int(head(bnd_f, h, F_BLOCKS + 1)), int(head(bnd_f, h, F_BLOCKS + 2))
        lo0, lo1, lo2 = head(bnd_f, h, F_LO), head(bnd_f, h, F_LO + 1), head(bnd_f, h, F_LO + 2)
        hi0, hi1, hi2 = head(bnd_f, h, F_HI), head(bnd_f, h, F_HI + 1), head(bnd_f, h, F_HI + 2)
        t, leave = box_span(o, d, lo0, lo1, lo2, hi0, hi1, hi2, t0, t1)
        if not t < leave:
            return math.inf, 1.0
        # The DDA over the majorant cells, in cell units: c(t) = (o + t d - lo) / (hi - lo) * blocks.
        sx, sy, sz = bx / (hi0 - lo0), by / (hi1 - lo1), bz / (hi2 - lo2)
        cx, cy, cz = (o[0] + t * d[0] - lo0) * sx, (o[1] + t * d[1] - lo1) * sy, (o[2] + t * d[2] - lo2) * sz
        dx, dy, dz = d[0] * sx, d[1] * sy, d[2] * sz
        ix, iy, iz = min(max(int(math.floor(cx)), 0), bx - 1), min(max(int(math.floor(cy)), 0), by - 1), min(max(int(math.floor(cz)), 0), bz - 1)
        # Where the ray crosses the next cell boundary along each axis, and the step between them.
        stx = 1 if dx > 0.0 else -1
        sty = 1 if dy > 0.0 else -1
        stz = 1 if dz > 0.0 else -1
        nxt_x = t + ((ix + (1 if dx > 0.0 else 0)) - cx) / dx if dx != 0.0 else math.inf
        nxt_y = t + ((iy + (1 if dy > 0.0 else 0)) - cy) / dy if dy != 0.0 else math.inf
        nxt_z = t + ((iz + (1 if dz > 0.0 else 0)) - cz) / dz if dz != 0.0 else math.inf
        del_x = abs(1.0 / dx) if dx != 0.0 else math.inf
        del_y = abs(1.0 / dy) if dy != 0.0 else math.inf
        del_z = abs(1.0 / dz) if dz != 0.0 else math.inf
        majorants = int(head(bnd_f, h, F_MAJORANTS))
        for _ in range(bx + by + bz + 3):
            exit_t = min(nxt_x, nxt_y, nxt_z, leave)
            mu = at(bnd_f, majorants, (ix * by + iy) * bz + iz)
            if mu > 0.0 and exit_t > t:
                hit, tr, n = cell_track(bnd_f, h, o, d, t, exit_t, mu * speed, mu, key, base, n, ratio, tr)
                if hit < math.inf:
                    return hit, 1.0
                if tr == 0.0:
                    return math.inf, 0.0
            if exit_t >= leave:
                break
            t = exit_t
            if nxt_x <= nxt_y and nxt_x <= nxt_z:
                ix += stx
                nxt_x += del_x
            elif nxt_y <= nxt_z:
                iy += sty
                nxt_y += del_y
            else:
                iz += stz
                nxt_z += del_z
            if ix < 0 or iy < 0 or iz < 0 or ix >= bx or iy >= by or iz >= bz:
                break
        return math.inf, tr
    mu = head(bnd_f, h, F_MAJORANT)
    if mu > 0.0 and t1 > t0:
        hit, tr, n = cell_track(bnd_f, h, o, d, t0, t1, mu * speed, mu, key, base, n, ratio, tr)
        if hit < math.inf:
            return hit, 1.0
    return math.inf, tr


@target.device
def cell_track(bnd_f, h, o, d, t, t_end, rate, mu, key, base, n, ratio, tr):
    """Tracking through one stretch (t, t_end) of constant majorant mu (rate = mu x speed per
    unit t), o and d in the medium's space: tentative collisions at exponential steps; delta
    tracking returns the first that is real (probability density / mu), ratio tracking
    multiplies tr by 1 - density / mu at each. Returns (hit t or inf, tr, draws so far)."""
    while n < uint64(MAX_STEPS):
        u = uniform(key, base + n)
        n += uint64(1)
        # -ln(1 - u) with u in [0, 1): finite, never log(0).
        t -= math.log1p(-u) / rate
        if not t < t_end:
            return math.inf, tr, n
        p = (o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2])
        sigma = field_density(bnd_f, h, p)
        if ratio:
            tr *= max(0.0, 1.0 - sigma / mu)
            if tr == 0.0:
                return math.inf, 0.0, n
            if tr < ROULETTE_BELOW:
                # Russian roulette, unbiased: a shadow ray that carries little through a thick
                # medium stops early most of the time rather than tracking to its far side.
                v = uniform(key, base + n)
                n += uint64(1)
                if v >= ROULETTE_KEEP:
                    return math.inf, 0.0, n
                tr /= ROULETTE_KEEP
        else:
            v = uniform(key, base + n)
            n += uint64(1)
            if v * mu < sigma:
                return t, tr, n
    return math.inf, tr, n
