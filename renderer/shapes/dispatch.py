"""Shapes by kind: which family's flattening makes a shape's rows, which kernel a row's hit
takes, and which family measures and samples an emitting row's surface."""

import numpy as np
from .. import target

from scenefmt import affine

from ..config import SPAWN_OFFSET
from ..kernel_flags import INSTANCES, MEDIA, MESHES, MOTION
from ..motion import instance_maps, map_normal, map_point, map_vector, moves
from ..numerics.vec import dot, madd, max_abs, unit, xform_normal, xform_point, xform_vector
from ..trees import INST_OBJECT_FROM_WORLD, INST_UNTRANSFORMED, INST_WORLD_FROM_OBJECT
from . import (BOX, DISK, MEDIUM, MESH_TRIANGLE, MOVING_SPHERE, PRIM_KIND, PRIM_MATERIAL, QUAD, SPHERE, TRIANGLE, boxes, meshes,
               planar, spheres)
from .boxes import box_derivatives, box_surface, hit_box, sample_box_surface
from .meshes import mesh_derivatives, mesh_surface, sample_mesh_triangle, sampled_normal
from .planar import hit_planar, planar_derivatives, planar_surface, sample_planar_surface
from .spheres import SPHERE_RADIUS, hit_sphere, sample_sphere_surface, sphere_center, sphere_derivatives, sphere_surface


def shape_rows(model, m, similarity, shutter: tuple[float, float], as_box: bool):
    """The (kind, row, lo, hi) rows of a shape model baked through affine map m, or None when m
    cannot be baked in (a sphere under a non-similarity: it needs an instance of its own).

    `similarity` is (linear part, scale or None) of m; `as_box` allows a box to be one BOX row
    (its material does not read (u, v), and it is a surface, not a medium's boundary).
    """
    if model.type in ("sphere", "moving_sphere"):
        lin, s = similarity
        return None if s is None else [spheres.sphere_row(model, m, lin, s, *shutter)]
    if model.type == "box" and as_box:
        row = boxes.box_row(model, m)
        if row is not None:
            return [row]
    return planar.planar_rows(model, m)


def similarity_of(m) -> tuple:
    lin = affine.linear(m)
    return lin, affine.similarity_scale(lin)


def surface_records(kind: np.ndarray, prim: np.ndarray, flat) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What `sample_surface` needs of each primitive row `prim` (of kinds `kind`) of flat scene
    `flat`, measured once here in the tree's space by its family: (area, edge u, edge v, corner).
    The edges are a planar shape's or a mesh triangle's (zero for others); the corner a mesh
    triangle's first (other kinds keep theirs in prims_f)."""
    count = len(prim)
    area, u, v, corner = np.zeros(count), np.zeros((count, 3)), np.zeros((count, 3)), np.zeros((count, 3))
    sphere = (kind == SPHERE) | (kind == MOVING_SPHERE)
    flat_kind = (kind == QUAD) | (kind == TRIANGLE) | (kind == DISK)
    mesh = kind == MESH_TRIANGLE
    box = kind == BOX
    u[flat_kind], v[flat_kind] = planar.edges(flat.prims_f, prim[flat_kind])
    if mesh.any():
        corner[mesh], u[mesh], v[mesh] = meshes.corners_and_edges(flat.tri_i, flat.verts_f, prim[mesh] - len(flat.prims_f))
    area[sphere] = spheres.area(flat.prims_f, prim[sphere])
    area[flat_kind] = planar.area(kind[flat_kind], u[flat_kind], v[flat_kind])
    area[mesh] = meshes.area(u[mesh], v[mesh])
    area[box] = boxes.area(flat.prims_f, prim[box])
    return area, u, v, corner


# --- the kernels ------------------------------------------------------------------------------


@target.device
def hit_primitive(kind, data, i, o, d, inv, inv_a, tmin, tmax, time):
    """Distance to primitive i of a surface kind along the ray, or inf; `inv` is the inverse
    direction (see hit_box) and `inv_a` is 1 / (d . d)."""
    if kind == SPHERE or kind == MOVING_SPHERE:
        return hit_sphere(sphere_center(kind, data, i, time), data[i, SPHERE_RADIUS], o, d, inv_a, tmin, tmax)
    if kind == BOX:
        return hit_box(data, i, o, d, inv, tmin, tmax)
    return hit_planar(kind, data, i, o, d, tmin, tmax)


