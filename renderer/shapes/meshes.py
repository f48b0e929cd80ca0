"""Triangle meshes: their tables, their (vectorised) flattening, and the watertight ray test.

A mesh is not a row of `prims_f` per triangle (16 doubles, 128 bytes): its triangles are rows
of `tri_i` (three vertex rows and the mesh's row in `mesh_i`) over shared vertex tables, and of
`prims_i` (kind MESH_TRIANGLE and material), so the trees and the path tracer see them as
primitives. `prims_i` row P + k is triangle k, P being the number of `prims_f` rows: a tree's
leaf holds either primitives or triangles (compile.py joins the two trees of a group that has
both). All of it, tree included, is about 60 bytes a triangle (docs/meshes.md).

Intersection is the watertight test of Woop, Benthin and Wald (JCGT 2013): the ray is moved to
the origin and sheared so that it runs along +z, and the three vertices are tested in that 2-D
frame by the signs of three edge functions. A point on an edge shared by two triangles gets the
same edge value, with opposite orientation, from both, so a ray through an edge or a vertex
hits at least one of them: a closed mesh leaks no rays. The edge functions are the (unnormalised)
barycentric coordinates, which give the hit point, the interpolated normal and (u, v).

An emitting triangle is sampled uniformly (`sample_mesh_triangle`) from its first corner and two
edges, which `corners_and_edges` gathers when flattening, with its flat normal even on a smooth
mesh (`sampled_normal`).
"""

from __future__ import annotations

import math
from typing import NamedTuple, Optional

import numpy as np
from .. import target

from scenefmt import affine

from ..columns import Column, Layout
from ..numerics.vec import cross, dot, madd, scale, sub, unit
from . import INF

TRIANGLE_I = Layout("tri_i", "int32", [
    Column("vertex", 3, "rows of the three corners in verts_f (front where they turn counter-clockwise)"),
    Column("mesh", 1, "the mesh's row in mesh_i"),
])
MESH_I = Layout("mesh_i", "int32", [
    Column("first_vertex", 1, "row of the mesh's first vertex in verts_f"),
    Column("normals", 1, "row of its first vertex normal in verts_n; -1 for flat shading"),
    Column("uvs", 1, "row of its first texture coordinate in verts_uv; -1: (u, v) are barycentric"),
])
TRI_VERTEX, TRI_MESH = TRIANGLE_I.offsets("vertex", "mesh")
MESH_FIRST_VERTEX, MESH_NORMALS, MESH_UVS = MESH_I.offsets("first_vertex", "normals", "uvs")


class MeshRows(NamedTuple):
    """One mesh baked into its tree's space: the rows `compile.py` appends to the tables."""

    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (T, 3) int64, rows of `vertices`
    normals: Optional[np.ndarray]  # (V, 3) unit, or None
    uvs: Optional[np.ndarray]  # (V, 2), or None
    lo: np.ndarray  # (T, 3) triangle bounds
    hi: np.ndarray


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per-vertex normals: the sum of the (area-weighted) normals of the faces around each vertex."""
    p0, p1, p2 = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    face_n = np.cross(p1 - p0, p2 - p0)  # length: twice the area
    out = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(out, faces[:, k], face_n)
    return _unit_rows(out, fallback=None)


def _unit_rows(n: np.ndarray, fallback) -> np.ndarray:
    length = np.linalg.norm(n, axis=1, keepdims=True)
    ok = length[:, 0] > 0
    out = np.where(ok[:, None], n / np.where(ok[:, None], length, 1.0), 0.0)
    if fallback is not None:
        out[~ok] = fallback[~ok]
    return out


def mesh_rows(mesh, m, smooth: bool) -> MeshRows:
    """The mesh data (scenefmt.meshfile.MeshData) baked through affine map m, all in numpy."""
    lin = np.array(affine.linear(m), np.float64)
    shift = np.array([row[3] for row in m], np.float64)
    vertices = mesh.vertices if affine.is_identity(m) else mesh.vertices @ lin.T + shift
    faces = mesh.faces
    if np.linalg.det(lin) < 0:
        # A mirror turns the corners' order around: swap two so the front stays outside.
        faces = faces[:, [0, 2, 1]]
    normals = None
    if smooth:
        if mesh.normals is not None:
            # Normals go through the inverse transpose; a zero one falls back to the computed one.
            computed = vertex_normals(vertices, faces)
            normals = _unit_rows(mesh.normals @ np.linalg.inv(lin), computed)
        else:
            normals = vertex_normals(vertices, faces)
    corners = vertices[faces]  # (T, 3, 3)
    return MeshRows(vertices, faces, normals, mesh.uvs, corners.min(axis=1), corners.max(axis=1))


def corners_and_edges(tri_i: np.ndarray, verts_f: np.ndarray, rows: np.ndarray):
    """The first corner and the edges from it to the other two of triangles `rows` of tri_i."""
    corners = verts_f[tri_i[rows, TRI_VERTEX:TRI_VERTEX + 3]]  # (M, 3 corners, 3)
    return corners[:, 0], corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]


def area(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Area of triangles with edges u, v from a corner."""
    return 0.5 * np.linalg.norm(np.cross(u, v), axis=1)


