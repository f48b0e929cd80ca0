"""Lights: the table of emitters, its flattening, and sampling a point on one from a shading point.

Every primitive whose material is a diffuse light is a light, once per instance that places its
tree: a row of `light_i` names the instance and the primitive. A light is chosen in proportion
to its power (its area in the world times the luminance of its mean emission) by a binary
search of the cumulative table `light_f.cdf`, so a scene of thousands of emitters costs one
shadow ray per vertex, not thousands. Points are sampled in the tree's own space and carried
into the world by the instance's map:

- spheres seen from outside: a direction uniform in the cone they subtend (pdf in solid angle,
  which a similarity preserves); from inside, or under a map that is not a similarity (an
  ellipsoid), a point uniform on the surface;
- quads, triangles, disks and boxes: a point uniform on the surface, whose density per world
  area is the tree-space density times the map's area ratio at that normal.

Emission is two-sided (the books' diffuse light), so the conversion to solid angle takes the
absolute cosine at the light. `light_pdf` gives the density the sampler would have given a
direction that BSDF sampling found, for the multiple-importance weights of the integrator.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .columns import Column, Layout
from .kernels.cdf import pmf_and_cdf, search_cdf
from .kernels.traverse import INST_OBJECT_FROM_WORLD, INST_ROOT, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT, tree_prims
from .kernels.vec import cross, dot, madd, neg, scale, sub, unit, xform_normal, xform_point
from .materials import DIFFUSE_LIGHT, MAT_KIND, MAT_READS_UV, MAT_TEXTURE
from .shapes import BOX, DISK, MESH_TRIANGLE, MOVING_SPHERE, PRIM_KIND, PRIM_MATERIAL, QUAD, SPHERE, TRIANGLE
from .shapes.boxes import BOX_HI, BOX_LO
from .shapes.dispatch import surface
from .shapes.meshes import TRI_VERTEX
from .shapes.planar import PLANAR_ALPHA, PLANAR_BETA, PLANAR_CORNER, PLANAR_NORMAL
from .shapes.spheres import SPHERE_RADIUS, sphere_center
from .textures import texture_value

# How a light's points are drawn.
LIGHT_AREA = 0  # uniform on the surface
LIGHT_CONE = 1  # a sphere under a similarity: uniform in the cone it subtends where that exists
LIGHT_RECTANGLE = 2  # a rectangular quad under a similarity: uniform in the solid angle it subtends

LIGHT_I = Layout("light_i", "int32", [
    Column("instance", 1, "row of inst_i that places the light's tree"),
    Column("primitive", 1, "row of prims_i of the emitting primitive"),
    Column("strategy", 1, "LIGHT_AREA, LIGHT_CONE or LIGHT_RECTANGLE"),
])
LIGHT_F = Layout("light_f", "float64", [
    Column("cdf", 1, "probability of choosing this light or one before it (the last row is 1)"),
    Column("pmf", 1, "probability of choosing this light: its share of the lights' power"),
    Column("area", 1, "area in the tree's space (0 for a sphere, whose area moves with nothing)"),
    Column("edge_u", 3, "quad, triangle, disk, mesh triangle: the first edge (a disk's first radius), in the tree's space"),
    Column("edge_v", 3, "the second edge"),
    Column("corner", 3, "mesh triangle: its first corner (other kinds read theirs from prims_f)"),
])
LIGHT_INSTANCE, LIGHT_PRIMITIVE, LIGHT_STRATEGY = LIGHT_I.offsets("instance", "primitive", "strategy")
LIGHT_CDF, LIGHT_PMF, LIGHT_AREA_COLUMN, LIGHT_EDGE_U, LIGHT_EDGE_V, LIGHT_CORNER = LIGHT_F.offsets(
    "cdf", "pmf", "area", "edge_u", "edge_v", "corner")

# Below this squared sine of the cone's half-angle, 1 - cos is computed from its series:
# the difference itself would have lost most of its digits.
SMALL_CONE = 1e-4
# A rectangle subtending less than this solid angle is sampled by area: its spherical sampling
# would lose digits to the arc cosines, and area sampling is nearly uniform in angle there anyway.
SMALL_RECTANGLE = 1e-3
# Farther from its centre than this many times the sum of its edges' |x| + |y| + |z|, a rectangle
# is sampled by area too: the spherical rectangle's four arc cosines and dozen roots buy little there. On the
# Cornell box they were 45% of a sample's time and changed its error by under 2%, while sampling
# all by area, the ceiling beside the lamp included, had 1.4 times the variance.
FAR_RECTANGLE = 0.5
# Lights met at less than this |cosine| are skipped: they send next to nothing, and the solid
# angle density would be huge and inexact.
GRAZING = 1e-10


# --- flattening -------------------------------------------------------------------------------


def _edges(prims_f: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges u, v of planar rows, recovered from their (alpha, beta) dual vectors A and B:
    u is perpendicular to B and the normal with A . u = 1, v perpendicular to A and the normal
    with B . v = 1 (planar.py)."""
    a = prims_f[rows, PLANAR_ALPHA:PLANAR_ALPHA + 3]
    b = prims_f[rows, PLANAR_BETA:PLANAR_BETA + 3]
    n = prims_f[rows, PLANAR_NORMAL:PLANAR_NORMAL + 3]
    u = np.cross(b, n)
    u /= np.einsum("ij,ij->i", u, a)[:, None]
    v = np.cross(n, a)
    v /= np.einsum("ij,ij->i", v, b)[:, None]
    return u, v


