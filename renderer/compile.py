"""Flatten a scene graph into a FlatScene: walk its groups and instances, then build the trees.

The rows themselves are made by each category's module (shapes/, materials.py, textures.py,
media.py, camera.py, background.py); this module only decides where they go. Transforms are
baked into primitives wherever the shape keeps its kind (a transformed quad, triangle, disk or
box is still made of parallelograms, a box kept axis-aligned is still one box row, a sphere
under a similarity is still a sphere), so the common case pays nothing for instancing. Groups
placed by instances become shared bottom-level trees; a sphere under a non-uniform scale
becomes a one-shape instance. A mesh is baked into its group's tree in numpy (shapes/meshes.py);
a group with both shapes and a mesh gets one tree whose root joins a tree over each.
"""

from __future__ import annotations

import dataclasses
import numpy as np

from scenefmt import affine
from scenefmt.graph import GroupNode, InstanceNode, MaterialNode, MediumNode, SceneGraph, ShapeNode, SphereRunNode
from scenefmt.loading import paused_gc
from scenefmt.shapes import sphere_values

from . import background, camera, caustic_targets, environment, grid_media, guiding, light_emission, lights, materials, media, motion
from .bvh import MESH_TRAVERSAL_COST, WIDTH, build_bvh, join, single_leaf, widen
from .flat import FlatScene
from .materials import MAT_READS_UV, MATERIAL_F, MATERIAL_I
from .materials.table import COLOUR_KEYS, MAT_BUMP_MAP, MAT_NORMAL_MAP, texture_rows_of
from .shapes import BOX, MESH_TRIANGLE, PRIM_WIDTH, PRIMITIVE_I, SPHERE, meshes, spheres
from .shapes.dispatch import shape_rows, similarity_of
from .shapes.meshes import MESH_I, TRIANGLE_I
from .textures import TextureTables, perlin_tables
from .trees import INST_ROOT, INST_WORLD_FROM_OBJECT, INSTANCE_F, INSTANCE_I, NODE_I, TLAS_F, TLAS_I, tree_prims