# --- the kernels ------------------------------------------------------------------------------


# The frame a kernel compiled without meshes carries in its place (never read).
NO_SHEAR = (0, 1, 2, 0.0, 0.0, 1.0)


@target.device
def ray_shear(d):
    """The ray's frame for the watertight test: axes (kx, ky, kz), kz where |d| is largest and
    (kx, ky) ordered to keep the frame's handedness, and the shear (sx, sy, sz)."""
    ax, ay, az = abs(d[0]), abs(d[1]), abs(d[2])
    kz = 0 if ax >= ay and ax >= az else (1 if ay >= az else 2)
    kx = (kz + 1) % 3
    ky = (kx + 1) % 3
    if d[kz] < 0.0:
        kx, ky = ky, kx
    sz = 1.0 / d[kz]
    return kx, ky, kz, d[kx] * sz, d[ky] * sz, sz


@target.device
def _edges(tri_i, verts_f, j, o, shear):
    """(U, V, W, T, det): the edge functions of triangle j in the ray's sheared frame (the
    barycentric weights of its corners 0, 1, 2, unnormalised) and the hit distance times det."""
    kx, ky, kz, sx, sy, sz = shear
    a, b, c = tri_i[j, TRI_VERTEX], tri_i[j, TRI_VERTEX + 1], tri_i[j, TRI_VERTEX + 2]
    # Corners relative to the origin, then sheared so the ray runs along +z.
    az_ = verts_f[a, kz] - o[kz]
    bz_ = verts_f[b, kz] - o[kz]
    cz_ = verts_f[c, kz] - o[kz]
    ax_ = verts_f[a, kx] - o[kx] - sx * az_
    ay_ = verts_f[a, ky] - o[ky] - sy * az_
    bx_ = verts_f[b, kx] - o[kx] - sx * bz_
    by_ = verts_f[b, ky] - o[ky] - sy * bz_
    cx_ = verts_f[c, kx] - o[kx] - sx * cz_
    cy_ = verts_f[c, ky] - o[ky] - sy * cz_
    u = cx_ * by_ - cy_ * bx_
    v = ax_ * cy_ - ay_ * cx_
    w = bx_ * ay_ - by_ * ax_
    det = u + v + w
    t_scaled = (u * az_ + v * bz_ + w * cz_) * sz
    return u, v, w, t_scaled, det


@target.device
def hit_mesh_triangle(tri_i, verts_f, j, o, shear, tmin, tmax):
    """Distance in (tmin, tmax) to mesh triangle j along the ray, or inf (watertight: see above).

    An edge value of exactly 0 counts as inside, so a ray through a shared edge or vertex meets
    every triangle around it; only mixed signs (the point outside an edge) miss.
    """
    u, v, w, t_scaled, det = _edges(tri_i, verts_f, j, o, shear)
    if (u < 0.0 or v < 0.0 or w < 0.0) and (u > 0.0 or v > 0.0 or w > 0.0):
        return INF
    if det == 0.0:
        return INF  # the ray lies in the triangle's plane
    t = t_scaled / det
    if not (tmin < t < tmax):
        return INF
    return t


