"""Resolve a validated scene into a node graph: names become edges, defaults are applied.

Edges run texture -> material -> shape -> group -> instance, and medium -> boundary shape.
The renderer consumes this graph, never the raw models. Building it reports dangling
references (with did-you-mean), cycles through groups or textures, missing image files, and
(as warnings) definitions nothing uses.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional, Union

from . import affine, bounds
from .affine import Affine
from .diagnostics import Diagnostic, SceneError, did_you_mean, format_path, quote_key
from .files import FileProblem, open_regular_file
from .assets import AssetCache, memory_message
from .hdr_files import HdrProblem, hdr_header, hdr_peak, is_hdr
from .loading import SourceDocument
from .named_files import NamedFileProblem, locate_named_file
from .materials import Material, texture_fields
from .media import GridMedium, Medium
from .scene import Camera, Image, ImageBackground, Scene, Shutter, SkyBackground, SolidBackground
from .sky import SunSkyBackground
from .shapes import Box, ClosedShapeBase, Disk, Group, Instance, Mesh, MovingSphere, Quad, Sphere, SphereColumns, Triangle
from .textures import CheckerTexture, ImageTexture, NoiseTexture, SolidTexture

MAX_INSTANCE_NESTING = 16


NO_SHAPES = "the image will show only the background (write shapes: [] if that is meant)"

@dataclass(eq=False)
class TextureNode:
    """A texture; `inputs` holds the checker's `even` and `odd` textures."""

    model: Union[SolidTexture, CheckerTexture, ImageTexture, NoiseTexture]
    name: Optional[str]
    path: tuple
    inputs: dict[str, "TextureNode"] = field(default_factory=dict)
    image_path: Optional[Path] = None  # resolved file of an image texture
    image_size: Optional[tuple] = None  # its (width, height), from its header
    image_peak: Optional[float] = None  # the largest value of a float (.exr, .pfm) image; 8-bit ones peak at 1

    @property
    def kind(self) -> str:
        return self.model.type


@dataclass(eq=False)
class MaterialNode:
    """A material; `textures` maps its slot (`albedo`, `emit`) to a texture node."""

    model: Material
    name: Optional[str]
    path: tuple
    textures: dict[str, TextureNode] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        return self.model.type


@dataclass(eq=False)
class MediumNode:
    """A participating medium; `albedo` is its phase function's texture, `grid` a grid medium's
    checked density array (scenefmt.gridfile: read once, here)."""

    model: Medium
    name: Optional[str]
    path: tuple
    albedo: TextureNode
    grid: Optional[object] = None

    @property
    def kind(self) -> str:
        return self.model.type


@dataclass(eq=False)
class ShapeNode:
    """A primitive shape with its material, optional interior medium, and `world_from_object` map
    (relative to the group it belongs to)."""

    model: Union[Sphere, MovingSphere, Quad, Triangle, Disk, Box, Mesh]
    path: tuple
    material: Optional[MaterialNode]
    interior: Optional[MediumNode]
    transform: Affine
    mesh: Optional[object] = None  # a mesh's checked scenefmt.meshfile.MeshData (read once, here)
    # A shape that moves: (times, maps), each map the keyframe's, which follows `transform`;
    # None for one that stands still (keyframes all alike are folded into `transform`).
    motion: Optional[tuple] = None

    @property
    def kind(self) -> str:
        return self.model.type


@dataclass(eq=False)
class SphereRunNode:
    """Consecutive plain spheres of one shape list (shapes.is_plain_sphere: each a `sphere` with a
    named material and no transform or interior of its own), held as columns: a generated scene's
    million spheres are then a few arrays that the bounds, the summary and the flattening read in
    numpy, not a million nodes or models. Sphere k is written at `path_of(k)`."""

    list_path: tuple  # the shape list: ("shapes",) or ("groups", name, "shapes")
    first: int  # the list index of its first sphere
    materials: list[MaterialNode]  # the distinct materials, in the order first used
    material_index: "np.ndarray"  # (n,) int32: each sphere's entry in `materials`
    material_first: "np.ndarray"  # (m,) int64: for each entry of `materials`, the first sphere that uses it
    material_count: "np.ndarray"  # (m,) int64: for each entry of `materials`, how many spheres use it
    centers: "np.ndarray"  # (n, 3) float64
    radii: "np.ndarray"  # (n,) float64

    kind = "sphere_run"
    transform = affine.IDENTITY
    interior = None

    def __len__(self) -> int:
        return len(self.radii)

    @property
    def path(self) -> tuple:
        return self.path_of(0)

    def path_of(self, k: int) -> tuple:
        return self.list_path + (self.first + k,)


