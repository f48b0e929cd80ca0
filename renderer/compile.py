"""Flatten a scene graph into tables of primitives, materials and textures; `assemble` adds the BVHs.

Transforms are baked into primitives wherever the shape keeps its kind (a transformed quad,
triangle, disk or box is still made of parallelograms, a box kept axis-aligned is still one box
row, a sphere under a similarity is still a sphere), so the common case pays nothing for
instancing. Groups placed by instances become
shared bottom-level trees; a sphere under a non-uniform scale becomes a one-shape instance.

The arithmetic is on Python floats, not numpy arrays: scenes have thousands of rows, and numpy's
per-call cost on 3-vectors made flattening six times as slow; and without numpy the `rt render`
front end never imports it (0.07 s) for a scene without image textures (see tables.py).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Optional

from scenefmt import affine
from scenefmt.diagnostics import format_path
from scenefmt.graph import GroupNode, InstanceNode, MaterialNode, MediumNode, SceneGraph, ShapeNode, TextureNode
from scenefmt.scene import SkyBackground

from . import layout as L
from .tables import SceneTables, TreeTables

if TYPE_CHECKING:
    import numpy as np

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


Vec = tuple[float, float, float]


def _linear(m) -> tuple[Vec, Vec, Vec]:
    """The 3x3 linear part of an affine transform, as rows."""
    return tuple(tuple(float(x) for x in row[:3]) for row in m)  # type: ignore[return-value]


def _cross(a, b) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a, b) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _add(a, b) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a, b) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _scale(a, s: float) -> Vec:
    return (a[0] * s, a[1] * s, a[2] * s)


def _unit(a) -> Vec:
    length = math.sqrt(_dot(a, a))
    return (a[0] / length, a[1] / length, a[2] / length)


def _mul(lin, v) -> Vec:
    """lin @ v for a 3x3 matrix given as rows."""
    return tuple(_dot(row, v) for row in lin)  # type: ignore[return-value]


def _det(lin) -> float:
    return _dot(lin[0], _cross(lin[1], lin[2]))


def _similarity_scale(lin) -> Optional[float]:
    """s when lin = s * (an orthogonal matrix), else None: lin^T lin = s^2 I within 1e-9."""
    cols = [tuple(row[k] for row in lin) for k in range(3)]
    s2 = _dot(cols[0], cols[0])
    if s2 <= 0:
        return None
    for i in range(3):
        for j in range(3):
            target = s2 if i == j else 0.0
            if not abs(_dot(cols[i], cols[j]) - target) <= 1e-12 * s2 + 1e-9 * abs(target):
                return None
    return math.sqrt(s2)


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
        self.noise_seeds: list[int] = []
        self.mat_rows: list[tuple] = []
        self.mat_ids: dict[int, int] = {}
        self.phase_ids: dict[int, int] = {}
        self.bnd_kind: list[int] = []
        self.bnd_rows: list[list[float]] = []
        self.blas: list[TreeTables] = []
        self.blas_of_group: dict[int, int] = {}
        self.instances: list[tuple[int, tuple]] = []
        self.media_count = 0
        # Spheres under a non-similarity (ellipsoids), each in a tree of its own: shape id -> tree.
        self.own_instance: dict[int, int] = {}
        self.similarity_of: dict[tuple, tuple[tuple, Optional[float]]] = {}

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
            from .textures import load_image_texels  # numpy and Pillow, for scenes with images only

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
            param = (m.scale, float(form), float(m.octaves), float(len(self.noise_seeds)))
            color = m.color
            self.noise_seeds.append(m.seed)  # assemble makes its tables
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

    def similarity(self, m) -> tuple[tuple, Optional[float]]:
        """(linear part, similarity scale or None) of m, cached: a scene's many spheres share a
        few transforms."""
        known = self.similarity_of.get(m)
        if known is None:
            lin = _linear(m)
            known = self.similarity_of[m] = (lin, _similarity_scale(lin))
        return known

    def sphere_row(self, shape: ShapeNode, m) -> Optional[tuple[int, list, Vec, Vec]]:
        """(kind, row, lo, hi) of a sphere baked through m, or None if m is not a similarity."""
        lin, s = self.similarity(m)
        if s is None:
            return None
        # The object_from_world rotation for the uv frame, (lin / s) transposed, row by row.
        rot = [lin[j][i] / s for i in range(3) for j in range(3)]
        model = shape.model
        r = model.radius * s
        row = [0.0] * L.PRIM_WIDTH
        row[3] = r
        if model.type == "sphere":
            c = affine.apply_point(m, model.center)
            row[0:3] = c
            row[4:13] = rot
            return L.SPHERE, row, _sub(c, (r, r, r)), _add(c, (r, r, r))
        c0, c1 = affine.apply_point(m, model.center0), affine.apply_point(m, model.center1)
        span = self.shutter_close - self.shutter_open
        vel = tuple((c1[k] - c0[k]) / span for k in range(3)) if span > 0 else (0.0, 0.0, 0.0)
        row[0:3] = _sub(c0, _scale(vel, self.shutter_open))
        row[4:7] = vel
        row[7:16] = rot
        if span == 0:
            c1 = c0
        lo = tuple(min(c0[k], c1[k]) - r for k in range(3))
        hi = tuple(max(c0[k], c1[k]) + r for k in range(3))
        return L.MOVING_SPHERE, row, lo, hi

    def planar_rows(self, shape: ShapeNode, m) -> list[tuple[int, list, tuple, tuple]]:
        lin = _linear(m)
        flip = _det(lin) < 0
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
            p0, p1, p2 = (tuple(float(x) for x in p) for p in model.vertices)
            add(L.TRIANGLE, p0, _sub(p1, p0), _sub(p2, p0), ((0, 0), (1, 0), (0, 1)))
        elif model.type == "disk":
            n = _unit(tuple(float(x) for x in model.normal))
            helper = (1.0, 0.0, 0.0) if abs(n[0]) < 0.9 else (0.0, 1.0, 0.0)
            a = _unit(_cross(helper, n))
            b = _cross(n, a)  # a x b = n
            r = model.radius
            q2, u2, v2 = affine.apply_point(m, model.center), _mul(lin, _scale(a, r)), _mul(lin, _scale(b, r))
            ext = tuple(math.sqrt(u2[k] * u2[k] + v2[k] * v2[k]) for k in range(3))
            out.append((L.DISK, _planar_row(q2, u2, v2, flip), _sub(q2, ext), _add(q2, ext)))
        else:  # box
            lo, hi = tuple(float(x) for x in model.min), tuple(float(x) for x in model.max)
            size = _sub(hi, lo)
            for corner, u_axis, v_axis in _BOX_FACES:
                q = tuple(hi[k] if corner[k] > 0 else lo[k] for k in range(3))
                u = tuple(u_axis[k] * size[k] for k in range(3))
                v = tuple(v_axis[k] * size[k] for k in range(3))
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
                tables.add(kind, row, mat, lo, hi)
        if shape.interior is not None:
            # A medium's boundary is tested as planes: a box row's faces are made for it.
            rows = self.planar_rows(shape, m) if surface[0][0] == L.BOX else surface
            start = len(self.bnd_rows)
            for kind, row, _, _ in rows:
                self.bnd_kind.append(kind)
                self.bnd_rows.append(row)
            medium = [0.0] * L.PRIM_WIDTH
            medium[0] = -1.0 / shape.interior.model.density
            medium[1] = start
            medium[2] = len(rows)
            # A serial number independent of the BVH's row order keys the medium's random numbers.
            medium[3] = self.media_count
            self.media_count += 1
            lo = tuple(min(r[2][k] for r in rows) for k in range(3))
            hi = tuple(max(r[3][k] for r in rows) for k in range(3))
            tables.add(L.MEDIUM, medium, self.phase(shape.interior), lo, hi)
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
        if len(self.blas[blas]):
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
            blas=self.blas,
            instances=[(blas, m, affine.is_identity(m)) for blas, m in self.instances],
            tex_rows=self.tex_rows,
            mat_rows=[(kind, tex, param, self.reads_uv(tex)) for kind, tex, param in self.mat_rows],
            texel_chunks=self.texel_chunks,
            noise_seeds=self.noise_seeds,
            bnd_kind=self.bnd_kind,
            bnd_rows=self.bnd_rows,
            camera=camera_values(self.graph),
            background=background_values(self.graph),
        )


def camera_values(graph: SceneGraph) -> tuple[float, ...]:
    """The camera as the kernels read it (the second book's thin-lens camera), 21 values: origin,
    pixel00, du, dv, the lens disk's two axes, lens radius, shutter open and close."""
    cam, image = graph.camera, graph.image
    width, height = image.width, image.pixel_height
    center = tuple(float(x) for x in cam.look_from)
    focus = cam.focus
    viewport_h = 2.0 * math.tan(math.radians(cam.vfov) / 2.0) * focus
    viewport_w = viewport_h * (width / height)
    w = _unit(_sub(center, cam.look_at))
    u = _unit(_cross(cam.up, w))
    v = _cross(w, u)
    du = tuple(viewport_w * u[k] / width for k in range(3))
    dv = tuple(-viewport_h * v[k] / height for k in range(3))
    upper_left = tuple(center[k] - focus * w[k] - viewport_w * u[k] / 2 + viewport_h * v[k] / 2 for k in range(3))
    pixel00 = tuple(upper_left[k] + 0.5 * (du[k] + dv[k]) for k in range(3))
    radius = cam.lens_radius
    return (*center, *pixel00, *du, *dv, *_scale(u, radius), *_scale(v, radius), float(radius),
            float(graph.shutter.open), float(graph.shutter.close))


def background_values(graph: SceneGraph) -> tuple[float, ...]:
    """7 values: kind, then the colour (and zeros) or the sky's bottom and top colours."""
    bg = graph.background
    if isinstance(bg, SkyBackground):
        return (float(L.BACKGROUND_SKY), *map(float, bg.bottom), *map(float, bg.top))
    return (float(L.BACKGROUND_SOLID), *map(float, bg.color), 0.0, 0.0, 0.0)


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