@target.device
def mesh_surface(tri_i, mesh_i, verts_f, verts_n, verts_uv, j, o, d, want_uv):
    """Hit point, unit normal and (u, v) of a hit of the ray (o, d) on mesh triangle j.

    The point is the barycentric blend of the corners (on the triangle's plane, whatever the
    rounding of o + t d). The normal is the geometric one, or with smooth shading the blend of
    the vertex normals; a blended normal that faces the ray from the other side than the
    geometric one would turn the surface inside out for that ray, so the geometric one is kept.
    """
    u, v, w, t_scaled, det = _edges(tri_i, verts_f, j, o, ray_shear(d))
    inv = 1.0 / det if det != 0.0 else 0.0
    b0, b1, b2 = u * inv, v * inv, w * inv
    if det == 0.0:
        b0, b1, b2 = 1.0, 0.0, 0.0
    a, b, c = tri_i[j, TRI_VERTEX], tri_i[j, TRI_VERTEX + 1], tri_i[j, TRI_VERTEX + 2]
    pa = (verts_f[a, 0], verts_f[a, 1], verts_f[a, 2])
    pb = (verts_f[b, 0], verts_f[b, 1], verts_f[b, 2])
    pc = (verts_f[c, 0], verts_f[c, 1], verts_f[c, 2])
    p = (b0 * pa[0] + b1 * pb[0] + b2 * pc[0], b0 * pa[1] + b1 * pb[1] + b2 * pc[1], b0 * pa[2] + b1 * pb[2] + b2 * pc[2])
    ng = unit(cross(sub(pb, pa), sub(pc, pa)))
    n = ng
    mesh = tri_i[j, TRI_MESH]
    first = mesh_i[mesh, MESH_FIRST_VERTEX]
    nrm = mesh_i[mesh, MESH_NORMALS]
    if nrm >= 0:
        ka, kb, kc = nrm + a - first, nrm + b - first, nrm + c - first
        s = (
            b0 * verts_n[ka, 0] + b1 * verts_n[kb, 0] + b2 * verts_n[kc, 0],
            b0 * verts_n[ka, 1] + b1 * verts_n[kb, 1] + b2 * verts_n[kc, 1],
            b0 * verts_n[ka, 2] + b1 * verts_n[kb, 2] + b2 * verts_n[kc, 2],
        )
        length2 = dot(s, s)
        if length2 > 0.0:
            s = scale(s, 1.0 / np.sqrt(length2))
            if dot(s, d) * dot(ng, d) > 0.0:
                n = s
    tu, tv = b1, b2
    if want_uv:
        uvs = mesh_i[mesh, MESH_UVS]
        if uvs >= 0:
            ka, kb, kc = uvs + a - first, uvs + b - first, uvs + c - first
            tu = b0 * verts_uv[ka, 0] + b1 * verts_uv[kb, 0] + b2 * verts_uv[kc, 0]
            tv = b0 * verts_uv[ka, 1] + b1 * verts_uv[kb, 1] + b2 * verts_uv[kc, 1]
    return p, n, tu, tv



@target.device
def mesh_derivatives(tri_i, mesh_i, verts_f, verts_uv, j):
    """dp/du and dp/dv of mesh triangle j for the (u, v) `mesh_surface` gives, constant over the
    triangle. With texture coordinates: the solution of e1 = du1 dp/du + dv1 dp/dv, e2 = du2
    dp/du + dv2 dp/dv for the edges e1, e2 from the first corner and their (u, v) differences
    (as pbrt and MikkTSpace's per-triangle step do); a triangle whose (u, v) are degenerate (zero
    area in the texture) gets the barycentric ones. Without: (u, v) are the barycentric weights
    of corners 1 and 2, so dp/du = e1 and dp/dv = e2."""
    a, b, c = tri_i[j, TRI_VERTEX], tri_i[j, TRI_VERTEX + 1], tri_i[j, TRI_VERTEX + 2]
    pa = (verts_f[a, 0], verts_f[a, 1], verts_f[a, 2])
    e1 = sub((verts_f[b, 0], verts_f[b, 1], verts_f[b, 2]), pa)
    e2 = sub((verts_f[c, 0], verts_f[c, 1], verts_f[c, 2]), pa)
    mesh = tri_i[j, TRI_MESH]
    uvs = mesh_i[mesh, MESH_UVS]
    if uvs < 0:
        return e1, e2
    first = mesh_i[mesh, MESH_FIRST_VERTEX]
    ka, kb, kc = uvs + a - first, uvs + b - first, uvs + c - first
    du1, dv1 = verts_uv[kb, 0] - verts_uv[ka, 0], verts_uv[kb, 1] - verts_uv[ka, 1]
    du2, dv2 = verts_uv[kc, 0] - verts_uv[ka, 0], verts_uv[kc, 1] - verts_uv[ka, 1]
    det = du1 * dv2 - dv1 * du2
    # Relative to the (u, v) extent, so that small but valid texture triangles are kept.
    extent = max(abs(du1), abs(dv1), abs(du2), abs(dv2))
    if not abs(det) > 1e-9 * extent * extent:
        return e1, e2
    inv = 1.0 / det
    dpdu = ((dv2 * e1[0] - dv1 * e2[0]) * inv, (dv2 * e1[1] - dv1 * e2[1]) * inv, (dv2 * e1[2] - dv1 * e2[2]) * inv)
    dpdv = ((du1 * e2[0] - du2 * e1[0]) * inv, (du1 * e2[1] - du2 * e1[1]) * inv, (du1 * e2[2] - du2 * e1[2]) * inv)
    return dpdu, dpdv


@target.device
def sampled_normal(eu, ev):
    """The flat normal of a triangle with edges eu, ev: the one its sampler gives (a smooth
    mesh's hit blends another, which the density must not use)."""
    return unit(cross(eu, ev))


@target.device
def sample_mesh_triangle(q, eu, ev, triangle_area, u1, u2):
    """A point uniform on the triangle of corner q and edges eu, ev, its flat normal and the
    density per area, 1 / `triangle_area`."""
    n = sampled_normal(eu, ev)
    su = math.sqrt(u1)
    a, b = 1.0 - su, u2 * su
    return madd(madd(q, eu, a), ev, b), n, 1.0 / triangle_area