def _tree_area(kind: np.ndarray, prims_f: np.ndarray, rows: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Surface area in the tree's space of each row (spheres: 0, see LIGHT_F.area)."""
    para = np.linalg.norm(np.cross(u, v), axis=1)
    area = np.zeros(len(rows))
    area[kind == QUAD] = para[kind == QUAD]
    triangles = (kind == TRIANGLE) | (kind == MESH_TRIANGLE)
    area[triangles] = 0.5 * para[triangles]
    area[kind == DISK] = math.pi * para[kind == DISK]
    box = kind == BOX
    size = prims_f[rows[box], BOX_HI:BOX_HI + 3] - prims_f[rows[box], BOX_LO:BOX_LO + 3]
    area[box] = 2.0 * (size[:, 0] * size[:, 1] + size[:, 1] * size[:, 2] + size[:, 2] * size[:, 0])
    return area


def no_lights(prims: int, instances: int) -> dict[str, np.ndarray]:
    """The light tables of a scene without emitters."""
    return {"light_i": LIGHT_I.array(0), "light_f": LIGHT_F.array(0), "inst_light": np.zeros(instances, np.int32),
            "prim_light": np.full(prims, -1, np.int32)}


def flatten(flat) -> tuple[dict[str, np.ndarray], float]:
    """The light tables of flat scene `flat`: `light_i`, `light_f`, `inst_light` (each
    instance's first light row) and `prim_light` (an emitting primitive's rank among the
    emitters of its tree, -1 for others): the light of a hit is inst_light + prim_light.
    Power-proportional choice needs the mean emission, which `_powers` measures with the
    kernels' own sampling; the lights' total power (world area times luminance) comes back
    too, for weighing them against an environment map."""
    emitting = flat.mat_i[flat.prims_i[:, PRIM_MATERIAL], MAT_KIND] == DIFFUSE_LIGHT
    if not emitting.any():
        return no_lights(len(flat.prims_i), len(flat.inst_i)), 0.0
    inst_light = np.zeros(len(flat.inst_i), np.int32)
    prim_light = np.full(len(flat.prims_i), -1, np.int32)
    instances, prims = [], []
    rows = 0
    emitters_of_root: dict[int, np.ndarray] = {}
    for k, root in enumerate(flat.inst_i[:, INST_ROOT]):
        if root not in emitters_of_root:
            # A tree's rows: one run of surfaces and, with a mesh, one of its triangles.
            in_tree = tree_prims(flat.nodes_i, root)
            emitters_of_root[root] = in_tree[emitting[in_tree]]
            prim_light[emitters_of_root[root]] = np.arange(len(emitters_of_root[root]))
        found = emitters_of_root[root]
        inst_light[k] = rows
        prims.append(found)
        instances.append(np.full(len(found), k, np.int64))
        rows += len(found)
    prim = np.concatenate(prims) if prims else np.zeros(0, np.int64)
    inst = np.concatenate(instances) if instances else np.zeros(0, np.int64)
    kind = flat.prims_i[prim, PRIM_KIND]
    lin = flat.inst_f[inst, INST_WORLD_FROM_OBJECT:INST_WORLD_FROM_OBJECT + 12].reshape(-1, 3, 4)[:, :, :3]
    gram = np.einsum("kij,kil->kjl", lin, lin)
    scale2 = np.trace(gram, axis1=1, axis2=2) / 3.0
    similar = np.all(np.abs(gram - scale2[:, None, None] * np.eye(3)) <= 1e-9 * scale2[:, None, None], axis=(1, 2))
    sphere = (kind == SPHERE) | (kind == MOVING_SPHERE)
    planar = (kind == QUAD) | (kind == TRIANGLE) | (kind == DISK)
    u, v, corner = np.zeros((len(prim), 3)), np.zeros((len(prim), 3)), np.zeros((len(prim), 3))
    u[planar], v[planar] = _edges(flat.prims_f, prim[planar])
    square = np.abs(np.einsum("ij,ij->i", u, v)) <= 1e-9 * np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1)
    strategy = np.where(sphere & similar, LIGHT_CONE, np.where((kind == QUAD) & square & similar, LIGHT_RECTANGLE, LIGHT_AREA))
    mesh = kind == MESH_TRIANGLE
    if mesh.any():
        corners = flat.verts_f[flat.tri_i[prim[mesh] - len(flat.prims_f), TRI_VERTEX:TRI_VERTEX + 3]]  # (M, 3 corners, 3)
        corner[mesh] = corners[:, 0]
        u[mesh], v[mesh] = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    area = _tree_area(kind, flat.prims_f, prim, u, v)
    light_i = LIGHT_I.array(len(prim), instance=inst, primitive=prim, strategy=strategy)
    light_f = LIGHT_F.array(len(prim), area=area, edge_u=u, edge_v=v, corner=corner)
    power = _powers(flat, light_i, light_f)
    total = float(power.sum())
    if not total > 0.0:  # no light sends anything: nothing to sample
        return no_lights(len(flat.prims_i), len(flat.inst_i)), 0.0
    light_f[:, LIGHT_PMF], light_f[:, LIGHT_CDF] = pmf_and_cdf(power, total)
    return {"light_i": light_i, "light_f": light_f, "inst_light": inst_light, "prim_light": prim_light}, total


