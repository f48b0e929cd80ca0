"""Flatten a scene graph into tables of primitives, materials and textures; `assemble` adds the BVHs.

Transforms are baked into primitives wherever the shape keeps its kind (a transformed quad,
triangle, disk or box is still made of parallelograms, a box kept axis-aligned is still one box
row, a sphere under a similarity is still a sphere), so the common case pays nothing for
instancing. Groups placed by instances become
shared bottom-level trees; a sphere under a non-uniform scale becomes a one-shape instance.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Optional

import numpy as np

from scenefmt import affine
from scenefmt.diagnostics import format_path
from scenefmt.graph import GroupNode, InstanceNode, MaterialNode, MediumNode, SceneGraph, ShapeNode, TextureNode
from scenefmt.scene import SkyBackground

from . import layout as L
from .tables import SceneTables, TreeTables
from .textures import load_image_texels, perlin_tables

if TYPE_CHECKING:
    from .flat import FlatScene

_BOX_FACES = (
    # (corner selector, u axis, v axis) as in the book: all six u x v point outward.
    ((0, 0, 1), (1, 0, 0), (0, 1, 0)),  # front  z = max
    ((1, 0, 1), (0, 0, -1), (0, 1, 0)),  # right  x = max
    ((1, 0, 0), (-1, 0, 0), (0, 1, 0)),  # back   z = min
    ((0, 0, 0), (0, 0, 1), (0, 1, 0)),  # left   x = min
    ((0, 1, 1), (1, 0, 0), (0, 0, -1)),  # top    y = max
    ((0, 0, 0), (1, 0, 0), (0, 0, 1)),  # bottom y = min
)


def _linear(m) -> np.ndarray:
    return np.array([row[:3] for row in m], dtype=np.float64)


def _apply(m, p) -> np.ndarray:
    return np.array(affine.apply_point(m, p), dtype=np.float64)


def _similarity_scale(lin: np.ndarray) -> Optional[float]:
    """s when lin = s * (an orthogonal matrix), else None."""
    g = lin.T @ lin
    s2 = g[0, 0]
    if s2 <= 0 or not np.allclose(g, s2 * np.eye(3), rtol=1e-9, atol=1e-12 * s2):
        return None
    return math.sqrt(s2)


def _cross(a, b) -> tuple[float, float, float]:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _mul(lin, v) -> tuple[float, float, float]:
    """lin @ v for a 3x3 matrix given as rows."""
    return tuple(_dot(row, v) for row in lin)  # type: ignore[return-value]


# Planar rows are computed on Python floats, not numpy arrays: scenes have thousands of them (the
# final scene's ground was 2400 box faces before boxes got rows of their own), and numpy's
# per-call cost on 3-vectors made flattening them take six times as long.
def _planar_row(q, u, v, flip: bool) -> list[float]:
    n = _cross(u, v)
    nn = _dot(n, n)
    length = math.sqrt(nn)
    unit = (n[0] / length, n[1] / length, n[2] / length)
    if flip:
        # A mirroring transform keeps the front face where it was geometrically.
        unit = (-unit[0], -unit[1], -unit[2])
    w = (n[0] / nn, n[1] / nn, n[2] / nn)
    row = [0.0] * L.PRIM_WIDTH
    row[0:3], row[3:6] = q, unit
    row[6] = _dot(unit, q) + 0.0  # + 0.0: a plane through the origin gets offset +0, never -0
    # alpha = w . (p x v) = p . (v x w); beta = w . (u x p) = p . (w x u)
    row[7:10] = _cross(v, w)
    row[10:13] = _cross(w, u)
    return row


class _Compiler:
    def __init__(self, graph: SceneGraph):
        self.graph = graph
        self.shutter_open = float(graph.shutter.open)
        self.shutter_close = float(graph.shutter.close)
        self.tex_rows: list[tuple] = []
        self.tex_ids: dict[int, int] = {}
        self.white_row: Optional[int] = None
        self.texel_chunks: list[np.ndarray] = []
        self.texel_count = 0
        self.noise: list[tuple[np.ndarray, np.ndarray]] = []
        self.mat_rows: list[tuple] = []
        self.mat_ids: dict[int, int] = {}
        self.phase_ids: dict[int, int] = {}
        self.bnd_kind: list[int] = []
        self.bnd_rows: list[np.ndarray] = []
        self.blas: list[TreeTables] = []
        self.blas_of_group: dict[int, int] = {}
        self.instances: list[tuple[int, tuple]] = []
        self.media_count = 0
        # Spheres under a non-similarity (ellipsoids), each in a tree of its own: shape id -> tree.
        self.own_instance: dict[int, int] = {}
        self.similarity_of: dict[tuple, tuple[np.ndarray, Optional[float]]] = {}

    # --- textures and materials ----------------------------------------------------------------

    def texture(self, node: TextureNode) -> int:
        key = id(node)
        if key in self.tex_ids:
            return self.tex_ids[key]
        m = node.model
        index = len(self.tex_rows)
        self.tex_ids[key] = index
        self.tex_rows.append(None)  # reserve the slot; children come after
        color, param, child = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0), (-1, -1)
        if m.type == "solid":
            kind, color = L.TEX_SOLID, m.color
        elif m.type == "checker":
            kind = L.TEX_CHECKER
            param = (1.0 / m.scale, 0.0, 0.0, 0.0)
            child = (self.texture(node.inputs["even"]), self.texture(node.inputs["odd"]))
        elif m.type == "image":
            kind = L.TEX_IMAGE
            try:
                texels = load_image_texels(node.image_path, m.colorspace)
            except ValueError as exc:
                raise ValueError(f"image texture at {format_path(node.path)}: {exc}") from None
            h, w = texels.shape[:2]
            param = (float(self.texel_count), float(w), float(h), 0.0)
            self.texel_chunks.append(texels.reshape(-1, 3))
            self.texel_count += w * h
        else:
            kind = L.TEX_NOISE
            form = {"plain": L.NOISE_PLAIN, "turbulence": L.NOISE_TURBULENCE, "marble": L.NOISE_MARBLE}[m.form]
            param = (m.scale, float(form), float(m.octaves), float(len(self.noise)))
            color = m.color
            self.noise.append(perlin_tables(m.seed))
        self.tex_rows[index] = (kind, tuple(color), tuple(param), tuple(child))
        return index

    def reads_uv(self, tex: int) -> bool:
        """Whether texture row `tex` looks at surface coordinates: an image, or a checker over one.

        The kernels compute a hit's (u, v) only for such materials: on a sphere that takes an
        arc cosine and an arc tangent, which every other texture would pay for nothing.
        """
        kind, _, _, child = self.tex_rows[tex]
        if kind == L.TEX_IMAGE:
            return True
        return kind == L.TEX_CHECKER and any(self.reads_uv(c) for c in child)

    def white(self) -> int:
        """The row of a solid white texture, added once."""
        if self.white_row is None:
            self.white_row = len(self.tex_rows)
            self.tex_rows.append((L.TEX_SOLID, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0, 0.0), (-1, -1)))
        return self.white_row

    def material(self, node: MaterialNode) -> int:
        key = id(node)
        if key not in self.mat_ids:
            m = node.model
            kind = {"lambertian": L.LAMBERTIAN, "metal": L.METAL, "dielectric": L.DIELECTRIC,
                    "diffuse_light": L.DIFFUSE_LIGHT, "isotropic": L.ISOTROPIC}[m.type]
            slot = node.textures.get("albedo") or node.textures.get("emit")
            # A material without a colour (a dielectric) attenuates by 1: it still needs a
            # texture row, since the kernels look one up for every scattering material.
            tex = self.texture(slot) if slot is not None else self.white()
            param = (getattr(m, "fuzz", 0.0), getattr(m, "ior", 1.0))
            self.mat_ids[key] = len(self.mat_rows)
            self.mat_rows.append((kind, tex, param))
        return self.mat_ids[key]

    def phase(self, medium: MediumNode) -> int:
        """The isotropic material that scatters inside a medium."""
        key = id(medium)
        if key not in self.phase_ids:
            self.phase_ids[key] = len(self.mat_rows)
            self.mat_rows.append((L.ISOTROPIC, self.texture(medium.albedo), (0.0, 1.0)))
        return self.phase_ids[key]

    # --- primitives ----------------------------------------------------------------------------

    def similarity(self, m) -> tuple[np.ndarray, Optional[float]]:
        """(linear part, similarity scale or None) of m, cached: a scene's many spheres share a
        few transforms, and the check costs tens of microseconds in numpy."""
        known = self.similarity_of.get(m)
        if known is None:
            lin = _linear(m)
            known = self.similarity_of[m] = (lin, _similarity_scale(lin))
        return known

    def sphere_row(self, shape: ShapeNode, m) -> Optional[tuple[int, np.ndarray, np.ndarray, np.ndarray]]:
        """(kind, row, lo, hi) of a sphere baked through m, or None if m is not a similarity."""
        lin, s = self.similarity(m)
        if s is None:
            return None
        rot = (lin / s).T  # object_from_world rotation for the uv frame
        model = shape.model
        r = model.radius * s
        row = np.zeros(L.PRIM_WIDTH)
        row[3] = r
        if model.type == "sphere":
            c = _apply(m, model.center)
            row[0:3] = c
            row[4:13] = rot.reshape(9)
            return L.SPHERE, row, c - r, c + r
        c0, c1 = _apply(m, model.center0), _apply(m, model.center1)
        span = self.shutter_close - self.shutter_open
        vel = (c1 - c0) / span if span > 0 else np.zeros(3)
        row[0:3] = c0 - self.shutter_open * vel
        row[4:7] = vel
        row[7:16] = rot.reshape(9)
        if span == 0:
            c1 = c0
        return L.MOVING_SPHERE, row, np.minimum(c0, c1) - r, np.maximum(c0, c1) + r

    def planar_rows(self, shape: ShapeNode, m) -> list[tuple[int, list, tuple, tuple]]:
        lin = tuple(row[:3] for row in m)
        flip = np.linalg.det(_linear(m)) < 0
        model = shape.model
        out = []

        def add(kind, q, u, v, corners):
            q2, u2, v2 = affine.apply_point(m, q), _mul(lin, u), _mul(lin, v)
            pts = [tuple(q2[k] + a * u2[k] + b * v2[k] for k in range(3)) for a, b in corners]
            lo = tuple(min(p[k] for p in pts) for k in range(3))
            hi = tuple(max(p[k] for p in pts) for k in range(3))
            out.append((kind, _planar_row(q2, u2, v2, flip), lo, hi))

        if model.type == "quad":
            add(L.QUAD, model.q, model.u, model.v, ((0, 0), (1, 0), (0, 1), (1, 1)))
        elif model.type == "triangle":
            p0, p1, p2 = (np.asarray(p, float) for p in model.vertices)
            add(L.TRIANGLE, p0, p1 - p0, p2 - p0, ((0, 0), (1, 0), (0, 1)))
        elif model.type == "disk":
            n = np.asarray(model.normal, float)
            n = n / np.linalg.norm(n)
            helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
            a = np.cross(helper, n)
            a /= np.linalg.norm(a)
            b = np.cross(n, a)  # a x b = n
            r = model.radius
            lin3 = _linear(m)
            q2, u2, v2 = _apply(m, model.center), lin3 @ (a * r), lin3 @ (b * r)
            ext = np.sqrt(u2 * u2 + v2 * v2)
            out.append((L.DISK, _planar_row(q2, u2, v2, flip), q2 - ext, q2 + ext))
        else:  # box
            lo, hi = np.asarray(model.min, float), np.asarray(model.max, float)
            size = hi - lo
            for corner, u_axis, v_axis in _BOX_FACES:
                q = np.where(np.array(corner) > 0, hi, lo)
                u = np.array(u_axis) * size
                v = np.array(v_axis) * size
                add(L.QUAD, q, u, v, ((0, 0), (1, 0), (0, 1), (1, 1)))
        return out

    def box_row(self, shape: ShapeNode, m) -> Optional[tuple[int, list, tuple, tuple]]:
        """(BOX, row, lo, hi) of a box that m keeps axis-aligned and not flat, else None.

        A ray meets such a box in one slab test where its six faces as quads take six tests; as
        quads, the final scene's 400 ground boxes were 2400 rows, and a ray leaving a box top
        met about seven of them.
        """
        if any(m[r][c] != 0.0 for r in range(3) for c in range(3) if r != c):
            return None
        a, b = affine.apply_point(m, shape.model.min), affine.apply_point(m, shape.model.max)
        lo = tuple(min(a[k], b[k]) for k in range(3))
        hi = tuple(max(a[k], b[k]) for k in range(3))
        if not all(hi[k] > lo[k] for k in range(3)):
            return None
        row = [0.0] * L.PRIM_WIDTH
        row[0:3], row[3:6] = lo, hi
        return L.BOX, row, lo, hi

    def shape_rows(self, shape: ShapeNode, m, mat: Optional[int] = None):
        """The rows of shape baked through m: a surface made of material row `mat`, or, with no
        material, a medium's boundary (those stay quads: the media code tests planar rows)."""
        if shape.kind in ("sphere", "moving_sphere"):
            row = self.sphere_row(shape, m)
            return None if row is None else [row]
        if shape.kind == "box" and mat is not None and not self.reads_uv(self.mat_rows[mat][1]):
            row = self.box_row(shape, m)
            if row is not None:
                return [row]
        return self.planar_rows(shape, m)

    def add_shape(self, tables: TreeTables, shape: ShapeNode, m) -> bool:
        """Append shape's rows (surface and medium) baked through m; False if it needs an instance."""
        mat = self.material(shape.material) if shape.material is not None else None
        surface = self.shape_rows(shape, m, mat)
        if surface is None:
            return False
        if mat is not None:
            for kind, row, lo, hi in surface:
                tables.kind.append(kind)
                tables.rows.append(row)
                tables.mat.append(mat)
                tables.lo.append(lo)
                tables.hi.append(hi)
        if shape.interior is not None:
            # A medium's boundary is tested as planes: a box row's faces are made for it.
            rows = self.planar_rows(shape, m) if surface[0][0] == L.BOX else surface
            start = len(self.bnd_rows)
            for kind, row, _, _ in rows:
                self.bnd_kind.append(kind)
                self.bnd_rows.append(row)
            medium = np.zeros(L.PRIM_WIDTH)
            medium[0] = -1.0 / shape.interior.model.density
            medium[1] = start
            medium[2] = len(rows)
            # A serial number independent of the BVH's row order keys the medium's random numbers.
            medium[3] = self.media_count
            self.media_count += 1
            tables.kind.append(L.MEDIUM)
            tables.rows.append(medium)
            tables.mat.append(self.phase(shape.interior))
            tables.lo.append(np.min([r[2] for r in rows], axis=0))
            tables.hi.append(np.max([r[3] for r in rows], axis=0))
        return True

    # --- groups and instances ------------------------------------------------------------------

    def place(self, group: GroupNode, world_from_group) -> None:
        """Record the instances that put `group` into the world, flattening nested instances."""
        key = id(group)
        if key not in self.blas_of_group:
            tables = TreeTables()
            self.blas_of_group[key] = len(self.blas)
            self.blas.append(tables)
            self.fill(group, tables)
        blas = self.blas_of_group[key]
        if self.blas[blas].kind:
            self.instances.append((blas, world_from_group))
        for member in group.members:
            if isinstance(member, InstanceNode):
                self.place(member.group, affine.compose(world_from_group, member.transform))
            elif id(member) in self.own_instance:
                self.instances.append((self.own_instance[id(member)], affine.compose(world_from_group, member.transform)))

    def fill(self, group: GroupNode, tables: TreeTables) -> None:
        for member in group.members:
            if isinstance(member, InstanceNode):
                continue
            if not self.add_shape(tables, member, member.transform):
                # An ellipsoid: the sphere in its own tree, placed by its transform.
                own = TreeTables()
                self.add_shape(own, member, affine.IDENTITY)
                self.own_instance[id(member)] = len(self.blas)
                self.blas.append(own)

    # --- the whole scene -----------------------------------------------------------------------

    def run(self) -> SceneTables:
        self.place(self.graph.root, affine.IDENTITY)
        # The kernels index textures without bounds checks: a bad row would read stray memory.
        n_tex = len(self.tex_rows)
        for kind, tex, _ in self.mat_rows:
            if not 0 <= tex < n_tex:
                raise AssertionError(f"material of kind {kind} refers to texture row {tex} of {n_tex}")
        return SceneTables(
            blas=[tables.packed() for tables in self.blas],
            instances=[(blas, m, affine.is_identity(m)) for blas, m in self.instances],
            tex_rows=self.tex_rows,
            mat_rows=[(kind, tex, param, self.reads_uv(tex)) for kind, tex, param in self.mat_rows],
            texel_chunks=self.texel_chunks,
            noise=self.noise,
            bnd_kind=self.bnd_kind,
            bnd_rows=self.bnd_rows,
            camera=camera_array(self.graph),
            background=background_array(self.graph),
        )


