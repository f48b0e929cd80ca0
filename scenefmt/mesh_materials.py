"""An OBJ mesh with no `material:` of its own: its faces get the materials of its .mtl library.

The mesh is cut by `usemtl` into one mesh per material (`meshfile.split_by_material`) while the
graph is built, each part a shape node of its own with one material node. That is the cheapest
place to split: everything after the graph (the bounds, the effect summary, the lights made from
emissive shapes, the flattening) already handles a mesh of one material, and a part is exactly
the mesh its faces would make written alone, so the renderer needs no change and an OBJ of two
materials renders as the same scene written by hand with two meshes.

The libraries and their image maps are files a scene names: they resolve by named_files' rule
(relative to the OBJ, a map relative to its library, inside the allowed folders), each is read
once per load (assets.AssetCache), and what its materials drop is said once per library.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path
from typing import Optional

from .diagnostics import quote_key
from .files import FileProblem
from .materials import Lambertian
from .meshfile import split_by_material
from .mtl import DEFAULT_ALBEDO, MAX_LIBRARIES, MAX_OBJ_MATERIALS, MtlProblem, hide_name, material_of, quote_file, read_mtl
from .named_files import NamedFileProblem, locate_named_file


def material_parts(resolver, node, path: tuple) -> Optional[list]:
    """The shape nodes of `node`'s OBJ mesh, one per material of its library (the model has no
    `material`); None after reporting why there are none."""
    model, mesh = node.model, node.mesh
    where = path + ("file",)
    name = f"mesh file '{model.file}'"
    if not mesh.mtllibs:
        resolver.error(path, f"{name} names no material library (mtllib), so the shape needs a `material`")
        return None
    if len(mesh.mtllibs) > MAX_LIBRARIES:
        resolver.error(where, f"{name} names {len(mesh.mtllibs):,} material libraries, more than the {MAX_LIBRARIES} allowed")
        return None
    if len(mesh.material_names) > MAX_OBJ_MATERIALS:
        resolver.error(where, f"{name} uses {len(mesh.material_names):,} materials (usemtl names), more than the "
                              f"{MAX_OBJ_MATERIALS:,} allowed: each becomes a mesh of its own")
        return None
    base = resolver.doc.base_dir_of(where) if resolver.doc is not None else Path.cwd()
    obj_folder = (Path(base) / model.file).parent
    entries: dict = {}  # material name -> (library key, library folder, library name, entry)
    for line, library in mesh.mtllibs:
        try:
            resolved = locate_named_file("material library", library, obj_folder)
        except NamedFileProblem as exc:
            resolver.error(where, f"{name} line {line}: {hide_name(str(exc), library)}")
            return None
        try:
            read = resolver.assets.get("mtl", resolved, lambda: read_mtl(resolved))
        except (MtlProblem, FileProblem) as exc:
            resolver.error(where, f"{name} line {line}: material library {quote_file(library)} {exc}")
            return None
        if _first_time(resolver, ("mtl", str(resolved))):
            for at, message in read.warnings:
                resolver.mesh_warnings.append(resolver.warn(where, f"material library {quote_file(library)} line {at}: {message}"))
        folder = (obj_folder / library).parent
        for material, entry in read.materials.items():
            entries.setdefault(material, (str(resolved), folder, library, entry))
    cache = resolver.obj_parts
    key = (id(mesh), bool(model.smooth))
    if key not in cache:
        cache[key] = (mesh, split_by_material(mesh, model.smooth))  # the mesh kept: its id stays its own
    parts = cache[key][1]
    out = []
    for label, part in parts:
        material = mesh.material_names[label] if label >= 0 else None
        found = entries.get(material) if material is not None else None
        if found is None:
            material_node = _default(resolver, where, name, mesh, material, len(part.faces))
            source = "no entry"
        else:
            material_node = _library_material(resolver, where, name, found)
            if material_node is None:
                return None
            source = f"from {quote_file(found[2])}"
        shown = "no usemtl" if material is None else f"usemtl {quote_key(material)}"
        part.material_note = f"{shown}: {material_node.model.type} ({source})"
        out.append(replace(node, material=material_node, mesh=part))
    return out


def _first_time(resolver, key: tuple) -> bool:
    """Whether `key` is met for the first time in this load (so a remark is made once)."""
    seen = resolver.said_once
    if key in seen:
        return False
    seen.add(key)
    return True


def _library_material(resolver, where: tuple, name: str, found: tuple):
    """The material node of one library entry, made once per load; None after an error."""
    library_key, folder, library, entry = found
    made = resolver.obj_materials
    if (library_key, entry.name) in made:
        return made[(library_key, entry.name)]
    failed = []
    named: dict = {}  # the absolute name given to each image texture -> the name the library wrote

    def map_file(key: str, ref) -> Optional[str]:
        try:
            locate_named_file("image file", ref.file, folder)
        except NamedFileProblem as exc:
            failed.append(f"material library {quote_file(library)} line {ref.line}: {key}: {hide_name(str(exc), ref.file)}")
            return None
        absolute = os.path.abspath(folder / ref.file)  # an absolute name: the image is then checked as any other
        named[absolute] = ref.file
        return absolute

    try:
        model, warnings = material_of(entry, map_file)
    except ValueError as exc:  # pydantic's ValidationError: a value no rule of the mapping bounded
        resolver.error(where, f"{name}: material library {quote_file(library)} line {entry.line}: material "
                              f"{quote_key(entry.name)} cannot be made ({type(exc).__name__})")
        return None
    for message in failed:
        resolver.error(where, f"{name}: {message}")
    if failed:
        return None
    for at, message in warnings:
        resolver.mesh_warnings.append(resolver.warn(
            where, f"material library {quote_file(library)} line {at}: material {quote_key(entry.name)}: {message}"))
    first = len(resolver.errors)
    node = resolver.material(model, None, where)
    # What the material's own checks found (an image that does not decode, an emission too
    # bright) is said of the library's entry, not of a key path that the scene file never wrote.
    for k in range(first, len(resolver.errors)):
        message = resolver.errors[k].message
        for absolute, written in named.items():  # the image by the name the library gave it
            message = message.replace(f"'{absolute}'", quote_file(written))
        resolver.errors[k] = resolver.diagnostic(where, f"{name}: material library {quote_file(library)} line {entry.line}: "
                                                        f"material {quote_key(entry.name)}: {message}")
    made[(library_key, entry.name)] = node
    return node


def _default(resolver, where: tuple, name: str, mesh, material: Optional[str], faces: int):
    """The light grey lambertian of faces whose `usemtl` names no entry (or that come before any),
    said once per mesh file and name."""
    if _first_time(resolver, ("usemtl", id(mesh), material)):
        if material is None:
            what = f"{faces:,} triangles come before any usemtl"
        else:
            what = f"usemtl {quote_key(material)} names no material of its libraries ({faces:,} triangles)"
        resolver.mesh_warnings.append(resolver.warn(where, f"{name}: {what}: they get a grey lambertian "
                                                           f"(albedo {DEFAULT_ALBEDO[0]:g})"))
    made = resolver.obj_materials
    if "default" not in made:
        made["default"] = resolver.material(Lambertian(albedo=DEFAULT_ALBEDO), None, where)
    return made["default"]