@target.device
def surface(kind, S, i, o, d, t, time, want_uv):
    """Hit point, unit outward normal and (u, v) of a hit at distance t on primitive row i of
    the flat scene S.

    (u, v) is (0, 0) unless `want_uv`: only image textures read it, and on a sphere it costs
    an arc cosine and an arc tangent.
    """
    if MESHES and kind == MESH_TRIANGLE:
        return mesh_surface(S.tri_i, S.mesh_i, S.verts_f, S.verts_n, S.verts_uv, i - S.prims_f.shape[0], o, d, want_uv)
    data = S.prims_f
    p = madd(o, d, t)
    if kind == SPHERE or kind == MOVING_SPHERE:
        return sphere_surface(kind, data, i, p, time, want_uv)
    if kind == BOX:
        return box_surface(data, i, p, d)
    n, u, v = planar_surface(kind, data, i, p)
    return p, n, u, v


@target.device
def hit_material(prims_i, prim):
    """The material row of primitive row `prim` (a medium's: its phase function)."""
    return prims_i[prim, PRIM_MATERIAL]


@target.device
def is_volume(prims_i, prim):
    """Whether a hit on primitive row `prim` is a scattering event inside a medium rather than a
    point on a surface: it has no side, and the next ray starts at the point itself."""
    return MEDIA and prims_i[prim, PRIM_KIND] == MEDIUM


@target.device
def interaction(S, prim, o, d, t, time, want_uv):
    """Point, unit normal and (u, v) of the hit at distance t along o + t d on primitive row
    `prim` of the flat scene S, in the space of o and d.

    A surface's come from `surface`. A scattering event in a medium (`is_volume`) is the point
    o + t d with (u, v) = (0, 0) and the stand-in normal (1, 0, 0), which no phase function
    reads; it is computed where the ray is, so the caller passes the world's ray for it.
    """
    kind = S.prims_i[prim, PRIM_KIND]
    if MEDIA and kind == MEDIUM:
        return madd(o, d, t), (1.0, 0.0, 0.0), 0.0, 0.0
    return surface(kind, S, prim, o, d, t, time, want_uv)


@target.device
def moving_interaction(S, prim, inst, o, d, t, time, want_uv):
    """`interaction` of a surface hit under moving instance row `inst`, in the world: the ray
    taken into the instance's space and the point and normal back out, by its maps at `time`.
    Also the outward normal in the tree's space, for surface_derivatives."""
    world, back = instance_maps(S.inst_i, S.motion_f, inst, time)
    po, no, u, v = interaction(S, prim, map_point(back, o), map_vector(back, d), t, time, want_uv)
    return map_point(world, po), unit(map_normal(back, no)), u, v, no


@target.device
def world_interaction(S, prim, inst, o, d, t, time, want_uv, volume):
    """`interaction` of a hit found in world space on instance `inst`: point, unit normal and
    (u, v) in world space, and the normal in the instance's own space (what a tree's bounds
    read). The surface is queried in the instance's space, where the instance is at `time` if it
    moves (a volume event, which has no surface, on the world's ray), as the path tracer and every
    pass that follows its rays do."""
    if MOTION and INSTANCES and not volume and moves(S.inst_i, inst):
        return moving_interaction(S, prim, inst, o, d, t, time, want_uv)
    if INSTANCES and not volume and S.inst_i[inst, INST_UNTRANSFORMED] != 1:
        oo = xform_point(S.inst_f, inst, INST_OBJECT_FROM_WORLD, o)
        dd = xform_vector(S.inst_f, inst, INST_OBJECT_FROM_WORLD, d)
        po, no, u, v = interaction(S, prim, oo, dd, t, time, want_uv)
        p = xform_point(S.inst_f, inst, INST_WORLD_FROM_OBJECT, po)
        n = unit(xform_normal(S.inst_f, inst, INST_OBJECT_FROM_WORLD, no))
        return p, n, u, v, no
    p, n, u, v = interaction(S, prim, o, d, t, time, want_uv)
    return p, n, u, v, n



