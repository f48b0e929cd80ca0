"""What the light tree knows of each light that has a place: a world box, the cone of its normals
and how far past them it sends light (light_tree.LightBounds), by kind, in numpy.

- An emitting shape (an area light row: an instance places a primitive): the world box of the
  primitive's points carried by the instance's map (a quad's or triangle's corners; the box of a
  sphere over the shutter interval, of a disk, of a box); a flat shape's normal in the world
  (the instance's inverse transposed, as the kernels carry normals), with theta_o 0 and
  theta_e pi/2; emitting from both sides (the books' diffuse light) it is two-sided, from its
  front only (`front_only`) it is not. A sphere or a box sends light every way (theta_o pi).
- A point light: its position (a sphere of its radius), every way.
- A spot: its position, its axis, full intensity within the beam (theta_o) and nothing past the
  cut-off (theta_e = cutoff - beam).
"""

from __future__ import annotations

import math

import numpy as np

from .camera import CAM_CLOSE, CAM_OPEN
from .light_tree import LightBounds, full_sphere
from .shapes import BOX, DISK, MESH_TRIANGLE, MOVING_SPHERE, PRIM_KIND, QUAD, SPHERE, TRIANGLE
from .shapes.boxes import BOX_HI, BOX_LO
from .shapes.planar import PLANAR_CORNER, PLANAR_NORMAL
from .shapes.spheres import MOVING_VELOCITY, SPHERE_CENTER, SPHERE_RADIUS
from .trees import INST_OBJECT_FROM_WORLD, INST_WORLD_FROM_OBJECT

# Reference direction that picks the sign of a two-sided light's normal, so that the normals of
# lights facing either way along one line are summed as one when the tree groups them.
# (Any direction serves that is not perpendicular to the normals scenes use most: the axes.)
_SIGN_REFERENCE = np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)


def _box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """(n, 8, 3): the corners of boxes (lo, hi)."""
    pick = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], np.float64)
    return lo[:, None, :] + pick[None, :, :] * (hi - lo)[:, None, :]


def area_light_bounds(flat, instance: np.ndarray, primitive: np.ndarray, edge_u: np.ndarray, edge_v: np.ndarray,
                      corner: np.ndarray, power: np.ndarray, front_only: np.ndarray) -> LightBounds:
    """The bounds of area light rows placed by `instance` (rows of inst_i) on primitives
    `primitive` (rows of prims_i), with their light_f records (`edge_u`, `edge_v`, `corner`),
    powers and whether each emits from its front only."""
    count = len(primitive)
    kind = flat.prims_i[primitive, PRIM_KIND]
    points = np.zeros((count, 8, 3))
    sphere = (kind == SPHERE) | (kind == MOVING_SPHERE)
    if sphere.any():
        rows = primitive[sphere]
        c = flat.prims_f[rows, SPHERE_CENTER:SPHERE_CENTER + 3]
        r = flat.prims_f[rows, SPHERE_RADIUS][:, None]
        moving = (kind[sphere] == MOVING_SPHERE)[:, None]
        velocity = np.where(moving, flat.prims_f[rows, MOVING_VELOCITY:MOVING_VELOCITY + 3], 0.0)
        # The centre wherever the shutter interval takes it: a moving sphere's row is at time 0.
        c0 = c + velocity * flat.camera[CAM_OPEN]
        c1 = c + velocity * flat.camera[CAM_CLOSE]
        points[sphere] = _box_corners(np.minimum(c0, c1) - r, np.maximum(c0, c1) + r)
    box = kind == BOX
    if box.any():
        rows = primitive[box]
        points[box] = _box_corners(flat.prims_f[rows, BOX_LO:BOX_LO + 3], flat.prims_f[rows, BOX_HI:BOX_HI + 3])
    disk = kind == DISK
    if disk.any():
        c = flat.prims_f[primitive[disk], PLANAR_CORNER:PLANAR_CORNER + 3]
        half = np.sqrt(edge_u[disk] ** 2 + edge_v[disk] ** 2)  # the disk's reach along each axis
        points[disk] = _box_corners(c - half, c + half)
    planar = (kind == QUAD) | (kind == TRIANGLE)
    mesh = kind == MESH_TRIANGLE
    corners = np.zeros((count, 3))
    corners[planar] = flat.prims_f[primitive[planar], PLANAR_CORNER:PLANAR_CORNER + 3]
    corners[mesh] = corner[mesh]
    flat_rows = planar | mesh
    far = np.where((kind == QUAD)[:, None], edge_u + edge_v, edge_u)  # a triangle repeats a corner
    for k, offset in enumerate((0.0 * edge_u, edge_u, edge_v, far)):
        points[flat_rows, 2 * k] = points[flat_rows, 2 * k + 1] = (corners + offset)[flat_rows]
    world = flat.inst_f[instance, INST_WORLD_FROM_OBJECT:INST_WORLD_FROM_OBJECT + 12].reshape(count, 3, 4)
    placed = np.einsum("nij,nkj->nki", world[:, :, :3], points) + world[:, None, :, 3]
    lo, hi = placed.min(axis=1), placed.max(axis=1)

    axis, theta_o, theta_e = full_sphere(count)
    two_sided = np.zeros(count, np.bool_)
    normal_rows = flat_rows | disk
    if normal_rows.any():
        n_tree = np.zeros((count, 3))
        n_tree[planar | disk] = flat.prims_f[primitive[planar | disk], PLANAR_NORMAL:PLANAR_NORMAL + 3]
        n_tree[mesh] = np.cross(edge_u[mesh], edge_v[mesh])
        inverse = flat.inst_f[instance, INST_OBJECT_FROM_WORLD:INST_OBJECT_FROM_WORLD + 12].reshape(count, 3, 4)[:, :, :3]
        # A normal is carried by the inverse map transposed (vec.xform_normal).
        n_world = np.einsum("nji,nj->ni", inverse, n_tree)
        length = np.linalg.norm(n_world, axis=1)
        has = normal_rows & (length > 0.0)
        n_world[has] /= length[has][:, None]
        both = has & ~front_only
        n_world[both] *= np.where(n_world[both] @ _SIGN_REFERENCE < 0.0, -1.0, 1.0)[:, None]
        axis[has] = n_world[has]
        theta_o[has] = 0.0
        two_sided[both] = True
    return LightBounds(lo, hi, axis, theta_o, theta_e, two_sided, np.asarray(power, np.float64))


def point_bounds(position: np.ndarray, radius: np.ndarray, power: np.ndarray) -> LightBounds:
    """Point lights at `position` (sampled as spheres of `radius`, 0 for a point): every way."""
    r = np.asarray(radius, np.float64).reshape(-1, 1)
    axis, theta_o, theta_e = full_sphere(len(position))
    return LightBounds(position - r, position + r, axis, theta_o, theta_e, np.zeros(len(position), np.bool_),
                       np.asarray(power, np.float64))


def spot_bounds(position: np.ndarray, direction: np.ndarray, beam: np.ndarray, cutoff: np.ndarray,
                power: np.ndarray) -> LightBounds:
    """Spot lights at `position` along unit `direction`: full intensity within `beam` of it, none
    past `cutoff` (radians)."""
    beam = np.minimum(np.asarray(beam, np.float64), cutoff)
    theta_e = np.maximum(np.asarray(cutoff, np.float64) - beam, 0.0)
    return LightBounds(position.copy(), position.copy(), np.asarray(direction, np.float64), beam,
                       np.minimum(theta_e, math.pi), np.zeros(len(position), np.bool_), np.asarray(power, np.float64))