# Light-traced caustics join each photon to the camera and aim it at spheres where they stand.
CAUSTICS_STAND_STILL = ("image.integrator caustics needs shapes and a camera that stand still (their photons are aimed "
                        "where things are at the shutter's opening); use mis, the default, with motion")

# A run of fewer plain spheres is made of one ShapeNode each: few nodes cost little, and a scene
# written by hand keeps a node per shape.
SPHERE_RUN_MIN = 256


@dataclass(eq=False)
class InstanceNode:
    """One placement of a group: `group_from_instance` is the instance's own transform."""

    group: "GroupNode"
    path: tuple
    transform: Affine
    # An instance that moves: (times, maps), each map the keyframe's, which follows `transform`.
    motion: Optional[tuple] = None

    kind = "instance"


@dataclass(eq=False)
class GroupNode:
    """An ordered set of shapes and instances; the scene's top level is the group named `None`."""

    name: Optional[str]
    path: tuple
    members: list[Union[ShapeNode, SphereRunNode, InstanceNode]] = field(default_factory=list)


@dataclass(eq=False)
class SceneGraph:
    """The resolved scene: settings plus the root group, and every node reachable from it."""

    camera: Camera
    image: Image
    shutter: Shutter
    background: Union[SolidBackground, SkyBackground, ImageBackground, SunSkyBackground]
    root: GroupNode
    textures: list[TextureNode]
    materials: list[MaterialNode]
    media: list[MediumNode]
    groups: list[GroupNode]
    warnings: list[Diagnostic] = field(default_factory=list)
    source: Optional[str] = None
    memory: Optional[bounds.MemoryEstimate] = None  # what rendering it needs (scenefmt.bounds)
    # An image background (environment map) as the image texture it is read as, at ("background",).
    environment: Optional[TextureNode] = None
    # The scene's lights that are no shape (scenefmt.lights models, world space), in file order:
    # light k is at ("lights", k).
    lights: list = field(default_factory=list)

    @property
    def environment_path(self) -> Optional[Path]:
        """The resolved file of an image background (environment map), or None."""
        return self.environment.image_path if self.environment is not None else None


MAX_TEXTURE_PIXELS = 16384 * 16384


class ImageProblem(ValueError):
    """An image file cannot serve as a texture; the message says why, without the file's name."""


def image_header(path: Path) -> tuple[int, int]:
    """(width, height) of an image file, from its header alone; ImageProblem if it cannot serve
    as a texture (unreadable, or more than MAX_TEXTURE_PIXELS)."""
    from PIL import Image, UnidentifiedImageError

    if is_hdr(path):
        try:
            header = hdr_header(path)
        except HdrProblem as exc:
            raise ImageProblem(str(exc)) from None
        width, height = header.width, header.height
    else:
        try:
            with warnings.catch_warnings(), open_regular_file(path) as fh:
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # the memory estimate says more
                with Image.open(fh) as img:
                    width, height = img.size
        except FileProblem as exc:
            raise ImageProblem(str(exc)) from None
        except UnidentifiedImageError:
            raise ImageProblem("is not a readable image (not a format Pillow can identify)") from None
        except Image.DecompressionBombError:
            raise ImageProblem(f"has more pixels than Pillow decodes ({2 * Image.MAX_IMAGE_PIXELS:,}, "
                               "its decompression-bomb limit)") from None
        except (OSError, ValueError) as exc:  # Pillow's own words may quote the file's header (a PPM's first token): only their kind
            raise ImageProblem(f"is not a readable image (Pillow could not decode its header: {type(exc).__name__})") from None
        except MemoryError:
            raise
        except Exception as exc:  # noqa: BLE001 - a plugin's parsing meets what it did not expect
            raise ImageProblem(f"is not a readable image ({type(exc).__name__} in its header)") from None
    if width * height > MAX_TEXTURE_PIXELS:
        raise ImageProblem(f"is {width} x {height} pixels, more than the {MAX_TEXTURE_PIXELS:,} allowed")
    return width, height