def _powers(flat, light_i: np.ndarray, light_f: np.ndarray) -> np.ndarray:
    """Each light's power up to a common factor: its world area times the luminance of its
    emission averaged over 16 stratified points of its surface."""
    out = np.zeros(len(light_i))
    light_powers(flat._replace(light_i=light_i, light_f=light_f), out)
    return out


# --- the kernels ------------------------------------------------------------------------------


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def luminance(c):
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def frame_of(w):
    """Two unit vectors completing unit w to an orthonormal frame (Duff et al. 2017)."""
    sign = math.copysign(1.0, w[2])
    a = -1.0 / (sign + w[2])
    b = w[0] * w[1] * a
    return (1.0 + sign * w[0] * w[0] * a, sign * b, -sign * w[0]), (b, sign + w[1] * w[1] * a, -w[1])


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def uniform_sphere(u1, u2):
    z = 1.0 - 2.0 * u1
    r = math.sqrt(max(0.0, 1.0 - z * z))
    phi = 2.0 * math.pi * u2
    return (r * math.cos(phi), r * math.sin(phi), z)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def cone_one_minus_cos(sin2_max):
    """1 - cos(theta_max) of a cone whose half-angle has squared sine sin2_max, without cancellation."""
    if sin2_max < SMALL_CONE:
        return 0.5 * sin2_max + 0.125 * sin2_max * sin2_max
    return 1.0 - math.sqrt(max(0.0, 1.0 - sin2_max))


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def sample_cone(p, c, r, dist2, u1, u2):
    """A point and outward normal on the sphere (c, r) seen from p outside it, whose direction from
    p is uniform in the cone the sphere subtends; and that cone's solid angle density.

    The direction makes angle theta with the axis, cos theta uniform in [cos theta_max, 1]; the
    point is where it first meets the sphere, found from the angle alpha at the centre between
    the axis and the point (law of sines in the triangle p, c, point) rather than by intersecting
    a ray that may graze the sphere.
    """
    sin2_max = r * r / dist2
    one_minus = cone_one_minus_cos(sin2_max)
    # 1 - cos(theta) uniform in [0, 1 - cos(theta_max)], kept as a difference for small cones.
    om = u1 * one_minus
    cos_t = 1.0 - om
    sin2_t = om * (2.0 - om)
    sin_max = math.sqrt(sin2_max)
    cos_a = sin2_t / sin_max + cos_t * math.sqrt(max(0.0, 1.0 - sin2_t / sin2_max))
    cos_a = min(1.0, max(-1.0, cos_a))
    sin_a = math.sqrt(max(0.0, 1.0 - cos_a * cos_a))
    phi = 2.0 * math.pi * u2
    axis = scale(sub(p, c), 1.0 / math.sqrt(dist2))  # from the centre towards p
    e1, e2 = frame_of(axis)
    ca, sa = sin_a * math.cos(phi), sin_a * math.sin(phi)
    n = (ca * e1[0] + sa * e2[0] + cos_a * axis[0], ca * e1[1] + sa * e2[1] + cos_a * axis[1],
         ca * e1[2] + sa * e2[2] + cos_a * axis[2])
    return madd(c, n, r), n, 1.0 / (2.0 * math.pi * one_minus)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def rectangle_frame(q, eu, ev, p):
    """The rectangle (corner q, perpendicular edges eu, ev) as seen from p: its unit axes x, y, z
    (z pointing away from p's side), the coordinates x0 <= x1, y0 <= y1 and z0 <= 0 of its
    edges relative to p, the solid angle it subtends, and the terms the sampler needs."""
    lx, ly = math.sqrt(dot(eu, eu)), math.sqrt(dot(ev, ev))
    x, y = scale(eu, 1.0 / lx), scale(ev, 1.0 / ly)
    z = cross(x, y)
    rel = sub(q, p)
    z0 = dot(rel, z)
    if z0 > 0.0:
        z, z0 = neg(z), -z0
    x0, y0 = dot(rel, x), dot(rel, y)
    x1, y1 = x0 + lx, y0 + ly
    # The normals of the four planes through p and each edge, and the angles between them.
    n0 = unit(cross((x0, y0, z0), (x1, y0, z0)))
    n1 = unit(cross((x1, y0, z0), (x1, y1, z0)))
    n2 = unit(cross((x1, y1, z0), (x0, y1, z0)))
    n3 = unit(cross((x0, y1, z0), (x0, y0, z0)))
    g0 = math.acos(min(1.0, max(-1.0, -dot(n0, n1))))
    g1 = math.acos(min(1.0, max(-1.0, -dot(n1, n2))))
    g2 = math.acos(min(1.0, max(-1.0, -dot(n2, n3))))
    g3 = math.acos(min(1.0, max(-1.0, -dot(n3, n0))))
    k = 2.0 * math.pi - g2 - g3
    solid = g0 + g1 - k
    return x, y, z, x0, x1, y0, y1, z0, solid, k, n0[2], n2[2]


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def sample_rectangle(p, frame, u1, u2):
    """A point of the rectangle whose direction from p is uniform in the solid angle it subtends
    (the spherical rectangle of Urena, Fajardo and King, 2013): u1 picks the x at which a
    plane through p cuts off that share of the solid angle, u2 the height on that line."""
    x, y, z, x0, x1, y0, y1, z0, solid, k, b0, b1 = frame
    au = u1 * solid + k
    fu = (math.cos(au) * b0 - b1) / math.sin(au)
    cu = math.copysign(1.0, fu) / math.sqrt(fu * fu + b0 * b0)
    cu = min(1.0, max(-1.0, cu))
    xu = -(cu * z0) / math.sqrt(max(1e-300, 1.0 - cu * cu))
    xu = min(x1, max(x0, xu))
    d = math.sqrt(xu * xu + z0 * z0)
    h0 = y0 / math.sqrt(d * d + y0 * y0)
    h1 = y1 / math.sqrt(d * d + y1 * y1)
    hv = h0 + u2 * (h1 - h0)
    hv2 = hv * hv
    yv = (hv * d) / math.sqrt(1.0 - hv2) if hv2 < 1.0 - 1e-12 else y1
    yv = min(y1, max(y0, yv))
    return (p[0] + xu * x[0] + yv * y[0] + z0 * z[0], p[1] + xu * x[1] + yv * y[1] + z0 * z[1],
            p[2] + xu * x[2] + yv * y[2] + z0 * z[2])


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def near_rectangle(S, light, prim, p_tree):
    """Whether light row `light` (a rectangle) is near enough p (tree space) to be sampled by
    solid angle (FAR_RECTANGLE); sample_light and light_pdf decide alike."""
    q, eu, ev = PLANAR_CORNER, LIGHT_EDGE_U, LIGHT_EDGE_V
    reach = 0.0
    dist2 = 0.0
    for k in range(3):
        a, b = S.light_f[light, eu + k], S.light_f[light, ev + k]
        c = S.prims_f[prim, q + k] + 0.5 * (a + b) - p_tree[k]
        dist2 += c * c
        reach += abs(a) + abs(b)
    return dist2 < (FAR_RECTANGLE * reach) ** 2


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def light_rectangle(S, light, prim, p_tree):
    """The rectangle frame of light row `light` from p (tree space)."""
    q = (S.prims_f[prim, PLANAR_CORNER], S.prims_f[prim, PLANAR_CORNER + 1], S.prims_f[prim, PLANAR_CORNER + 2])
    eu = (S.light_f[light, LIGHT_EDGE_U], S.light_f[light, LIGHT_EDGE_U + 1], S.light_f[light, LIGHT_EDGE_U + 2])
    ev = (S.light_f[light, LIGHT_EDGE_V], S.light_f[light, LIGHT_EDGE_V + 1], S.light_f[light, LIGHT_EDGE_V + 2])
    return rectangle_frame(q, eu, ev, p_tree)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def sample_surface(kind, prims_f, prim, light_f, light, time, u1, u2):
    """A point uniform on the surface of primitive `prim` (tree space), its outward normal and
    1 / area (the density per tree-space area)."""
    if kind == SPHERE or kind == MOVING_SPHERE:
        c = sphere_center(kind, prims_f, prim, time)
        r = prims_f[prim, SPHERE_RADIUS]
        n = uniform_sphere(u1, u2)
        return madd(c, n, r), n, 1.0 / (4.0 * math.pi * r * r)
    if kind == BOX:
        lo = (prims_f[prim, BOX_LO], prims_f[prim, BOX_LO + 1], prims_f[prim, BOX_LO + 2])
        hi = (prims_f[prim, BOX_HI], prims_f[prim, BOX_HI + 1], prims_f[prim, BOX_HI + 2])
        sx, sy, sz = hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]
        faces = (sy * sz, sz * sx, sx * sy)  # the area of a face across x, y and z
        half = faces[0] + faces[1] + faces[2]
        # u1 chooses the face (by area) and is reused, rescaled, as the first coordinate on it.
        pick = u1 * 2.0 * half
        side = 0
        if pick >= half:
            pick -= half
            side = 1
        axis = 0
        while axis < 2 and pick >= faces[axis]:
            pick -= faces[axis]
            axis += 1
        s = min(pick / faces[axis], 1.0) if faces[axis] > 0.0 else 0.5
        sign = 1.0 if side == 1 else -1.0
        if axis == 0:
            x = (hi[0] if side == 1 else lo[0], lo[1] + s * sy, lo[2] + u2 * sz)
            n = (sign, 0.0, 0.0)
        elif axis == 1:
            x = (lo[0] + u2 * sx, hi[1] if side == 1 else lo[1], lo[2] + s * sz)
            n = (0.0, sign, 0.0)
        else:
            x = (lo[0] + s * sx, lo[1] + u2 * sy, hi[2] if side == 1 else lo[2])
            n = (0.0, 0.0, sign)
        return x, n, 1.0 / (2.0 * half)
    eu = (light_f[light, LIGHT_EDGE_U], light_f[light, LIGHT_EDGE_U + 1], light_f[light, LIGHT_EDGE_U + 2])
    ev = (light_f[light, LIGHT_EDGE_V], light_f[light, LIGHT_EDGE_V + 1], light_f[light, LIGHT_EDGE_V + 2])
    if kind == MESH_TRIANGLE:
        q = (light_f[light, LIGHT_CORNER], light_f[light, LIGHT_CORNER + 1], light_f[light, LIGHT_CORNER + 2])
        n = unit(cross(eu, ev))
    else:
        q = (prims_f[prim, PLANAR_CORNER], prims_f[prim, PLANAR_CORNER + 1], prims_f[prim, PLANAR_CORNER + 2])
        n = (prims_f[prim, PLANAR_NORMAL], prims_f[prim, PLANAR_NORMAL + 1], prims_f[prim, PLANAR_NORMAL + 2])
    if kind == TRIANGLE or kind == MESH_TRIANGLE:
        su = math.sqrt(u1)
        a, b = 1.0 - su, u2 * su
    elif kind == DISK:
        rr = math.sqrt(u1)
        phi = 2.0 * math.pi * u2
        a, b = rr * math.cos(phi), rr * math.sin(phi)
    else:  # QUAD
        a, b = u1, u2
    return madd(madd(q, eu, a), ev, b), n, 1.0 / light_f[light, LIGHT_AREA_COLUMN]


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def area_ratio(inst_f, inst, n_world):
    """Tree-space area per world area at a surface point of world normal n_world (unit): for the
    map L from tree to world, |det L^-1| |L^T n|."""
    m = INST_OBJECT_FROM_WORLD
    det = (inst_f[inst, m] * (inst_f[inst, m + 5] * inst_f[inst, m + 10] - inst_f[inst, m + 6] * inst_f[inst, m + 9])
           - inst_f[inst, m + 1] * (inst_f[inst, m + 4] * inst_f[inst, m + 10] - inst_f[inst, m + 6] * inst_f[inst, m + 8])
           + inst_f[inst, m + 2] * (inst_f[inst, m + 4] * inst_f[inst, m + 9] - inst_f[inst, m + 5] * inst_f[inst, m + 8]))
    w = INST_WORLD_FROM_OBJECT
    # L^T n: column c of L dotted with n.
    lt = (inst_f[inst, w] * n_world[0] + inst_f[inst, w + 4] * n_world[1] + inst_f[inst, w + 8] * n_world[2],
          inst_f[inst, w + 1] * n_world[0] + inst_f[inst, w + 5] * n_world[1] + inst_f[inst, w + 9] * n_world[2],
          inst_f[inst, w + 2] * n_world[0] + inst_f[inst, w + 6] * n_world[1] + inst_f[inst, w + 10] * n_world[2])
    return abs(det) * math.sqrt(dot(lt, lt))


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def emission(S, prim, x_tree, n_tree, x_world, time):
    """The emitted radiance of primitive `prim` at a point (its texture reads (u, v) there)."""
    mat = S.prims_i[prim, PRIM_MATERIAL]
    kind = S.prims_i[prim, PRIM_KIND]
    # A ray down onto the point from one unit above it: every kind's (u, v) as a hit there gives it.
    _, _, u, v = surface(kind, S, prim, madd(x_tree, n_tree, 1.0), neg(n_tree), 1.0, time, S.mat_i[mat, MAT_READS_UV] != 0)
    return texture_value(S.tex_i, S.tex_f, S.texels, S.noise_perm, S.noise_vec, S.mat_i[mat, MAT_TEXTURE], u, v, x_world)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def sample_light(S, p, time, u0, u1, u2):
    """A point on a light for shading point p (world): (ok, point, unit direction from p, distance,
    solid angle density including the choice of light, emitted radiance). u0 chooses the light
    (by power), u1 and u2 the point on it. Not ok when the light is met edge-on or at p itself."""
    zero = (0.0, 0.0, 0.0)
    light = search_cdf(S.light_f, LIGHT_CDF, 0, S.light_f.shape[0], u0)
    inst = S.light_i[light, LIGHT_INSTANCE]
    prim = S.light_i[light, LIGHT_PRIMITIVE]
    kind = S.prims_i[prim, PRIM_KIND]
    moved = S.inst_i[inst, INST_UNTRANSFORMED] != 1
    p_tree = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, p) if moved else p
    cone = False  # the density below is per solid angle already (a cone or a spherical rectangle)
    strategy = S.light_i[light, LIGHT_STRATEGY]
    if strategy == LIGHT_CONE:
        c = sphere_center(kind, S.prims_f, prim, time)
        r = S.prims_f[prim, SPHERE_RADIUS]
        rel = sub(p_tree, c)
        dist2 = dot(rel, rel)
        cone = dist2 > r * r * (1.0 + 1e-9)
    elif strategy == LIGHT_RECTANGLE and near_rectangle(S, light, prim, p_tree):
        frame = light_rectangle(S, light, prim, p_tree)
        cone = frame[8] > SMALL_RECTANGLE
    if cone and strategy == LIGHT_CONE:
        x_tree, n_tree, pdf = sample_cone(p_tree, c, r, dist2, u1, u2)
    elif cone:
        x_tree = sample_rectangle(p_tree, frame, u1, u2)
        n_tree = (S.prims_f[prim, PLANAR_NORMAL], S.prims_f[prim, PLANAR_NORMAL + 1], S.prims_f[prim, PLANAR_NORMAL + 2])
        pdf = 1.0 / frame[8]
    else:
        x_tree, n_tree, pdf = sample_surface(kind, S.prims_f, prim, S.light_f, light, time, u1, u2)
    if moved:
        x = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, x_tree)
        n = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, n_tree))
    else:
        x, n = x_tree, n_tree
    to = sub(x, p)
    dist2_w = dot(to, to)
    if not dist2_w > 0.0:
        return False, x, zero, 0.0, 0.0, zero
    dist = math.sqrt(dist2_w)
    wi = scale(to, 1.0 / dist)
    if not cone:
        cos_l = abs(dot(n, wi))
        if cos_l <= GRAZING:
            return False, x, wi, dist, 0.0, zero
        if moved:
            pdf *= area_ratio(S.inst_f, inst, n)
        pdf *= dist2_w / cos_l
    pdf *= S.light_f[light, LIGHT_PMF]
    return True, x, wi, dist, pdf, emission(S, prim, x_tree, n_tree, x, time)