class _Tree:
    """The primitives of one bottom-level tree, in the order they were added: rows added one by
    one, and runs of rows made in numpy (`add_block`), kept in order as blocks."""

    def __init__(self):
        self.kind: list[int] = []
        self.material: list[int] = []
        self.rows: list[list] = []
        self.lo: list[tuple] = []  # bounds over the shutter interval
        self.hi: list[tuple] = []
        self.blocks: list[tuple] = []  # (kind, material, rows, lo, hi) arrays
        self.count = 0
        self.meshes: list[tuple[meshes.MeshRows, int]] = []  # (rows, material row), in numpy

    @property
    def triangles(self) -> int:
        return sum(len(rows.faces) for rows, _ in self.meshes)

    def add(self, kind: int, row: list, material: int, lo, hi) -> None:
        self.kind.append(kind)
        self.material.append(material)
        self.rows.append(row)
        self.lo.append(lo)
        self.hi.append(hi)
        self.count += 1

    def add_block(self, kind: int, material: np.ndarray, rows: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> None:
        """Add rows made in numpy, with a material row each."""
        self._close_block()
        n = len(rows)
        self.blocks.append((np.full(n, kind, np.int32), np.asarray(material, np.int32), rows, lo, hi))
        self.count += n

    def _close_block(self) -> None:
        if self.kind:
            self.blocks.append((np.array(self.kind, np.int32), np.array(self.material, np.int32),
                                np.array(self.rows, np.float64).reshape(-1, PRIM_WIDTH),
                                np.array(self.lo, np.float64).reshape(-1, 3), np.array(self.hi, np.float64).reshape(-1, 3)))
            self.kind, self.material, self.rows, self.lo, self.hi = [], [], [], [], []

    def arrays(self) -> tuple[np.ndarray, ...]:
        """kind, material, rows, lo and hi of every primitive, in the order added."""
        self._close_block()
        if len(self.blocks) != 1:
            self.blocks = [tuple(np.concatenate(parts) for parts in zip(*self.blocks))]
        return self.blocks[0]

    def __len__(self) -> int:
        return self.count

    def empty(self) -> bool:
        return not self.count and not self.meshes


class _Walk:
    """One pass over the graph: material and texture rows as shapes refer to them, a tree per
    group, and the instances that place the groups."""

    def __init__(self, graph: SceneGraph):
        self.graph = graph
        self.shutter = (float(graph.shutter.open), float(graph.shutter.close))
        self.textures = TextureTables()
        self.mat_i: list[list] = []
        self.mat_f: list[list] = []
        self.mat_rows: dict[int, int] = {}
        self.bnd_kind: list[int] = []
        self.bnd_rows: list[list] = []
        # The density fields of varying media, (bnd_f row of the first, its rows), placed among the
        # boundary rows: a grid's rows stay one numpy block (a 256^3 grid as lists would take 30 bytes a value).
        self.bnd_fields: list[tuple[int, np.ndarray]] = []
        self.bnd_count = 0
        self.trees: list[_Tree] = []
        self.tree_of_group: dict[int, int] = {}
        self.instances: list[tuple[int, tuple]] = []
        self.media_count = 0
        # Spheres under a non-similarity (ellipsoids) and moving shapes, each in a tree of its own:
        # shape id -> (tree, its placement in its group).
        self.own_instance: dict[int, tuple] = {}
        # A scene's many shapes share a few transforms.
        self.similarities: dict[tuple, tuple] = {}
        self.last_transform, self.last_similar = None, False

    def _material_row(self, key: int, rows: tuple[list, list]) -> int:
        if key not in self.mat_rows:
            self.mat_rows[key] = len(self.mat_i)
            self.mat_i.append(rows[0])
            self.mat_f.append(rows[1])
        return self.mat_rows[key]

    def material(self, node: MaterialNode) -> int:
        if id(node) in self.mat_rows:
            return self.mat_rows[id(node)]
        slot = next((node.textures[key] for key in COLOUR_KEYS if key in node.textures), None)
        # A material without a colour (a dielectric) attenuates by 1: it still needs a texture
        # row, since the kernels look one up for every scattering material.
        texture = self.textures.add(slot) if slot is not None else self.textures.white()
        # Maps and textured parameters hold numbers (read as linear); an emission is a colour.
        others = {key: self.textures.add(tex, data=key != "emission") for key, tex in node.textures.items()
                  if key not in COLOUR_KEYS}
        return self._material_row(id(node), materials.material_rows(node.model, texture, others))

    def material_reads_uv(self, mat: int) -> bool:
        """Whether any texture of material row `mat` reads surface (u, v)."""
        return any(self.textures.reads_uv(row) for row in texture_rows_of(self.mat_i[mat]))

    def phase(self, medium: MediumNode) -> int:
        """The material row of the isotropic phase function that scatters inside a medium."""
        if id(medium) in self.mat_rows:
            return self.mat_rows[id(medium)]
        return self._material_row(id(medium), materials.phase_function(self.textures.add(medium.albedo), medium.model.phase_g))

    def varying_medium(self, medium: MediumNode, m, first: int, boundaries: int) -> tuple[int, list]:
        """The row of a medium whose density varies, bounded by boundary rows first.., its field's
        rows appended to the boundary table (grid_media.field_rows) in the space of a shape placed
        by m."""
        full = np.eye(4)
        full[:3, :] = np.asarray(m, np.float64).reshape(3, 4)
        medium_from_tree = np.linalg.inv(full)[:3, :]
        header = self.bnd_count
        rows = grid_media.field_rows(medium.model, medium.grid, medium_from_tree, header, perlin_tables)
        self.bnd_fields.append((header, rows))
        self.bnd_count += len(rows)
        majorant = float(rows[0, grid_media.F_MAJORANT])
        return media.medium_row(majorant, first, boundaries, self.media_count, header)

    def similarity(self, m) -> tuple:
        known = self.similarities.get(m)
        if known is None:
            known = self.similarities[m] = similarity_of(m)
        return known

    def add_shape(self, tree: _Tree, shape: ShapeNode, m) -> bool:
        """Append shape's rows (surface and medium) baked through m; False if it needs an instance."""
        mat = self.material(shape.material) if shape.material is not None else None
        if shape.kind == "mesh":
            tree.meshes.append((meshes.mesh_rows(shape.mesh, m, shape.model.smooth), mat))
            return True
        # A box row has no (u, v) and no tangents: a material that reads (u, v) or has a normal or
        # bump map (even one of a solid colour, which reads no (u, v)) gets the six faces as quads.
        as_box = (mat is not None and not self.material_reads_uv(mat)
                  and self.mat_i[mat][MAT_NORMAL_MAP] < 0 and self.mat_i[mat][MAT_BUMP_MAP] < 0)
        surface = shape_rows(shape.model, m, self.similarity(m), self.shutter, as_box)
        if surface is None:
            return False
        if mat is not None:
            for kind, row, lo, hi in surface:
                tree.add(kind, row, mat, lo, hi)
        if shape.interior is not None:
            # A medium's boundary is tested as planes or spheres: a box row's faces are made for it.
            bounds = shape_rows(shape.model, m, self.similarity(m), self.shutter, False) if surface[0][0] == BOX else surface
            first = self.bnd_count
            for kind, row, _, _ in bounds:
                self.bnd_kind.append(kind)
                self.bnd_rows.append(row)
            self.bnd_count += len(bounds)
            if shape.interior.kind == "constant":
                kind, row = media.medium_row(shape.interior.model.density, first, len(bounds), self.media_count)
            else:
                kind, row = self.varying_medium(shape.interior, m, first, len(bounds))
            self.media_count += 1
            lo = tuple(min(r[2][k] for r in bounds) for k in range(3))
            hi = tuple(max(r[3][k] for r in bounds) for k in range(3))
            tree.add(kind, row, self.phase(shape.interior), lo, hi)
        return True

    def place(self, group: GroupNode, world_from_group) -> None:
        """Record the instances that put `group` into the world, flattening nested instances.
        `world_from_group` is an affine map, or a _Moving one."""
        key = id(group)
        if key not in self.tree_of_group:
            tree = _Tree()
            self.tree_of_group[key] = len(self.trees)
            self.trees.append(tree)
            self.fill(group, tree)
        index = self.tree_of_group[key]
        if not self.trees[index].empty():
            self.instances.append((index, world_from_group))
        for member in group.members:
            if isinstance(member, InstanceNode):
                self.place(member.group, _compose(world_from_group, _placement(member.motion, member.transform)))
            elif id(member) in self.own_instance:
                tree, inner = self.own_instance[id(member)]
                self.instances.append((tree, _compose(world_from_group, inner)))

    def own_tree(self, member: ShapeNode) -> None:
        """Put `member` in a tree of its own, placed by an instance: an ellipsoid (a sphere under
        a non-similarity) stays a sphere in its own space, and a moving shape is moved as a whole.
        Its transform is baked into the tree where the shape keeps its kind, else it places it."""
        own = _Tree()
        inner = affine.IDENTITY
        if member.motion is None or not self.add_shape(own, member, member.transform):
            own = _Tree()
            self.add_shape(own, member, affine.IDENTITY)
            inner = member.transform
        self.own_instance[id(member)] = (len(self.trees), _placement(member.motion, inner))
        self.trees.append(own)

    def plain_sphere(self, member) -> bool:
        """Whether member is a sphere with a material, no medium and a similarity transform: one
        of a run that `spheres.sphere_run_rows` flattens at once."""
        if (type(member) is not ShapeNode or member.interior is not None or member.material is None or member.model.type != "sphere"
                or member.motion is not None):
            return False
        m = member.transform
        if m is not self.last_transform:  # shapes without transform steps share one object
            self.last_transform, self.last_similar = m, self.similarity(m)[1] is not None
        return self.last_similar

    def add_spheres(self, tree: _Tree, centers: np.ndarray, radii: np.ndarray, material_rows: np.ndarray, m) -> None:
        """Add plain spheres baked through the similarity m, in their order, with a material row each."""
        rows, lo, hi = spheres.sphere_run_rows(centers, radii, m, *self.similarity(m))
        tree.add_block(SPHERE, material_rows, rows, lo, hi)

    def sphere_run(self, tree: _Tree, run: list) -> None:
        """Add a run of plain sphere nodes, grouped by transform, in their order."""
        start = 0
        for k in range(1, len(run) + 1):
            if k == len(run) or run[k].transform != run[start].transform:
                part = run[start:k]
                values = sphere_values([shape.model for shape in part])
                material_rows = np.array([self.material(shape.material) for shape in part], np.int32)
                self.add_spheres(tree, values[:, :3], values[:, 3], material_rows, part[0].transform)
                start = k

    def sphere_run_node(self, tree: _Tree, run: SphereRunNode) -> None:
        """Add the spheres of a graph's run (no transform of their own), in their order."""
        material_rows = np.array([self.material(node) for node in run.materials], np.int32)[run.material_index]
        self.add_spheres(tree, run.centers, run.radii, material_rows, affine.IDENTITY)

    def fill(self, group: GroupNode, tree: _Tree) -> None:
        run: list[ShapeNode] = []  # plain spheres not yet added
        for member in group.members:
            if self.plain_sphere(member):
                run.append(member)
                continue
            if run:
                self.sphere_run(tree, run)
                run = []
            if isinstance(member, InstanceNode):
                continue
            if isinstance(member, SphereRunNode):
                self.sphere_run_node(tree, member)
                continue
            if member.motion is not None or not self.add_shape(tree, member, member.transform):
                self.own_tree(member)
        if run:
            self.sphere_run(tree, run)


@dataclasses.dataclass(frozen=True)
class _Moving:
    """A placement that moves: world_from_object at each keyframe time (motion.py interpolates)."""

    times: tuple
    maps: tuple  # affine maps, one per time

    def at(self, time: float):
        """The map at `time`, as the kernels interpolate it."""
        m = motion.map_at_numpy(motion.keyframe_rows(self.times, self.maps), time)
        return tuple(tuple(float(x) for x in row) for row in m)


def _placement(node_motion, transform):
    """A member's placement in its group: its transform, or, when it moves, each keyframe's map
    after it."""
    if node_motion is None:
        return transform
    times, maps = node_motion
    return _Moving(times, tuple(affine.compose(m, transform) for m in maps))


def _compose(outer, inner):
    """outer after inner, either of which may move. Where both move, the product is taken at
    every keyframe time of either and interpolated as one motion (exact where the outer moves
    rigidly and the inner stands still, an approximation in between otherwise)."""
    if not isinstance(outer, _Moving) and not isinstance(inner, _Moving):
        return affine.compose(outer, inner)
    if not isinstance(outer, _Moving):
        return _Moving(inner.times, tuple(affine.compose(outer, m) for m in inner.maps))
    if not isinstance(inner, _Moving):
        return _Moving(outer.times, tuple(affine.compose(m, inner) for m in outer.maps))
    times = tuple(sorted(set(outer.times) | set(inner.times)))
    return _Moving(times, tuple(affine.compose(outer.at(t), inner.at(t)) for t in times))


class _MeshTables:
    """The mesh tables of the flat scene, filled tree by tree in leaf order."""

    def __init__(self):
        self.prims_i: list[np.ndarray] = []
        self.tri_i: list[np.ndarray] = []
        self.mesh_i: list[list] = []
        self.verts_f: list[np.ndarray] = []
        self.verts_n: list[np.ndarray] = []
        self.verts_uv: list[np.ndarray] = []
        self.triangles = self.vertices = self.normals = self.uvs = 0

    def add(self, tree_meshes, order: np.ndarray) -> None:
        """Append the meshes of one tree; `order` is its tree's triangle order."""
        tri, kinds = [], []
        for rows, material in tree_meshes:
            row = len(self.mesh_i)
            normals = uvs = -1
            if rows.normals is not None:
                normals = self.normals
                self.verts_n.append(rows.normals)
                self.normals += len(rows.normals)
            if rows.uvs is not None:
                uvs = self.uvs
                self.verts_uv.append(rows.uvs)
                self.uvs += len(rows.uvs)
            self.mesh_i.append(MESH_I.row(first_vertex=self.vertices, normals=normals, uvs=uvs))
            t = np.empty((len(rows.faces), TRIANGLE_I.width), np.int32)
            t[:, 0:3] = rows.faces + self.vertices
            t[:, 3] = row
            tri.append(t)
            kinds.append(np.broadcast_to(np.array([MESH_TRIANGLE, material], np.int32), (len(rows.faces), 2)))
            self.verts_f.append(rows.vertices)
            self.vertices += len(rows.vertices)
        tri_rows = np.concatenate(tri)[order]
        self.tri_i.append(tri_rows)
        self.prims_i.append(np.concatenate(kinds)[order])
        self.triangles += len(tri_rows)


def _inverse_affine(m: np.ndarray) -> np.ndarray:
    full = np.eye(4)
    full[:3, :] = m.reshape(3, 4)
    return np.linalg.inv(full)[:3, :].reshape(12)


def _array(rows: list, layout, dtype) -> np.ndarray:
    return np.array(rows, dtype).reshape(len(rows), layout.width)


def _boundary_tables(walk: _Walk) -> dict:
    """bnd_i and bnd_f: the media's boundary rows, with their density fields' rows where they were
    placed (kind -1: no boundary; a medium finds its field by its header row)."""
    if not walk.bnd_fields:  # every medium constant: the table as it always was
        return {"bnd_i": np.array(walk.bnd_kind, np.int32), "bnd_f": np.array(walk.bnd_rows, np.float64).reshape(-1, PRIM_WIDTH)}
    kinds = np.full(walk.bnd_count, -1, np.int32)
    rows = np.zeros((walk.bnd_count, PRIM_WIDTH))
    taken = np.zeros(walk.bnd_count, bool)
    for first, block in walk.bnd_fields:
        rows[first:first + len(block)] = block
        taken[first:first + len(block)] = True
    free = np.nonzero(~taken)[0]  # the boundary rows, in the order they were added
    kinds[free] = walk.bnd_kind
    if len(free):
        rows[free] = np.array(walk.bnd_rows, np.float64).reshape(-1, PRIM_WIDTH)
    return {"bnd_i": kinds, "bnd_f": rows}


def _assemble(walk: _Walk, use_bvh: bool) -> FlatScene:
    """Build the trees over the walk's rows and lay everything out as a FlatScene."""
    build_tree = build_bvh if use_bvh else single_leaf
    prim_i, prim_f, node_f, node_i = [], [], [], []
    prim_count = node_count = 0
    tree_root, tree_lo, tree_hi = [], [], []
    # Mesh triangles come after every prims_f row in prims_i (see shapes/meshes.py).
    first_triangle = sum(len(tree) for tree in walk.trees)
    mesh = _MeshTables()
    for tree in walk.trees:
        tree_root.append(node_count)
        if tree.empty():
            tree_lo.append(np.full(3, np.inf))
            tree_hi.append(np.full(3, -np.inf))
            continue
        n_prims = len(tree)
        bvh = None
        if n_prims:
            kind, material, rows, lo, hi = tree.arrays()
            bvh = build_tree(lo, hi)
            # The tree's rows in leaf order.
            prim_i.append(np.stack([kind, material], axis=1)[bvh.order])
            prim_f.append(rows[bvh.order])
        tri_base = mesh.triangles
        if tree.meshes:
            lo = np.concatenate([rows.lo for rows, _ in tree.meshes])
            hi = np.concatenate([rows.hi for rows, _ in tree.meshes])
            tris = build_bvh(lo, hi, MESH_TRAVERSAL_COST) if use_bvh else single_leaf(lo, hi)
            mesh.add(tree.meshes, tris.order)
            bvh = tris if bvh is None else join(bvh, tris)
        tree_lo.append(bvh.lo[0])
        tree_hi.append(bvh.hi[0])
        base = prim_count
        prim_count += n_prims
        wide = widen(bvh)
        child = wide.child
        # Offsets become absolute: leaves into the primitive table (a leaf slot past the tree's
        # primitives is a triangle's), interior slots into the nodes.
        codes, counts = child[:, :WIDTH], child[:, WIDTH:]
        leaf_base = np.where(codes < n_prims, base, first_triangle + tri_base - n_prims)
        codes += np.where(counts > 0, leaf_base, np.where(counts == 0, node_count, 0))
        node_f.append(wide.box)
        node_i.append(child)
        node_count += len(child)

    def cat(parts, width, dtype):
        if not parts:
            return np.zeros((0, width), dtype)
        joined = parts[0] if len(parts) == 1 else np.concatenate(parts)
        return np.ascontiguousarray(joined, dtype=dtype)

    # Instances: world bounds from the 8 corners of each tree's root box; a moving instance's
    # over its whole motion (motion.motion_bounds), its keyframes in motion_f.
    count = len(walk.instances)
    open_, close = walk.shutter
    placements, keys, key_rows = [], [], []
    key_count = 0
    for _, m in walk.instances:
        if isinstance(m, _Moving) and close > open_:
            rows = motion.keyframe_rows(m.times, m.maps)
            key_rows.append(rows)
            keys.append((key_count, len(rows)))
            key_count += len(rows)
            m = tuple(tuple(float(x) for x in row) for row in motion.map_at_numpy(rows, open_))
        else:
            # A shutter that never opens sees a moving instance where it is at that time.
            m = m.at(open_) if isinstance(m, _Moving) else m
            keys.append((-1, 0))
            key_rows.append(None)
        placements.append(m)
    o2w = np.array(placements, np.float64).reshape(count, 12)
    inst_lo, inst_hi = np.empty((count, 3)), np.empty((count, 3))
    for k, (tree, _) in enumerate(walk.instances):
        lo, hi = tree_lo[tree], tree_hi[tree]
        if key_rows[k] is not None and np.all(np.isfinite(lo)):
            inst_lo[k], inst_hi[k] = motion.motion_bounds(key_rows[k], lo, hi)
            continue
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        world = corners @ o2w[k].reshape(3, 4)[:, :3].T + o2w[k].reshape(3, 4)[:, 3]
        inst_lo[k], inst_hi[k] = world.min(axis=0), world.max(axis=0)
    moving_rows = [rows for rows in key_rows if rows is not None]
    motion_f = (np.concatenate(moving_rows) if moving_rows else np.zeros((0, motion.MOTION_F.width)))
    inst_i = INSTANCE_I.array(
        count,
        root=[tree_root[tree] for tree, _ in walk.instances],
        untransformed=[int(affine.is_identity(m) and first < 0) for m, (first, _) in zip(placements, keys)],
        serial=np.arange(count),
        first_key=[first for first, _ in keys],
        keys=[n for _, n in keys],
    )
    inst_f = INSTANCE_F.array(count, world_from_object=o2w,
                              object_from_world=np.array([_inverse_affine(m) for m in o2w]).reshape(count, 12))
    tlas = build_tree(inst_lo, inst_hi)
    # Instances in the top-level tree's leaf order.
    order = tlas.order
    mat_i = _array(walk.mat_i, MATERIAL_I, np.int32)
    for row in range(len(mat_i)):
        mat_i[row, MAT_READS_UV] = walk.material_reads_uv(row)
    flat = FlatScene(
        prims_i=cat(prim_i + mesh.prims_i, PRIMITIVE_I.width, np.int32),
        prims_f=cat(prim_f, PRIM_WIDTH, np.float64),
        **_boundary_tables(walk),
        tri_i=cat(mesh.tri_i, TRIANGLE_I.width, np.int32),
        mesh_i=np.array(mesh.mesh_i, np.int32).reshape(-1, MESH_I.width),
        verts_f=cat(mesh.verts_f, 3, np.float64),
        verts_n=cat(mesh.verts_n, 3, np.float64),
        verts_uv=cat(mesh.verts_uv, 2, np.float64),
        nodes_f=cat(node_f, 6 * WIDTH, np.float64),
        nodes_i=cat(node_i, NODE_I.width, np.int64),
        inst_i=np.ascontiguousarray(inst_i[order]),
        inst_f=np.ascontiguousarray(inst_f[order]),
        tlas_f=TLAS_F.array(len(tlas.lo), lo=tlas.lo, hi=tlas.hi),
        tlas_i=TLAS_I.array(len(tlas.a), next=tlas.a, count=tlas.n, axis=tlas.axis),
        motion_f=camera.with_camera_keys(motion_f, walk.graph),
        mat_i=mat_i,
        mat_f=_array(walk.mat_f, MATERIAL_F, np.float64),
        **walk.textures.arrays(),
        camera=np.array(camera.camera_row(walk.graph, first_key=len(motion_f)), np.float64),
        background=np.array(background.background_row(walk.graph), np.float64),
        **lights.no_lights(0, 0),
        **environment.no_environment(),
        **guiding.empty_guide(),
        **caustic_targets.no_targets(len(prim_i) + len(mesh.prims_i), len(walk.mat_i)),
        caustic_lf=light_emission.no_photon_lights(),
    )
    env_tables, env_power = environment.environment_tables(flat, walk.graph)
    flat = flat._replace(**env_tables)
    flat = flat._replace(**lights.light_tables(flat, env_power, walk.graph))
    if walk.graph.image.integrator == "caustics":
        flat = flat._replace(**caustic_tables(flat, env_power))
    return flat


def caustic_tables(flat: FlatScene, env_power: float) -> dict:
    """integrator caustics' tables: the specular spheres photons aim at (the books' metal and
    glass, without a normal or bump map) and the lights that send them."""
    from .materials.table import DIELECTRIC, MAT_KIND, METAL
    from .shapes.spheres import SPHERE_CENTER, SPHERE_RADIUS

    kinds = flat.mat_i[:, MAT_KIND]
    specular = ((kinds == METAL) | (kinds == DIELECTRIC)) & (flat.mat_i[:, MAT_NORMAL_MAP] < 0) & (flat.mat_i[:, MAT_BUMP_MAP] < 0)
    tables = caustic_targets.target_tables(flat, SPHERE, specular, SPHERE_RADIUS, SPHERE_CENTER, INST_ROOT,
                                           INST_WORLD_FROM_OBJECT, tree_prims)
    flat = flat._replace(**tables)
    return {**tables, "caustic_lf": light_emission.photon_lights(flat, env_power)}


def with_integrator(graph: SceneGraph, integrator: str) -> SceneGraph:
    """The graph rendered with another estimator (flat.INTEGRATORS)."""
    return dataclasses.replace(graph, image=graph.image.model_copy(update={"integrator": integrator}))


def with_sampler(graph: SceneGraph, sampler: str) -> SceneGraph:
    """The graph rendered with another sampler (sampling.SAMPLERS)."""
    return dataclasses.replace(graph, image=graph.image.model_copy(update={"sampler": sampler}))


def with_width(graph: SceneGraph, width: int) -> SceneGraph:
    """The graph rendered at another width, keeping the image's shape."""
    image = graph.image
    update = {"width": width}
    if image.height is not None:
        update["height"] = max(1, round(image.height * width / image.width))
    return dataclasses.replace(graph, image=image.model_copy(update=update))


def compile_scene(graph: SceneGraph, use_bvh: bool = True) -> FlatScene:
    """Flatten `graph` into the arrays the kernels read. Without `use_bvh` every tree is a single
    leaf, so each ray tests every primitive: the brute-force reference the BVH must agree with."""
    with paused_gc():
        walk = _Walk(graph)
        walk.place(graph.root, affine.IDENTITY)
        return _assemble(walk, use_bvh)


def camera_values(graph: SceneGraph) -> list[float]:
    """The camera row the kernels read (camera.CAMERA)."""
    return camera.camera_row(graph)