@target.device
def surface_derivatives(S, prim, n):
    """dp/du and dp/dv, in the tree's space, of the (u, v) that `interaction` gives at a point of
    primitive row `prim` of the flat scene S whose unit outward normal there is n (as
    `interaction` returned it, in the tree's space). Asked only for a hit whose material needs a
    tangent frame (a normal or a bump map); a caller under an instance carries both to the world
    as vectors (the linear part of world_from_object).

    Neither is normalised: a bump map's finite differences step along them. (0, 0, 0) where (u, v)
    has no derivative (a sphere's poles, a BOX row, a medium), and a frame built on them then
    falls back to any frame. dp/du x dp/dv points outward, except under a mirroring transform or
    on a mesh whose texture coordinates are mirrored: a tangent frame reads its handedness from
    the pair (materials/shading_normal.py)."""
    kind = S.prims_i[prim, PRIM_KIND]
    if MESHES and kind == MESH_TRIANGLE:
        return mesh_derivatives(S.tri_i, S.mesh_i, S.verts_f, S.verts_uv, prim - S.prims_f.shape[0])
    if MEDIA and kind == MEDIUM:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    if kind == SPHERE or kind == MOVING_SPHERE:
        return sphere_derivatives(kind, S.prims_f, prim, n)
    if kind == BOX:
        return box_derivatives()
    return planar_derivatives(kind, S.prims_f, prim)



@target.device
def world_derivatives(S, prim, inst, n_tree, time):
    """`surface_derivatives` of a hit on primitive row `prim` placed by instance row `inst`,
    carried to the world as vectors (the linear part of world_from_object, a moving instance's
    at `time`); `n_tree` is the outward normal `interaction` gave in the tree's space."""
    dpdu, dpdv = surface_derivatives(S, prim, n_tree)
    if MOTION and INSTANCES and moves(S.inst_i, inst):
        world, _ = instance_maps(S.inst_i, S.motion_f, inst, time)
        return map_vector(world, dpdu), map_vector(world, dpdv)
    if INSTANCES and S.inst_i[inst, INST_UNTRANSFORMED] != 1:
        return (xform_vector(S.inst_f, inst, INST_WORLD_FROM_OBJECT, dpdu),
                xform_vector(S.inst_f, inst, INST_WORLD_FROM_OBJECT, dpdv))
    return dpdu, dpdv


@target.device
def sample_surface(kind, data, i, area, eu, ev, corner, time, u1, u2):
    """A point uniform on the surface of primitive row i of kind `kind` (tree space) at `time`, its
    outward normal and the density per tree-space area; `area`, `eu`, `ev` and `corner` are the
    row's record from `surface_records`."""
    if kind == SPHERE or kind == MOVING_SPHERE:
        return sample_sphere_surface(kind, data, i, area, time, u1, u2)
    if kind == BOX:
        return sample_box_surface(data, i, area, u1, u2)
    if MESHES and kind == MESH_TRIANGLE:
        return sample_mesh_triangle(corner, eu, ev, area, u1, u2)
    return sample_planar_surface(kind, data, i, eu, ev, area, u1, u2)


@target.device
def sampler_normal(kind, eu, ev):
    """Whether a hit on a row of kind `kind` may find another normal than `sample_surface` gives
    at the same point (a smooth mesh's triangle blends its vertices'), and if so the sampler's
    (tree space), which a density per solid angle must use."""
    if MESHES and kind == MESH_TRIANGLE:
        return True, sampled_normal(eu, ev)
    return False, (0.0, 0.0, 0.0)


@target.device
def spawn_origin(p, o, n, d):
    """Origin of a ray leaving hit point p (reached by a ray from o) in direction d.

    The renderer casts every ray with t_min = 0, so self-intersection is avoided here instead:
    p moves along the unit normal n, to the side d points to, by SPAWN_OFFSET times the
    magnitude of the coordinates involved. The rounding error of a hit point is a few ulps of
    that magnitude, so the margin is always far larger than the error and, being relative,
    looks the same at every scale (see docs/robustness.md).
    """
    eps = SPAWN_OFFSET * (max_abs(p) + max_abs(o))
    return madd(p, n, eps if dot(d, n) > 0.0 else -eps)