@njit(forceinline=True, _nrt=False, cache=True, error_model="numpy")
def light_pdf(S, inst, prim, p, x, n, time):
    """The density `sample_light` from shading point p gives the point x (normal n) of primitive
    `prim` placed by instance `inst`, per solid angle at p: the weight a BSDF-sampled hit on
    a light needs."""
    if S.prim_light[prim] < 0:
        return 0.0  # an emitter of no power: never sampled
    light = S.inst_light[inst] + S.prim_light[prim]
    to = sub(x, p)
    dist2 = dot(to, to)
    if not dist2 > 0.0:
        return 0.0
    pmf = S.light_f[light, LIGHT_PMF]
    moved = S.inst_i[inst, INST_UNTRANSFORMED] != 1
    kind = S.prims_i[prim, PRIM_KIND]
    strategy = S.light_i[light, LIGHT_STRATEGY]
    if strategy == LIGHT_RECTANGLE:
        p_tree = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, p) if moved else p
        if near_rectangle(S, light, prim, p_tree):
            solid = light_rectangle(S, light, prim, p_tree)[8]
            if solid > SMALL_RECTANGLE:
                return pmf / solid
    if strategy == LIGHT_CONE:
        p_tree = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, p) if moved else p
        c = sphere_center(kind, S.prims_f, prim, time)
        r = S.prims_f[prim, SPHERE_RADIUS]
        rel = sub(p_tree, c)
        d2 = dot(rel, rel)
        if d2 > r * r * (1.0 + 1e-9):
            return pmf / (2.0 * math.pi * cone_one_minus_cos(r * r / d2))
    if kind == SPHERE or kind == MOVING_SPHERE:
        r = S.prims_f[prim, SPHERE_RADIUS]
        per_area = 1.0 / (4.0 * math.pi * r * r)
    elif kind == BOX:
        lo, hi = BOX_LO, BOX_HI
        sx = S.prims_f[prim, hi] - S.prims_f[prim, lo]
        sy = S.prims_f[prim, hi + 1] - S.prims_f[prim, lo + 1]
        sz = S.prims_f[prim, hi + 2] - S.prims_f[prim, lo + 2]
        per_area = 1.0 / (2.0 * (sx * sy + sy * sz + sz * sx))
    else:
        per_area = 1.0 / S.light_f[light, LIGHT_AREA_COLUMN]
        if kind == MESH_TRIANGLE:
            # The geometric normal, which the sampler used (a smooth mesh's hit has a blended one).
            eu = (S.light_f[light, LIGHT_EDGE_U], S.light_f[light, LIGHT_EDGE_U + 1], S.light_f[light, LIGHT_EDGE_U + 2])
            ev = (S.light_f[light, LIGHT_EDGE_V], S.light_f[light, LIGHT_EDGE_V + 1], S.light_f[light, LIGHT_EDGE_V + 2])
            n = unit(cross(eu, ev))
            if moved:
                n = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, n))
    if moved:
        per_area *= area_ratio(S.inst_f, inst, n)
    cos_l = abs(dot(n, to)) / math.sqrt(dist2)
    if cos_l <= GRAZING:
        return math.inf
    return pmf * per_area * dist2 / cos_l


@njit(cache=True, error_model="numpy")
def light_powers(S, out):
    """out[l] = world area of light l times the luminance of its mean emission over 4x4 stratified points."""
    for light in range(S.light_i.shape[0]):
        inst = S.light_i[light, LIGHT_INSTANCE]
        prim = S.light_i[light, LIGHT_PRIMITIVE]
        kind = S.prims_i[prim, PRIM_KIND]
        moved = S.inst_i[inst, INST_UNTRANSFORMED] != 1
        total_l = 0.0
        total_area = 0.0
        for a in range(4):
            for b in range(4):
                x_tree, n_tree, per_area = sample_surface(kind, S.prims_f, prim, S.light_f, light, 0.0, (a + 0.5) / 4.0, (b + 0.5) / 4.0)
                x = x_tree
                ratio = 1.0
                if moved:
                    x = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, x_tree)
                    ratio = area_ratio(S.inst_f, inst, unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, n_tree)))
                total_l += max(0.0, luminance(emission(S, prim, x_tree, n_tree, x, 0.0)))
                total_area += 1.0 / (per_area * ratio)  # world area, as seen from this point's normal
        out[light] = total_area / 16.0 * total_l / 16.0
