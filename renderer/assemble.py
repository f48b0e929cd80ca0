"""Finish a flattened scene: build the BVHs over its tables and lay everything out as a FlatScene."""

from __future__ import annotations

import numpy as np

from . import layout as L
from .bvh import WIDTH, build_bvh, single_leaf, widen
from .flat import FlatScene
from .tables import SceneTables
from .textures import perlin_tables


def _inverse_affine(m: np.ndarray) -> np.ndarray:
    full = np.eye(4)
    full[:3, :] = m.reshape(3, 4)
    return np.linalg.inv(full)[:3, :].reshape(12)


def assemble(tables: SceneTables, use_bvh: bool = True) -> FlatScene:
    """The FlatScene of `tables`. Without `use_bvh` every tree is a single leaf (see compile_scene)."""
    build_tree = build_bvh if use_bvh else single_leaf
    prim_kind, prim_rows, prim_mat = [], [], []
    prim_count = 0
    node_box, node_child = [], []
    node_count = 0
    blas_root, blas_lo, blas_hi = [], [], []
    for tree_tables in tables.blas:
        blas_root.append(node_count)
        if not len(tree_tables):
            blas_lo.append(np.full(3, np.inf))
            blas_hi.append(np.full(3, -np.inf))
            continue
        kind, rows, mat, lo, hi = tree_tables.as_numpy()
        tree = build_tree(lo, hi)
        blas_lo.append(tree.lo[0])
        blas_hi.append(tree.hi[0])
        base = prim_count
        # The tree's rows in leaf order.
        prim_kind.append(kind[tree.order])
        prim_rows.append(rows[tree.order])
        prim_mat.append(mat[tree.order])
        prim_count += len(tree.order)
        wide = widen(tree)
        child = wide.child
        # Offsets become absolute: leaves into the primitive table, interior slots into the nodes.
        codes, counts = child[:, :WIDTH], child[:, WIDTH:]
        codes += np.where(counts > 0, base, np.where(counts == 0, node_count, 0))
        node_box.append(wide.box)
        node_child.append(child)
        node_count += len(child)

    def cat(parts, shape, dtype):
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(shape, dtype)

    # Instances: world bounds from the 8 corners of each tree's root box.
    inst_root, inst_ident, inst_o2w, inst_w2o, ilo, ihi = [], [], [], [], [], []
    for blas, m, identity in tables.instances:
        root = blas_root[blas]
        o2w = np.array(m, dtype=np.float64).reshape(12)
        lo, hi = blas_lo[blas], blas_hi[blas]
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        linear = o2w.reshape(3, 4)[:, :3]
        world = corners @ linear.T + o2w.reshape(3, 4)[:, 3]
        inst_root.append(root)
        inst_ident.append(1 if identity else 0)
        inst_o2w.append(o2w)
        inst_w2o.append(_inverse_affine(o2w))
        ilo.append(world.min(axis=0))
        ihi.append(world.max(axis=0))
    tlas = build_tree(np.array(ilo).reshape(-1, 3), np.array(ihi).reshape(-1, 3))
    order = tlas.order
    tlas_a = tlas.a.astype(np.int32)

    def pick(values, shape, dtype):
        arr = np.array(values, dtype=dtype).reshape(shape)
        return np.ascontiguousarray(arr[order]) if len(values) else arr

    tex_rows, mat_rows = tables.tex_rows, tables.mat_rows
    n_tex = len(tex_rows)
    tex_kind = np.array([r[0] for r in tex_rows], np.int32).reshape(n_tex)
    tex_color = np.array([r[1] for r in tex_rows], np.float64).reshape(n_tex, 3)
    tex_param = np.array([r[2] for r in tex_rows], np.float64).reshape(n_tex, 4)
    tex_child = np.array([r[3] for r in tex_rows], np.int32).reshape(n_tex, 2)
    n_mat = len(mat_rows)
    texels = np.concatenate(tables.texel_chunks).astype(np.float32) if tables.texel_chunks else np.zeros((1, 3), np.float32)
    if tables.noise_seeds:
        noise = [perlin_tables(seed) for seed in tables.noise_seeds]
        noise_perm = np.stack([p for p, _ in noise]).astype(np.int32)
        noise_vec = np.stack([v for _, v in noise]).astype(np.float64)
    else:
        noise_perm = np.zeros((1, 3, 256), np.int32)
        noise_vec = np.zeros((1, 256, 3), np.float64)
    inst_o2w_arr = pick(inst_o2w, (-1, 12), np.float64)
    inst_w2o_arr = pick(inst_w2o, (-1, 12), np.float64)
    return FlatScene(
        prims_i=np.stack([cat(prim_kind, (0,), np.int32), cat(prim_mat, (0,), np.int32)], axis=1),
        prims_f=cat(prim_rows, (0, L.PRIM_WIDTH), np.float64),
        bnd_i=np.array(tables.bnd_kind, np.int32),
        bnd_f=np.array(tables.bnd_rows, np.float64).reshape(-1, L.PRIM_WIDTH),
        nodes_f=np.ascontiguousarray(cat(node_box, (0, 6 * WIDTH), np.float64)),
        nodes_i=np.ascontiguousarray(cat(node_child, (0, 2 * WIDTH), np.int64)),
        inst_i=np.ascontiguousarray(
            np.stack(
                [pick(inst_root, (-1,), np.int32), pick(inst_ident, (-1,), np.int32),
                 pick(list(range(len(inst_root))), (-1,), np.int32)],
                axis=1,
            ).reshape(-1, 3)
        ),
        inst_f=np.ascontiguousarray(np.concatenate([inst_o2w_arr, inst_w2o_arr], axis=1).reshape(-1, 24)),
        tlas_f=np.ascontiguousarray(np.concatenate([tlas.lo, tlas.hi], axis=1)),
        tlas_i=np.ascontiguousarray(np.stack([tlas_a, tlas.n, tlas.axis], axis=1).astype(np.int32)),
        mat_i=np.array([(r[0], r[1], r[3]) for r in mat_rows], np.int32).reshape(n_mat, 3),
        mat_f=np.array([r[2] for r in mat_rows], np.float64).reshape(n_mat, 2),
        tex_i=np.concatenate([tex_kind.reshape(-1, 1), tex_child], axis=1).astype(np.int32),
        tex_f=np.ascontiguousarray(np.concatenate([tex_color, tex_param], axis=1)),
        texels=texels,
        noise_perm=noise_perm,
        noise_vec=noise_vec,
        camera=np.array(tables.camera, np.float64),
        background=np.array(tables.background, np.float64),
    )