class _Resolver:
    def __init__(self, scene: Scene, doc: Optional[SourceDocument], broken: dict[str, set], shape_paths: Optional[list],
                 columns: Optional[dict] = None):
        self.scene = scene
        self.columns = columns or {}  # list path -> shapes.SphereColumns of its spheres validated in bulk
        self.doc = doc
        self.broken = broken
        self.shape_paths = shape_paths
        self.errors: list[Diagnostic] = []
        self.textures: dict[str, TextureNode] = {}
        self.materials: dict[str, MaterialNode] = {}
        self.media: dict[str, MediumNode] = {}
        self.groups: dict[str, GroupNode] = {}
        self.used: dict[str, set] = {"textures": set(), "materials": set(), "media": set(), "groups": set()}
        self.all_textures: list[TextureNode] = []
        self.all_materials: list[MaterialNode] = []
        self.all_media: list[MediumNode] = []
        self._texture_stack: list[str] = []
        self._group_stack: list[str] = []
        self.mesh_warnings: list[Diagnostic] = []
        self.assets = AssetCache()  # each file read once, however many places name it
        # An OBJ's own materials (mesh_materials.py): its parts, the nodes of its library's
        # entries, and the remarks already made, each once per load.
        self.obj_parts: dict = {}
        self.obj_materials: dict = {}
        self.said_once: set = set()

    # --- reporting -----------------------------------------------------------------------------

    def error(self, path: tuple, message: str) -> None:
        self.errors.append(self.diagnostic(path, message))

    def diagnostic(self, path: tuple, message: str) -> Diagnostic:
        if self.doc is not None:
            return self.doc.diagnostic(path, message)
        return Diagnostic("<scene>", 0, 0, tuple(path), message)

    def check_colour(self, tex: TextureNode, path: tuple, most: float, what: str) -> None:
        """Report a texture whose colour exceeds `most` where it is used as `what`."""
        peak, where = bounds.texture_peak(tex)
        if peak <= most:
            return
        if self.doc is not None and self.doc.written(where + ("color",)):
            where = where + ("color",)
        used = "" if where[: len(path)] == path else f" (it is used at {format_path(path)})"
        self.error(where, f"{what} must be at most {most:g} per channel, found {peak:g}{used}")

    def warn(self, path: tuple, message: str) -> Diagnostic:
        if self.doc is not None:
            return self.doc.diagnostic(path, message, of_key=True, severity="warning")
        return Diagnostic("<scene>", 0, 0, tuple(path), message, "warning")

    def undefined(self, section: str, name: str, path: tuple) -> None:
        if name in self.broken.get(section, ()):
            return  # already reported where it is defined
        kind = {"textures": "texture", "materials": "material", "media": "medium", "groups": "group"}[section]
        defined = list(getattr(self.scene, section)) + list(self.broken.get(section, ()))
        hint = did_you_mean(name, defined)
        if not hint:
            hint = f"; defined {section}: {', '.join(sorted(defined))}" if defined else f"; the scene defines no {section}"
        self.error(path, f"undefined {kind} {quote_key(name)}{hint}")

    # --- textures ------------------------------------------------------------------------------

    def texture_slot(self, value, path: tuple) -> Optional[TextureNode]:
        if isinstance(value, str):
            return self.named_texture(value, path)
        if isinstance(value, tuple):
            node = TextureNode(SolidTexture(color=value), None, path)
            self.all_textures.append(node)
            return node
        return self.texture(value, None, path)

    def named_texture(self, name: str, path: tuple) -> Optional[TextureNode]:
        self.used["textures"].add(name)
        if name in self.textures:
            return self.textures[name]
        if name not in self.scene.textures:
            self.undefined("textures", name, path)
            return None
        if name in self._texture_stack:
            cycle = " -> ".join(self._texture_stack[self._texture_stack.index(name):] + [name])
            self.error(path, f"textures refer to each other in a cycle: {cycle}")
            return None
        self._texture_stack.append(name)
        try:
            node = self.texture(self.scene.textures[name], name, ("textures", name))
        finally:
            self._texture_stack.pop()
        if node is not None:
            self.textures[name] = node
        return node

    def texture(self, model, name: Optional[str], path: tuple) -> Optional[TextureNode]:
        node = TextureNode(model, name, path)
        if isinstance(model, CheckerTexture):
            for slot in ("even", "odd"):
                child = self.texture_slot(getattr(model, slot), path + (slot,))
                if child is None:
                    return None
                node.inputs[slot] = child
        elif isinstance(model, ImageTexture):
            self.image(node)
        self.all_textures.append(node)
        return node

    def image(self, node: TextureNode) -> None:
        """Set the checked file of an image texture node, and the peak of a float one; after
        reporting why, no file."""
        file, where = node.model.file, node.path + ("file",)
        node.image_path = self.named_file("image file", file, where)
        if node.image_path is None:
            return
        try:
            node.image_size = self.assets.get("image", node.image_path, lambda: image_header(node.image_path))
        except ImageProblem as exc:
            self.error(where, f"image file '{file}' {exc}")
            node.image_path = None
            return
        if is_hdr(node.image_path):
            # A float image may hold any value: decode it once, its header and the memory that
            # takes checked first, so its colours are checked as a reflectance or radiance where
            # it is used (and its values are finite and not negative).
            path = node.image_path
            width, height = node.image_size
            need = width * height * bounds.HDR_TEXTURE_BYTES_PER_PIXEL
            if need > bounds.memory_limit():  # the render could not hold it: say so before decoding it
                self.error(where, f"image file '{file}' is {width} x {height} pixels: rendering with it needs about "
                           f"{bounds.gib(need)}, more than {bounds.memory_limit_text()}")
                node.image_path = None
                return
            try:
                node.image_peak = self.assets.get("peak", path, lambda: hdr_peak(path, MAX_TEXTURE_PIXELS, bounds.memory_limit()))
            except HdrProblem as exc:
                self.error(where, f"image file '{file}' {exc}")
                node.image_path = None
            except MemoryError as exc:
                self.error(where, f"image file '{file}': " + memory_message(exc, "decode it", need))
                node.image_path = None

    def named_file(self, kind: str, name: str, path: tuple) -> Optional[Path]:
        """The real path of the file `name` written at `path`, by the one rule for every file a
        scene names (named_files.py: relative to the file that writes it, inside the allowed
        folders, recorded); None after reporting why. Without a document, names are relative to
        the current folder, as for a scene given as data."""
        folder = self.doc.base_dir_of(path) if self.doc is not None else Path.cwd()
        try:
            return locate_named_file(kind, name, folder)
        except NamedFileProblem as exc:
            self.error(path, str(exc))
            return None

    # --- materials and media -------------------------------------------------------------------

    def material_slot(self, value, path: tuple) -> Optional[MaterialNode]:
        if isinstance(value, str):
            self.used["materials"].add(value)
            if value in self.materials:
                return self.materials[value]
            if value not in self.scene.materials:
                self.undefined("materials", value, path)
                return None
            node = self.material(self.scene.materials[value], value, ("materials", value))
            self.materials[value] = node
            return node
        return self.material(value, None, path)

    def material(self, model, name: Optional[str], path: tuple) -> MaterialNode:
        node = MaterialNode(model, name, path)
        for slot, value, role in texture_fields(model):
            where = path + (slot,) if role != "scalar" else path + (slot, "texture")
            tex = self.texture_slot(value, where)
            if tex is not None:
                node.textures[slot] = tex
                if role == "reflectance":
                    self.check_colour(tex, where, bounds.MAX_REFLECTANCE, f"a reflectance ({slot})")
                elif role == "radiance":
                    self.check_colour(tex, where, bounds.MAX_RADIANCE, "an emitted radiance")
        self.all_materials.append(node)
        return node

    def medium_slot(self, value, path: tuple) -> Optional[MediumNode]:
        if isinstance(value, str):
            self.used["media"].add(value)
            if value in self.media:
                return self.media[value]
            if value not in self.scene.media:
                self.undefined("media", value, path)
                return None
            node = self.medium(self.scene.media[value], value, ("media", value))
            if node is not None:
                self.media[value] = node
            return node
        return self.medium(value, None, path)

    def medium(self, model: Medium, name: Optional[str], path: tuple) -> Optional[MediumNode]:
        albedo = self.texture_slot(model.albedo, path + ("albedo",))
        if albedo is None:
            return None
        self.check_colour(albedo, path + ("albedo",), bounds.MAX_REFLECTANCE, "a reflectance (albedo)")
        node = MediumNode(model, name, path, albedo)
        if isinstance(model, GridMedium):
            node.grid = self.grid_data(model, path)
            if node.grid is None:
                return None
        self.all_media.append(node)
        return node

    def grid_data(self, model: GridMedium, path: tuple):
        """A grid medium's checked density array, or None after reporting why."""
        from .gridfile import FileProblem, GridProblem, read_grid

        where, name = path + ("file",), f"grid file '{model.file}'"
        resolved = self.named_file("grid file", model.file, where)
        if resolved is None:
            return None
        try:
            return self.assets.get(f"grid {model.key}", resolved, lambda: read_grid(resolved, model.key))
        except (GridProblem, FileProblem) as exc:
            self.error(where, f"{name}: {exc}")
        except MemoryError as exc:
            self.error(where, f"{name}: " + memory_message(exc, "read it"))
        return None

    # --- shapes and groups ---------------------------------------------------------------------

    def group_slot(self, value, path: tuple) -> Optional[GroupNode]:
        if isinstance(value, str):
            self.used["groups"].add(value)
            if value in self._group_stack:
                cycle = " -> ".join(self._group_stack[self._group_stack.index(value):] + [value])
                self.error(path, f"groups instance each other in a cycle: {cycle}")
                return None
            if value in self.groups:
                return self.groups[value]
            if value not in self.scene.groups:
                self.undefined("groups", value, path)
                return None
            node = self.group(self.scene.groups[value], value, ("groups", value))
            if node is not None:
                self.groups[value] = node
            return node
        return self.group(value, None, path)

    def group(self, model: Group, name: Optional[str], path: tuple) -> Optional[GroupNode]:
        if len(self._group_stack) >= MAX_INSTANCE_NESTING:
            self.error(path, f"instances are nested more than {MAX_INSTANCE_NESTING} deep")
            return None
        self._group_stack.append(name or f"(inline group at {format_path(path)})")
        try:
            node = GroupNode(name, path)
            node.members = self.shape_list(model.shapes, path + ("shapes",))
        finally:
            self._group_stack.pop()
        return node

    def shape_list(self, models: list, list_path: tuple) -> list:
        """The nodes of a list of shapes: a ShapeNode or InstanceNode each, but a SphereRunNode for
        every SPHERE_RUN_MIN or more plain spheres in a row (with a material defined)."""
        import numpy as np

        columns = SphereColumns.of_models(models, self.columns.get(list_path))
        defined = self.scene.materials
        plain = np.zeros(len(models), bool)
        plain[columns.index[np.array([name in defined for name in columns.names], bool)[columns.material_code]]] = True
        edges = np.flatnonzero(np.diff(np.concatenate([[0], plain.view(np.int8), [0]])))
        runs = [(start, end) for start, end in zip(edges[::2].tolist(), edges[1::2].tolist()) if end - start >= SPHERE_RUN_MIN]
        members: list = []
        done = 0
        for start, end in runs + [(len(models), len(models))]:
            for i in range(done, start):
                member = self.shape(models[i], list_path + (i,))
                if isinstance(member, list):  # an OBJ mesh cut by its materials
                    members.extend(member)
                elif member is not None:
                    members.append(member)
            if end > start:
                members.append(self.sphere_run(list_path, start, end, columns))
            done = end
        return members

    def sphere_run(self, list_path: tuple, start: int, end: int, columns: SphereColumns) -> SphereRunNode:
        """The run of plain spheres at places start to end (not included) of a list, from its columns."""
        import numpy as np

        first = int(np.searchsorted(columns.index, start))
        rows = slice(first, first + end - start)
        centers = np.ascontiguousarray(columns.values[rows, :3])
        radii = columns.values[rows, 3].copy()
        code, names = columns.material_code[rows], columns.names
        # The materials in the order first used, as one node a sphere would resolve them, with
        # where each is first used and how often (what the summary and the bounds read).
        used, at, count = np.unique(code, return_index=True, return_counts=True)
        order = np.argsort(at, kind="stable")
        slot = np.zeros(used.max() + 1, np.int32)
        slot[used[order]] = np.arange(len(used), dtype=np.int32)
        materials = [self.material_slot(names[used[k]], list_path + (start + int(at[k]), "material")) for k in order]
        return SphereRunNode(list_path, start, materials, slot[code], at[order].astype(np.int64),
                             count[order].astype(np.int64), centers, radii)

    def motion(self, model, path: tuple, transform: Affine) -> tuple[Affine, Optional[tuple]]:
        """The still transform and the motion (times, keyframe maps) of a shape or instance: keyframes
        that all place it alike fold into the transform, and it stands still."""
        if not model.motion:
            return transform, None
        maps = []
        for k, key in enumerate(model.motion):
            if key.transform:
                bounds.check_transform(key.transform, path + ("motion", k), self.error)
            maps.append(affine.from_steps(key.transform))
        if all(m == maps[0] for m in maps):
            return affine.compose(maps[0], transform), None
        if self.scene.image.integrator == "caustics":
            self.error(path + ("motion",), CAUSTICS_STAND_STILL)
        return transform, (tuple(float(key.time) for key in model.motion), tuple(maps))

    def shape(self, model, path: tuple) -> Union[ShapeNode, InstanceNode, list, None]:
        """The node of one shape; for an OBJ mesh without a material, a list: one node per material
        of its library (mesh_materials.py)."""
        transform = affine.IDENTITY
        if model.transform:
            bounds.check_transform(model.transform, path, self.error)
            transform = affine.from_steps(model.transform)
        transform, motion = self.motion(model, path, transform)
        if isinstance(model, Instance):
            group = self.group_slot(model.group, path + ("group",))
            return InstanceNode(group, path, transform, motion) if group is not None else None
        material = self.material_slot(model.material, path + ("material",)) if model.material is not None else None
        interior = None
        if isinstance(model, ClosedShapeBase) and model.interior is not None:
            interior = self.medium_slot(model.interior, path + ("interior",))
        node = ShapeNode(model, path, material, interior, transform, motion=motion)
        if isinstance(model, Mesh):
            node.mesh = self.mesh_data(model, path)
            if node.mesh is None:
                return None
            if model.material is None:
                from .mesh_materials import material_parts

                return material_parts(self, node, path)
        return node

    def mesh_data(self, model: Mesh, path: tuple):
        """The mesh's checked data (from its file or inline arrays), or None after reporting why."""
        from .meshfile import MeshProblem, from_arrays, read_estimate, read_mesh

        if model.file is None:
            where, name = path + ("faces",), "the inline mesh"
            try:
                mesh = from_arrays(model.vertices, model.faces)
            except MeshProblem as exc:
                self.error(where, f"{name}: {exc}")
                return None
        else:
            where, name = path + ("file",), f"mesh file '{model.file}'"
            resolved = self.named_file("mesh file", model.file, where)
            if resolved is None:
                return None
            try:
                mesh = self.assets.get("mesh", resolved, lambda: read_mesh(resolved))
            except (MeshProblem, FileProblem) as exc:
                line = getattr(exc, "line", None)
                self.error(where, f"{name} line {line}: {exc.message}" if line else f"{name}: {exc}")
                return None
            except MemoryError as exc:
                self.error(where, f"{name}: " + memory_message(exc, "read it", read_estimate(resolved)))
                return None
            if mesh.mtllib_line is not None and model.material is not None:
                self.mesh_warnings.append(self.warn(
                    where, f"{name} names a material library (mtllib, line {mesh.mtllib_line}): the OBJ's materials are "
                    "not read; the shape's material: is used for every face"))
        if mesh.degenerate:
            self.mesh_warnings.append(self.warn(
                where, f"{name}: {mesh.degenerate:,} of its {len(mesh.faces) + mesh.degenerate:,} triangles have zero area and are left out"))
        return mesh

    # --- the whole scene -----------------------------------------------------------------------

    def resolve(self) -> SceneGraph:
        scene = self.scene
        root = GroupNode(None, ())
        if self.shape_paths is None:
            root.members = self.shape_list(scene.shapes, ("shapes",))
        else:  # a partly valid scene, for its errors: its shapes keep their places in the file
            for shape, path in zip(scene.shapes, self.shape_paths):
                member = self.shape(shape, path)
                if isinstance(member, list):  # an OBJ mesh cut by its materials
                    root.members.extend(member)
                elif member is not None:
                    root.members.append(member)
        # Definitions nothing reached are still checked (so their errors show), then reported as
        # unused; a group goes first since resolving it marks what it uses.
        warnings = []
        for section, resolve_one in (
            ("groups", lambda n: self.group_slot(n, ("groups", n))),
            ("materials", lambda n: self.material_slot(n, ("materials", n))),
            ("media", lambda n: self.medium_slot(n, ("media", n))),
            ("textures", lambda n: self.named_texture(n, ("textures", n))),
        ):
            for name in [n for n in getattr(scene, section) if n not in self.used[section]]:
                resolve_one(name)
                kind = {"textures": "texture", "materials": "material", "media": "medium", "groups": "group"}[section]
                warnings.append(self.warn((section, name), f"{kind} '{name}' is defined but never used"))
        if not scene.shapes and "shapes" not in scene.model_fields_set:
            # Valid, but most likely a mistake (an empty file, a shapes key misplaced): the image
            # shows the background alone. `shapes: []` says it is meant, as in weekend_sky.yaml.
            if self.doc is not None and not self.doc.data:
                warnings.append(self.warn((), f"the scene is empty: {NO_SHAPES}"))
            else:
                warnings.append(self.warn((), f"the scene has no shapes key: {NO_SHAPES}"))
        if scene.camera.moves and scene.image.integrator == "caustics":
            self.error(("camera", "motion"), CAUSTICS_STAND_STILL)
        if scene.lights and scene.image.integrator == "path":
            # Valid, but they would light nothing: a path meets no point and no direction by chance.
            warnings.append(self.warn(("lights",), "point, spot and directional lights light nothing with image.integrator "
                                      "path, which finds a light only by hitting it; use mis (the default) to sample them"))
        background = scene.background
        if isinstance(background, tuple):
            background = SolidBackground(color=background)
        for key in ("color", "bottom", "top"):
            colour = getattr(background, key, None)
            if colour is not None and max(colour) > bounds.MAX_RADIANCE:
                where = ("background",) if isinstance(scene.background, tuple) else ("background", key)
                self.error(where, f"a background radiance must be at most {bounds.MAX_RADIANCE:g} per channel, found {max(colour):g}")
        environment = self.environment(background) if isinstance(background, ImageBackground) else None
        return SceneGraph(
            camera=scene.camera,
            image=scene.image,
            shutter=scene.shutter,
            background=background,
            root=root,
            textures=self.all_textures,
            materials=self.all_materials,
            media=self.all_media,
            groups=list(self.groups.values()),
            warnings=self.mesh_warnings + warnings,
            source=self.doc.file if self.doc is not None else None,
            environment=environment,
            lights=list(scene.lights),
        )

    def environment(self, model: ImageBackground) -> TextureNode:
        """An environment map as the image texture it is read as (an 8-bit image as sRGB): its file
        checked, and a float one read whole, as any image texture's; its brightest value times
        `strength` is then checked as a radiance (at most bounds.MAX_RADIANCE)."""
        node = TextureNode(ImageTexture(file=model.file, colorspace="srgb"), None, ("background",))
        self.image(node)
        peak = bounds.texture_peak(node)[0]
        if node.image_path is not None and peak * model.strength > bounds.MAX_RADIANCE:
            self.error(("background", "strength"), f"a background radiance must be at most {bounds.MAX_RADIANCE:g} per channel, "
                       f"found {peak * model.strength:g} (the image's brightest value {peak:g} times strength {model.strength:g})")
        return node


def build_graph(
    scene: Scene,
    doc: Optional[SourceDocument] = None,
    *,
    broken: Optional[dict[str, set]] = None,
    shape_paths: Optional[list] = None,
    columns: Optional[dict] = None,
) -> SceneGraph:
    """Resolve `scene` into a `SceneGraph`; raises `SceneError` listing every problem. `columns`
    holds the spheres `shapes.plain_spheres` validated in bulk, by the path of their list."""
    resolver = _Resolver(scene, doc, broken or {}, shape_paths, columns)
    graph = resolver.resolve()
    if resolver.errors:
        raise SceneError(resolver.errors)
    # What the scene implies once expanded (extents through instances, memory), on a sound graph.
    problems, graph.memory = bounds.check_scene(graph, resolver.diagnostic)
    if problems:
        raise SceneError(problems)
    return graph


def graph_problems(scene: Scene, doc: Optional[SourceDocument], broken: dict[str, set], shape_paths: list) -> list[Diagnostic]:
    """The graph errors of a partially valid scene (used to report all errors of a file at once)."""
    resolver = _Resolver(scene, doc, broken, shape_paths)
    resolver.resolve()
    return resolver.errors