def camera_array(graph: SceneGraph) -> np.ndarray:
    """The camera as the kernels read it (the second book's thin-lens camera)."""
    cam, image = graph.camera, graph.image
    width, height = image.width, image.pixel_height
    center = np.asarray(cam.look_from, float)
    focus = cam.focus
    viewport_h = 2.0 * math.tan(math.radians(cam.vfov) / 2.0) * focus
    viewport_w = viewport_h * (width / height)
    w = center - np.asarray(cam.look_at, float)
    w /= np.linalg.norm(w)
    u = np.cross(np.asarray(cam.up, float), w)
    u /= np.linalg.norm(u)
    v = np.cross(w, u)
    du = viewport_w * u / width
    dv = -viewport_h * v / height
    upper_left = center - focus * w - viewport_w * u / 2 + viewport_h * v / 2
    pixel00 = upper_left + 0.5 * (du + dv)
    radius = cam.lens_radius
    out = np.zeros(21)
    out[0:3], out[3:6], out[6:9], out[9:12] = center, pixel00, du, dv
    out[12:15], out[15:18] = u * radius, v * radius
    out[18] = radius
    out[19], out[20] = graph.shutter.open, graph.shutter.close
    return out


def background_array(graph: SceneGraph) -> np.ndarray:
    bg = graph.background
    out = np.zeros(7)
    if isinstance(bg, SkyBackground):
        out[0] = L.BACKGROUND_SKY
        out[1:4], out[4:7] = bg.bottom, bg.top
    else:
        out[0] = L.BACKGROUND_SOLID
        out[1:4] = bg.color
    return out


def with_width(graph: SceneGraph, width: int) -> SceneGraph:
    """The graph rendered at another width, keeping the image's shape."""
    image = graph.image
    update = {"width": width}
    if image.height is not None:
        update["height"] = max(1, round(image.height * width / image.width))
    return dataclasses.replace(graph, image=image.model_copy(update=update))


def scene_tables(graph: SceneGraph) -> SceneTables:
    """Flatten `graph` into tables of primitives, materials and textures: all but the trees."""
    return _Compiler(graph).run()


def compile_scene(graph: SceneGraph, use_bvh: bool = True) -> FlatScene:
    """Flatten `graph` into the arrays the kernels read. Without `use_bvh` every tree is a single
    leaf, so each ray tests every primitive: the brute-force reference the BVH must agree with."""
    # Imported here, not above: the trees are built by compiled code, and the tables alone are
    # made without importing Numba (in rt render's front-end process, see rt/split.py).
    from .assemble import assemble

    return assemble(scene_tables(graph), use_bvh)
