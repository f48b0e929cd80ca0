"""What a glTF document says, as one of our scenes: the plan `rt import` writes out.

`plan_import(doc, options)` reads a `gltf_read.GltfDocument` and returns an `ImportPlan`: the
scene's plain data (checked by our models), the meshes to write as PLY files and the image files
to write beside it, the warnings (what glTF has that our format does not), and the header
comment. It writes nothing itself (`rt/importing.py` does).

Conventions (docs/import.md):
- glTF is in metres, right-handed, +Y up, a model's front toward +Z; so is our format: nothing is
  converted. glTF texture coordinates start at the image's top-left corner, ours at its
  bottom-left: v becomes 1 - v.
- Node transforms are composed down the hierarchy into each placement's world matrix; a mesh
  placed once is written as shapes with that transform, a mesh placed several times as a group
  (written once) and an instance per placement. Lights are world-space in our format (never in
  a group), so they take their node's world position and direction.
- KHR_lights_punctual intensities are photometric (candela, lux); ours are radiometric (W/sr,
  W/m^2). They are divided by `lumens_per_watt` (683 lm/W by default, the luminous efficacy of
  555 nm light that defines the candela); 1 takes them as radiometric already.
"""

from __future__ import annotations

import io
import math
import re
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Optional

import numpy as np

from .diagnostics import quote_text
from .gltf_read import GltfDocument, GltfProblem, as_float, as_floats, as_int, image_bytes, read_accessor

LUMENS_PER_WATT = 683.0
TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN = 4, 5, 6
_MODES = {0: "points", 1: "lines", 2: "line loops", 3: "line strips"}
# Extensions read (in part: the warnings say which parts are not).
KNOWN_EXTENSIONS = {
    "KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_materials_transmission", "KHR_materials_ior",
    "KHR_materials_specular", "KHR_materials_clearcoat", "KHR_materials_volume",
}
_NAME_CHARS = re.compile(r"[^A-Za-z0-9_\-]")


@dataclass
class ImportOptions:
    prefix: str = ""  # put before every name, so that two imported models can be included together
    assets: str = "model_assets"  # the folder of meshes and images, relative to the scene file
    part: bool = False  # write only what an included file may hold (no camera, image, background, lights)
    width: int = 640
    samples: int = 64
    lumens_per_watt: float = LUMENS_PER_WATT
    source_name: str = "model.glb"  # for the header


@dataclass
class MeshFile:
    """One primitive's triangles, to be written as a PLY file at `path` (relative to the scene)."""

    path: str
    positions: np.ndarray  # (V, 3) float32
    faces: np.ndarray  # (T, 3) int32
    normals: Optional[np.ndarray] = None  # (V, 3) float32
    uvs: Optional[np.ndarray] = None  # (V, 2) float32, our orientation (v up)


@dataclass
class ImportPlan:
    data: dict  # the scene, plain data in our format
    meshes: list = field(default_factory=list)  # MeshFile
    images: dict = field(default_factory=dict)  # path relative to the scene -> bytes
    warnings: list = field(default_factory=list)
    header: str = ""
    triangles: int = 0


class _Warnings:
    """Warnings counted by kind: one line for twenty single-sided materials, not twenty."""

    def __init__(self):
        self.counts: Counter = Counter()

    def add(self, text: str) -> None:
        self.counts[text] += 1

    def lines(self) -> list[str]:
        return [text if n == 1 else f"{text} ({n} times)" for text, n in self.counts.items()]


def _clean(x: float) -> float:
    """A float our format takes, as a reader wants it: 12 significant digits (0.39999999999999997,
    float rounding of a composed transform, reads 0.4), 0 for magnitudes under 1e-40 (the format
    refuses below 1e-50), -0 as 0."""
    x = float(f"{float(x):.12g}")
    return 0.0 if abs(x) < 1e-40 else x + 0.0


def _vec(v) -> list:
    """A vector or a matrix row of clean floats; entries under 1e-12 of its largest are rounding, made 0."""
    v = [_clean(x) for x in v]
    peak = max((abs(x) for x in v), default=0.0)
    return [0.0 if abs(x) < 1e-12 * peak else x for x in v]


class _Names:
    """Names for definitions: the glTF name where it makes one, made unique, with the prefix."""

    def __init__(self, prefix: str):
        self.prefix = prefix
        self.used: set = set()

    def make(self, wanted: Any, fallback: str) -> str:
        base = _NAME_CHARS.sub("_", wanted)[:40] if isinstance(wanted, str) and wanted.strip() else fallback
        base = self.prefix + base
        if not re.match(r"^[A-Za-z_]", base):
            base = "_" + base
        name, k = base[:60], 2
        while name in self.used:
            name, k = f"{base[:55]}_{k}", k + 1
        self.used.add(name)
        return name


def node_local_matrix(node, index: int) -> np.ndarray:
    """A node's local transform, 4x4 acting on column vectors (glTF's matrix is column-major; T R S otherwise)."""
    what = f"node {index}"
    if node.matrix is not None:
        m = np.array(as_floats(node.matrix, 16, f"{what}'s matrix"), np.float64).reshape(4, 4).T
        return m
    t = as_floats(node.translation, 3, f"{what}'s translation", (0.0, 0.0, 0.0))
    x, y, z, w = as_floats(node.rotation, 4, f"{what}'s rotation", (0.0, 0.0, 0.0, 1.0))
    s = as_floats(node.scale, 3, f"{what}'s scale", (1.0, 1.0, 1.0))
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0 or not math.isfinite(n):
        raise GltfProblem(f"{what}'s rotation is not a unit quaternion")
    x, y, z, w = x / n, y / n, z / n, w / n
    r = np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])
    m = np.eye(4)
    m[:3, :3] = r * np.array(s)[None, :]
    m[:3, 3] = t
    return m


def world_matrices(doc: GltfDocument, warn: _Warnings) -> list[tuple[int, np.ndarray]]:
    """(node, world matrix) for every node of the default scene, parents before children; an error
    for a cycle or a node reached twice (glTF's nodes form disjoint trees)."""
    gltf = doc.gltf
    nodes = gltf.nodes or []
    scenes = gltf.scenes or []
    if scenes:
        which = as_int(gltf.scene, "the default scene", 0, len(scenes) - 1) if gltf.scene is not None else 0
        roots = scenes[which].nodes or []
        if not isinstance(roots, list):
            raise GltfProblem(f"scene {which}'s nodes is not a list")
    else:  # no scenes: every node that is nobody's child
        children = {c for n in nodes for c in (n.children or []) if isinstance(c, int)}
        roots = [i for i in range(len(nodes)) if i not in children]
    out = []
    seen = set()
    stack = [(as_int(r, "a scene's root node", 0, len(nodes) - 1), np.eye(4)) for r in reversed(roots)]
    while stack:
        i, parent = stack.pop()
        if i in seen:
            raise GltfProblem(f"node {i} is reached twice from the scene's roots: the node hierarchy has a cycle or "
                              "a node with two parents, and glTF's nodes must form trees")
        seen.add(i)
        node = nodes[i]
        world = parent @ node_local_matrix(node, i)
        if not np.isfinite(world).all():
            raise GltfProblem(f"node {i}'s world transform overflows to a non-finite number")
        out.append((i, world))
        kids = node.children or []
        if not isinstance(kids, list):
            raise GltfProblem(f"node {i}'s children is not a list")
        for c in reversed(kids):
            stack.append((as_int(c, f"node {i}'s child", 0, len(nodes) - 1), world))
        if node.skin is not None:
            warn.add("skins are ignored: skinned meshes are placed in their node's pose, not posed by their joints")
    if gltf.animations:
        warn.add("animations are ignored: the scene is the model at rest")
    return out


def transform_steps(m: np.ndarray) -> list:
    """Our transform steps for a world matrix: none, a translation, or one matrix step."""
    linear, t = m[:3, :3], m[:3, 3]
    if np.array_equal(linear, np.eye(3)):
        return [] if not t.any() else [{"translate": _vec(t)}]
    return [{"matrix": [_vec(row) for row in m[:3]]}]


def _singular(m: np.ndarray) -> bool:
    # MatrixStep's test (det <= 1e-12 max|a|^3), on the matrix scaled to a largest entry of 1 (no overflow).
    a = m[:3, :3]
    peak = float(np.abs(a).max())
    return not peak > 0 or abs(float(np.linalg.det(a / peak))) <= 1e-12


# --- meshes ---------------------------------------------------------------------------------


def triangles_of(mode: int, corners: np.ndarray) -> np.ndarray:
    """(T, 3) corner indices of a triangle list, strip or fan (glTF's modes 4, 5, 6)."""
    n = len(corners)
    if mode == TRIANGLES:
        return corners[: n - n % 3].reshape(-1, 3)
    if n < 3:
        return np.zeros((0, 3), corners.dtype)
    k = np.arange(n - 2)
    if mode == TRIANGLE_STRIP:
        # Every other triangle of a strip turns the other way; swapping two corners keeps one winding.
        odd = k % 2 == 1
        a, b, c = corners[k], corners[k + 1], corners[k + 2]
        return np.stack([a, np.where(odd, c, b), np.where(odd, b, c)], 1)
    return np.stack([np.full(n - 2, corners[0]), corners[k + 1], corners[k + 2]], 1)


def read_primitive(doc: GltfDocument, mesh_index: int, p: int, prim, warn: _Warnings) -> Optional[tuple]:
    """(positions, faces, normals, uvs) of a primitive, checked; None (with a warning) for one that is no surface."""
    what = f"mesh {mesh_index} primitive {p}"
    mode = TRIANGLES if prim.mode is None else as_int(prim.mode, f"{what}'s mode", 0, 6)
    if mode in _MODES:
        warn.add(f"primitives of {_MODES[mode]} are skipped: rt renders surfaces")
        return None
    attrs = prim.attributes
    if attrs is None or getattr(attrs, "POSITION", None) is None:
        raise GltfProblem(f"{what} has no POSITION attribute")
    positions = read_accessor(doc, attrs.POSITION, f"{what} POSITION", ("VEC3",))
    if np.abs(positions).max() > 1e30:
        raise GltfProblem(f"{what} has a vertex coordinate beyond 1e30")
    nv = len(positions)
    normals = uvs = None
    if getattr(attrs, "NORMAL", None) is not None:
        normals = read_accessor(doc, attrs.NORMAL, f"{what} NORMAL", ("VEC3",))
        if len(normals) != nv:
            raise GltfProblem(f"{what} has {len(normals):,} normals for {nv:,} positions")
    if getattr(attrs, "TEXCOORD_0", None) is not None:
        uvs = read_accessor(doc, attrs.TEXCOORD_0, f"{what} TEXCOORD_0", ("VEC2",))
        if len(uvs) != nv:
            raise GltfProblem(f"{what} has {len(uvs):,} texture coordinates for {nv:,} positions")
        uvs = np.stack([uvs[:, 0], 1.0 - uvs[:, 1]], 1)  # glTF's v runs down the image, ours up
    if getattr(attrs, "COLOR_0", None) is not None:
        warn.add("vertex colours (COLOR_0) are ignored")
    if prim.targets:
        warn.add("morph targets are ignored")
    if prim.indices is not None:
        corners = read_accessor(doc, prim.indices, f"{what} indices", ("SCALAR",))[:, 0]
        acc = doc.gltf.accessors[prim.indices]
        if acc.componentType not in (5121, 5123, 5125) or acc.normalized or corners.dtype.kind != "i":
            raise GltfProblem(f"{what}'s indices are not unsigned integers")
        if len(corners) and int(corners.max()) >= nv:
            raise GltfProblem(f"{what} has an index {int(corners.max()):,} past its {nv:,} vertices")
    else:
        corners = np.arange(nv, dtype=np.int64)
    faces = triangles_of(mode, corners)
    if mode == TRIANGLES and len(corners) % 3:
        warn.add("a triangle list's index count is not a multiple of 3: the last corners are dropped")
    faces = _with_area(positions.astype(np.float32).astype(np.float64), faces, warn)
    if len(faces) == 0:
        warn.add("primitives with no triangles are skipped")
        return None
    return positions, faces, normals, uvs


def _with_area(positions: np.ndarray, faces: np.ndarray, warn: _Warnings) -> np.ndarray:
    """The triangles that have an area, by the test `meshfile` applies when it reads the PLY back
    (on the float32 positions the PLY holds), so that a mesh of only zero-area triangles is
    skipped here rather than written and refused by `rt validate`."""
    from .meshfile import DEGENERATE

    keep = np.ones(len(faces), bool)
    step = 1 << 20
    for start in range(0, len(faces), step):  # in chunks: a few hundred bytes of temporaries per triangle
        f = faces[start:start + step]
        a, b, c = positions[f[:, 0]], positions[f[:, 1]], positions[f[:, 2]]
        e1, e2 = b - a, c - a
        cross = np.linalg.norm(np.cross(e1, e2), axis=1)
        keep[start:start + step] = cross > DEGENERATE * np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1)
    if not keep.all():
        warn.add("triangles of zero area are dropped")
    return faces[keep]


# --- materials and textures -----------------------------------------------------------------


def _srgb_to_linear(x: np.ndarray) -> np.ndarray:
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def _linear_to_srgb(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, x * 12.92, 1.055 * x ** (1 / 2.4) - 0.055)


def bake_factor(data: bytes, factor: tuple) -> bytes:
    """A PNG of an sRGB image multiplied by a linear RGB factor (glTF's factor x texture, which our
    image textures have no factor for), within the 8 bits of the image."""
    import warnings

    from PIL import Image

    from .graph import MAX_TEXTURE_PIXELS

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # bounded here, by our own limit
            with Image.open(io.BytesIO(data)) as img:
                if img.width * img.height > MAX_TEXTURE_PIXELS:
                    raise GltfProblem(f"an image of {img.width} x {img.height} is larger than the {MAX_TEXTURE_PIXELS:,} pixels allowed")
                rgb = np.asarray(img.convert("RGB"), np.uint8)
    except GltfProblem:
        raise
    except Exception as exc:  # noqa: BLE001 - a decoder meets a broken image
        raise GltfProblem(f"an image cannot be decoded ({type(exc).__name__})") from None
    table = _srgb_to_linear(np.arange(256) / 255.0)
    scaled = table[rgb] * np.array(factor)[None, None, :]
    out = np.rint(_linear_to_srgb(scaled) * 255.0).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(out, "RGB").save(buf, format="PNG")
    return buf.getvalue()


class _Materials:
    """glTF materials as principled materials, and the image files and textures they use."""

    def __init__(self, doc: GltfDocument, names: _Names, options: ImportOptions, warn: _Warnings):
        self.doc, self.names, self.options, self.warn = doc, names, options, warn
        self.textures: dict = {}  # name -> texture data
        self.images: dict = {}  # path -> bytes
        self._texture_names: dict = {}  # (image, colorspace, factor) -> name
        self._image_paths: dict = {}  # (image, factor) -> path
        self.materials: dict = {}  # name -> material data
        self._material_names: dict = {}  # glTF index (None: the default material) -> name
        self.uses_texture: dict = {}  # name -> whether it reads (u, v)

    def texture(self, info, colorspace: str, what: str, factor: Optional[tuple] = None) -> Optional[str]:
        """The name of our image texture for a glTF textureInfo, or None (with a warning) where none can be made."""
        gltf = self.doc.gltf
        textures = gltf.textures or []
        if info.index is None:
            return None
        t = as_int(info.index, f"{what}'s texture", 0, len(textures) - 1) if textures else as_int(info.index, what, 0, -1)
        if (info.texCoord or 0) != 0:
            self.warn.add("textures read through TEXCOORD_1 or later use TEXCOORD_0 instead")
        if isinstance(info.extensions, dict) and "KHR_texture_transform" in info.extensions:
            self.warn.add("KHR_texture_transform is ignored: textures use the coordinates as they are")
        source = textures[t].source
        if source is None:
            self.warn.add("textures without a PNG or JPEG source (KHR_texture_basisu, EXT_texture_webp) are ignored")
            return None
        image = as_int(source, f"texture {t}'s source", 0, len(gltf.images or []) - 1)
        factor = None if factor is None or all(f == 1.0 for f in factor) else tuple(factor)
        key = (image, colorspace, factor)
        if key not in self._texture_names:
            path = self._image_path(image, factor)
            name = self.names.make(None, f"image{image}_{colorspace}" if factor is None else f"image{image}_{colorspace}_tinted")
            self.textures[name] = {"type": "image", "file": path, "colorspace": colorspace}
            self._texture_names[key] = name
        return self._texture_names[key]

    def _image_path(self, image: int, factor: Optional[tuple]) -> str:
        key = (image, factor)
        if key not in self._image_paths:
            data, suffix = image_bytes(self.doc, image)
            img = (self.doc.gltf.images or [])[image]
            stem = _NAME_CHARS.sub("_", img.name)[:40] if isinstance(img.name, str) and img.name.strip() else f"image{image}"
            if factor is not None:
                data, suffix = bake_factor(data, factor), ".png"
                stem += "_x" + "_".join(f"{f:.4g}" for f in factor).replace(".", "p")
            path = f"{self.options.assets}/{stem}{suffix}"
            k = 2
            while path in self.images:
                path, k = f"{self.options.assets}/{stem}_{k}{suffix}", k + 1
            self.images[path] = data
            self._image_paths[key] = path
        return self._image_paths[key]

    def material(self, index: Optional[int]) -> str:
        """Our material's name for glTF material `index` (None: glTF's default material)."""
        if index in self._material_names:
            return self._material_names[index]
        mats = self.doc.gltf.materials or []
        if index is None:
            name = self.names.make(None, "default_material")
            self.materials[name] = {"type": "principled", "base_color": [1.0, 1.0, 1.0], "metallic": 1.0, "roughness": 1.0}
            self.uses_texture[name] = False
        else:
            i = as_int(index, "a primitive's material", 0, len(mats) - 1) if mats else as_int(index, "a primitive's material", 0, -1)
            name = self.names.make(mats[i].name, f"material{i}")
            self.materials[name] = self._principled(mats[i], i)
            self.uses_texture[name] = bool(_texture_refs(self.materials[name]) & set(self.textures))
        self._material_names[index] = name
        return name

    def _principled(self, mat, i: int) -> dict:
        what = f"material {i}"
        warn = self.warn
        pbr = mat.pbrMetallicRoughness
        base = as_floats(pbr.baseColorFactor if pbr else None, 4, f"{what}'s baseColorFactor", (1.0, 1.0, 1.0, 1.0))
        metallic = as_float(pbr.metallicFactor if pbr else None, f"{what}'s metallicFactor", 1.0)
        roughness = as_float(pbr.roughnessFactor if pbr else None, f"{what}'s roughnessFactor", 1.0)
        out: dict = {"type": "principled"}
        colour = tuple(min(max(c, 0.0), 1.0) for c in base[:3])
        tex = self.texture(pbr.baseColorTexture, "srgb", f"{what}'s baseColorTexture", colour) if pbr and pbr.baseColorTexture else None
        out["base_color"] = tex if tex else _vec(colour)
        out["metallic"] = _clamp01(metallic)
        out["roughness"] = _clamp01(roughness)
        if pbr and pbr.metallicRoughnessTexture:
            mr = self.texture(pbr.metallicRoughnessTexture, "linear", f"{what}'s metallicRoughnessTexture")
            if mr:
                out["metallic"] = {"texture": mr, "channel": "b", "scale": _clamp01(metallic)}
                out["roughness"] = {"texture": mr, "channel": "g", "scale": _clamp01(roughness)}
        if mat.normalTexture is not None and mat.normalTexture.index is not None:
            nm = self.texture(mat.normalTexture, "linear", f"{what}'s normalTexture")
            if nm:
                out["normal_map"] = nm
                scale = as_float(mat.normalTexture.scale, f"{what}'s normal scale", 1.0)
                if scale < 0:
                    warn.add("a negative normal-map scale is taken as its magnitude")
                out["normal_scale"] = _clean(abs(scale))
        if mat.occlusionTexture is not None and mat.occlusionTexture.index is not None:
            warn.add("occlusion textures are ignored: the path tracer finds occlusion itself")
        ext = mat.extensions if isinstance(mat.extensions, dict) else {}
        emissive = as_floats(mat.emissiveFactor, 3, f"{what}'s emissiveFactor", (0.0, 0.0, 0.0))
        emissive = tuple(max(0.0, c) for c in emissive)
        strength = 1.0
        if isinstance(ext.get("KHR_materials_emissive_strength"), dict):
            strength = max(0.0, as_float(ext["KHR_materials_emissive_strength"].get("emissiveStrength"), f"{what}'s emissiveStrength", 1.0))
        if mat.emissiveTexture is not None and mat.emissiveTexture.index is not None and max(emissive) > 0:
            peak = max(emissive)
            grey = emissive[0] == emissive[1] == emissive[2]
            # A grey factor is a strength; a coloured one is baked into the image, its peak kept as the strength.
            em = self.texture(mat.emissiveTexture, "srgb", f"{what}'s emissiveTexture",
                              None if grey else tuple(c / peak for c in emissive))
            if em:
                out["emission"] = em
                strength *= peak
            else:
                out["emission"] = _vec(emissive)
        elif max(emissive) > 0:
            out["emission"] = _vec(emissive)
        if "emission" in out and strength != 1.0:
            out["emission_strength"] = _clean(strength)
        self._extensions(ext, out, what)
        if mat.alphaMode not in (None, "OPAQUE") or base[3] < 1.0:
            warn.add("transparency by alpha (alphaMode BLEND or MASK, base colour alpha) is ignored: surfaces are opaque")
        if not mat.doubleSided:
            warn.add("single-sided materials (doubleSided false) render both sides, as every rt surface does")
        return out

    def _extensions(self, ext: dict, out: dict, what: str) -> None:
        warn = self.warn
        for key in ext:
            if key not in KNOWN_EXTENSIONS:
                warn.add(f"material extension {quote_text(str(key)[:60])} is ignored")
        tr = ext.get("KHR_materials_transmission")
        if isinstance(tr, dict):
            factor = _clamp01(as_float(tr.get("transmissionFactor"), f"{what}'s transmissionFactor", 0.0))
            out["transmission"] = factor
            info = _texture_info(self.doc, tr.get("transmissionTexture"))
            if info is not None and factor > 0:
                t = self.texture(info, "linear", f"{what}'s transmissionTexture")
                if t:
                    out["transmission"] = {"texture": t, "channel": "r", "scale": factor}
            if factor > 0 and not isinstance(ext.get("KHR_materials_volume"), dict):
                out["thin_walled"] = True
        volume = ext.get("KHR_materials_volume")
        # Its thickness only stands in for geometry a rasteriser lacks: a path tracer refracts through
        # the mesh itself, so only an attenuation (a tint with distance) is lost, and only that is said.
        if isinstance(volume, dict) and ("attenuationColor" in volume or "attenuationDistance" in volume):
            warn.add("KHR_materials_volume's attenuation is ignored: transmissive solids are clear")
        ior = ext.get("KHR_materials_ior")
        if isinstance(ior, dict):
            value = as_float(ior.get("ior"), f"{what}'s ior", 1.5)
            if value > 0:
                out["ior"] = _clean(value)
            else:
                warn.add("an ior of 0 (glTF's 'no refraction') is written as 1.5")
        sp = ext.get("KHR_materials_specular")
        if isinstance(sp, dict):
            out["specular"] = _clamp01(as_float(sp.get("specularFactor"), f"{what}'s specularFactor", 1.0))
            colour = as_floats(sp.get("specularColorFactor"), 3, f"{what}'s specularColorFactor", (1.0, 1.0, 1.0))
            if max(colour) > 1.0:
                warn.add("specular colour factors above 1 are clamped to 1: rt's specular colour is a reflectance")
            out["specular_color"] = _vec(_clamp01(c) for c in colour)
            if sp.get("specularTexture") is not None or sp.get("specularColorTexture") is not None:
                warn.add("KHR_materials_specular's textures are ignored: its factors are used")
        cc = ext.get("KHR_materials_clearcoat")
        if isinstance(cc, dict):
            factor = _clamp01(as_float(cc.get("clearcoatFactor"), f"{what}'s clearcoatFactor", 0.0))
            rough = _clamp01(as_float(cc.get("clearcoatRoughnessFactor"), f"{what}'s clearcoatRoughnessFactor", 0.0))
            out["clearcoat"], out["clearcoat_roughness"] = factor, rough
            info = _texture_info(self.doc, cc.get("clearcoatTexture"))
            if info is not None:
                t = self.texture(info, "linear", f"{what}'s clearcoatTexture")
                if t:
                    out["clearcoat"] = {"texture": t, "channel": "r", "scale": factor}
            info = _texture_info(self.doc, cc.get("clearcoatRoughnessTexture"))
            if info is not None:
                t = self.texture(info, "linear", f"{what}'s clearcoatRoughnessTexture")
                if t:
                    out["clearcoat_roughness"] = {"texture": t, "channel": "g", "scale": rough}
            if cc.get("clearcoatNormalTexture") is not None:
                warn.add("clear-coat normal maps are ignored")


def _texture_refs(material: dict) -> set:
    refs = set()
    for v in material.values():
        if isinstance(v, str):
            refs.add(v)
        elif isinstance(v, dict) and isinstance(v.get("texture"), str):
            refs.add(v["texture"])
    return refs


def _texture_info(doc, value):
    """A textureInfo given as a plain dict inside an extension, as pygltflib's TextureInfo; None if absent."""
    if value is None:
        return None
    if not isinstance(value, dict):
        raise GltfProblem("a texture reference inside a material extension is not an object")
    from .gltf_read import need_pygltflib

    info = need_pygltflib().TextureInfo()
    info.index = value.get("index")
    info.texCoord = value.get("texCoord", 0)
    info.extensions = value.get("extensions") or {}
    return info


def _clamp01(x: float) -> float:
    return _clean(min(max(x, 0.0), 1.0))


# --- lights and the camera --------------------------------------------------------------------


def _point(m: np.ndarray) -> np.ndarray:
    return m[:3, 3].copy()


def _direction(m: np.ndarray, local) -> np.ndarray:
    d = m[:3, :3] @ np.array(local, np.float64)
    n = np.linalg.norm(d)
    if not n > 0:
        raise GltfProblem("a light's or camera's node scales its direction to nothing")
    return d / n


def punctual_light(doc: GltfDocument, light_index: Any, m: np.ndarray, options: ImportOptions, warn: _Warnings) -> dict:
    """Our light for a KHR_lights_punctual light placed by world matrix `m`."""
    ext = doc.gltf.extensions if isinstance(doc.gltf.extensions, dict) else {}
    lights = (ext.get("KHR_lights_punctual") or {}).get("lights") if isinstance(ext.get("KHR_lights_punctual"), dict) else None
    if not isinstance(lights, list) or not lights:
        raise GltfProblem("a node names a KHR_lights_punctual light, but the file defines none")
    i = as_int(light_index, "a node's KHR_lights_punctual light", 0, len(lights) - 1)
    light = lights[i]
    what = f"light {i}"
    if not isinstance(light, dict):
        raise GltfProblem(f"{what} is not an object")
    colour = as_floats(light.get("color"), 3, f"{what}'s color", (1.0, 1.0, 1.0))
    intensity = as_float(light.get("intensity"), f"{what}'s intensity", 1.0)
    if intensity < 0 or min(colour) < 0:
        raise GltfProblem(f"{what} has a negative colour or intensity")
    amount = _vec(c * intensity / options.lumens_per_watt for c in colour)
    if light.get("range") is not None:
        warn.add("light ranges are ignored: light falls off as the inverse square of distance, without a cut-off")
    kind = light.get("type")
    position = _vec(_point(m))
    direction = _vec(_direction(m, (0.0, 0.0, -1.0)))  # glTF lights point down their node's -Z
    if kind == "point":
        return {"type": "point", "position": position, "intensity": amount}
    if kind == "directional":
        return {"type": "directional", "direction": direction, "irradiance": amount}
    if kind == "spot":
        spot = light.get("spot") if isinstance(light.get("spot"), dict) else {}
        inner = as_float(spot.get("innerConeAngle"), f"{what}'s innerConeAngle", 0.0)
        outer = as_float(spot.get("outerConeAngle"), f"{what}'s outerConeAngle", math.pi / 4)
        if not 0 <= inner < outer <= math.pi / 2:
            raise GltfProblem(f"{what}'s cone angles must satisfy 0 <= inner < outer <= pi/2")
        # Our profile falls linearly in angle from the beam width to the cut-off; glTF's smoothly in
        # cosine between the same two angles. The beam width must be > 0: an inner angle of 0 is a
        # hundredth of the outer one.
        return {"type": "spot", "position": position, "direction": direction, "intensity": amount,
                "cutoff_angle": _clean(math.degrees(outer)), "beam_width": _clean(max(math.degrees(inner), math.degrees(outer) / 100))}
    raise GltfProblem(f"{what} has an unknown type (expected point, spot or directional)")


def camera_of(doc: GltfDocument, index: Any, m: np.ndarray, target: np.ndarray) -> Optional[tuple[dict, Optional[float]]]:
    """(our camera, aspect ratio or None) for a perspective glTF camera at world matrix `m`; None for another kind."""
    cams = doc.gltf.cameras or []
    i = as_int(index, "a node's camera", 0, len(cams) - 1) if cams else as_int(index, "a node's camera", 0, -1)
    cam = cams[i]
    if cam.type != "perspective" or cam.perspective is None:
        return None
    yfov = as_float(cam.perspective.yfov, f"camera {i}'s yfov")
    if not 0 < yfov < math.pi:
        raise GltfProblem(f"camera {i}'s yfov must lie in (0, pi) radians")
    aspect = cam.perspective.aspectRatio
    aspect = None if aspect is None else as_float(aspect, f"camera {i}'s aspectRatio")
    if aspect is not None and not 1e-3 < aspect < 1e3:
        raise GltfProblem(f"camera {i}'s aspectRatio must lie in (0.001, 1000)")
    eye = _point(m)
    forward = _direction(m, (0.0, 0.0, -1.0))  # glTF cameras look down their node's -Z, +Y up
    up = _direction(m, (0.0, 1.0, 0.0))
    # A camera that does not roll (its right-hand axis level) is written with the plain up of
    # +Y, which gives the same frame and reads as what it is; only a rolled camera keeps its own.
    right = np.cross(forward, up)
    if abs(forward[1]) < 0.999 and abs(right[1]) < 1e-9 * max(1.0, float(np.linalg.norm(right))) and up[1] > 0:
        up = np.array([0.0, 1.0, 0.0])
    # look_at on the view axis, as far as the model's centre along it (1 when that is behind).
    reach = float(np.dot(target - eye, forward))
    look_at = eye + forward * (reach if reach > 1e-9 else 1.0)
    return {"look_from": _vec(eye), "look_at": _vec(look_at), "up": _vec(up), "vfov": _clean(math.degrees(yfov))}, aspect


def framing_camera(low: np.ndarray, high: np.ndarray, vfov: float = 40.0) -> dict:
    """A camera that sees the whole box [low, high]: from the front (+Z) and a little above, far
    enough that the bounding sphere fits the vertical field of view."""
    centre = (low + high) / 2
    radius = max(float(np.linalg.norm(high - low)) / 2, 1e-6)
    along = np.array([0.0, 0.35, 1.0]) / math.sqrt(1 + 0.35 ** 2)
    distance = radius / math.sin(math.radians(vfov / 2)) * 1.05
    return {"look_from": _vec(centre + along * distance), "look_at": _vec(centre), "vfov": vfov}


# --- the plan --------------------------------------------------------------------------------


def plan_import(doc: GltfDocument, options: ImportOptions) -> ImportPlan:
    """The scene for a glTF document (see the module's docstring); raises GltfProblem."""
    warn = _Warnings()
    names = _Names(options.prefix)  # materials and textures
    group_names = _Names(options.prefix)  # groups: a section of their own, so a mesh may share its material's name
    gltf = doc.gltf
    for key in (gltf.extensionsRequired or []):
        if key not in KNOWN_EXTENSIONS:
            warn.add(f"the file requires extension {quote_text(str(key)[:60])}, which rt import does not read")
    placed = world_matrices(doc, warn)
    nodes = gltf.nodes or []
    meshes = gltf.meshes or []
    materials = _Materials(doc, names, options, warn)
    placements: dict = {}  # mesh -> [world matrices]
    lights: list = []
    camera_node = None
    for i, m in placed:
        node = nodes[i]
        if node.mesh is not None:
            mi = as_int(node.mesh, f"node {i}'s mesh", 0, len(meshes) - 1) if meshes else as_int(node.mesh, f"node {i}'s mesh", 0, -1)
            if _singular(m):
                warn.add("nodes whose transform flattens them (a zero scale) are skipped")
            else:
                placements.setdefault(mi, []).append(m)
        ext = node.extensions if isinstance(node.extensions, dict) else {}
        if isinstance(ext.get("KHR_lights_punctual"), dict) and not options.part:
            lights.append(punctual_light(doc, ext["KHR_lights_punctual"].get("light"), m, options, warn))
        elif isinstance(ext.get("KHR_lights_punctual"), dict):
            warn.add("lights are left out of a --part file: an included file holds no lights")
        if node.camera is not None and camera_node is None:
            cams = gltf.cameras or []
            ci = as_int(node.camera, f"node {i}'s camera", 0, len(cams) - 1) if cams else as_int(node.camera, f"node {i}'s camera", 0, -1)
            if cams[ci].type == "perspective":
                camera_node = (ci, m)
            else:
                warn.add("orthographic cameras are skipped: rt's camera is perspective")

    plan = ImportPlan(data={})
    shapes: list = []
    groups: dict = {}
    low, high = np.full(3, np.inf), np.full(3, -np.inf)
    for mi in sorted(placements):
        mesh = meshes[mi]
        mesh_name = mesh.name if isinstance(mesh.name, str) and mesh.name.strip() else None
        stem = _NAME_CHARS.sub("_", mesh_name)[:40] if mesh_name else f"mesh{mi}"
        members = []
        corners = []
        for p, prim in enumerate(mesh.primitives or []):
            got = read_primitive(doc, mi, p, prim, warn)
            if got is None:
                continue
            positions, faces, normals, uvs = got
            path = f"{options.assets}/{stem}_{p}.ply" if len(mesh.primitives) > 1 else f"{options.assets}/{stem}.ply"
            k = 2
            while any(f.path == path for f in plan.meshes):
                path, k = f"{options.assets}/{stem}_{p}_{k}.ply", k + 1
            plan.meshes.append(MeshFile(path, positions.astype(np.float32), faces.astype(np.int32),
                                        None if normals is None else normals.astype(np.float32),
                                        None if uvs is None else uvs.astype(np.float32)))
            plan.triangles += len(faces)
            material = materials.material(prim.material)
            if materials.uses_texture.get(material):
                if uvs is None:
                    warn.add("textured primitives without texture coordinates read each texture at (0, 0)")
                elif uvs.size and (uvs.min() < -1e-6 or uvs.max() > 1 + 1e-6):
                    warn.add("texture coordinates outside [0, 1] are clamped to the image's edge (glTF repeats the image)")
            shape = {"type": "mesh", "file": path}
            if normals is not None:
                shape["smooth"] = True
            shape["material"] = material
            members.append(shape)
            corners.append((positions.min(axis=0), positions.max(axis=0)))
        if not members:
            continue
        lo = np.min([c[0] for c in corners], axis=0)
        hi = np.max([c[1] for c in corners], axis=0)
        box = np.array([[x, y, z, 1.0] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        for m in placements[mi]:
            world = (m @ box.T).T[:, :3]
            low, high = np.minimum(low, world.min(axis=0)), np.maximum(high, world.max(axis=0))
        if len(placements[mi]) == 1:
            steps = transform_steps(placements[mi][0])
            for shape in members:
                shapes.append({**shape, "transform": steps} if steps else shape)
        else:
            group = group_names.make(mesh_name, f"mesh{mi}")
            groups[group] = {"shapes": members}
            for m in placements[mi]:
                inst = {"type": "instance", "group": group}
                steps = transform_steps(m)
                if steps:
                    inst["transform"] = steps
                shapes.append(inst)
    if not shapes:
        raise GltfProblem("the model's default scene places no triangle mesh: there is nothing to render")

    data: dict = {"version": 1}
    if not options.part:
        data["description"] = f"Imported by rt import from {options.source_name} (glTF 2.0)."
        aspect = None
        target = (low + high) / 2
        if camera_node is not None:
            found = camera_of(doc, camera_node[0], camera_node[1], target)
            camera, aspect = found if found else (framing_camera(low, high), None)
        else:
            camera = framing_camera(low, high)
        data["camera"] = camera
        data["image"] = {"width": options.width, "aspect_ratio": _clean(aspect) if aspect else 1.0,
                         "samples_per_pixel": options.samples, "max_depth": 12}
        emissive = any("emission" in m for m in materials.materials.values())
        data["background"] = {"type": "sky"} if not lights and not emissive else [0.0, 0.0, 0.0]
        if lights:
            data["lights"] = lights
    if materials.textures:
        data["textures"] = materials.textures
    data["materials"] = materials.materials
    if groups:
        data["groups"] = groups
    data["shapes"] = shapes
    plan.data = data
    plan.images = materials.images
    plan.warnings = warn.lines()
    plan.header = header(options, plan, camera_node is not None, bool(lights), "background" in data and data["background"] != [0.0, 0.0, 0.0])
    return plan


def header(options: ImportOptions, plan: ImportPlan, had_camera: bool, had_lights: bool, sky: bool) -> str:
    """The comment the scene file starts with: where it came from, units, axes, lights, how to include it."""
    src = options.source_name
    lines = [
        f"Imported by `rt import` from {src} (glTF 2.0): {len(plan.meshes)} mesh file(s), {plan.triangles:,} triangles,",
        f"{len(plan.images)} image file(s), in {options.assets}/ beside this file.",
        "Units: glTF's metres; one scene unit is one metre.",
        "Axes: glTF is right-handed with +Y up and a model's front toward +Z; rt's format is right-handed with the",
        "same axes, so no coordinate was converted. glTF's texture v runs down the image, ours up: v became 1 - v.",
    ]
    if options.part:
        lines += [
            "This file holds only what an included file may (textures, materials, groups, shapes): write",
            f"`include: {options.assets.removesuffix('_assets')}.yaml` in a scene that gives the camera, image and lights.",
        ]
    else:
        lines.append("Camera: the file's first perspective camera." if had_camera else
                     "Camera: the file has none, so this one frames the model's bounds from the front.")
        if had_lights:
            lines += [
                f"Lights: KHR_lights_punctual's photometric intensities (candela, lux) divided by {options.lumens_per_watt:g} lm/W",
                "into rt's radiometric W/sr and W/m^2 (rt import --lumens-per-watt 1 keeps the numbers as they are).",
            ]
        if sky:
            lines.append("Background: the file has no lights, so the default sky gradient lights the model.")
        lines.append("To use the model in another scene, import it again with --part and `include:` that file.")
    for w in plan.warnings:
        lines.append(f"Ignored: {w}")
    return "".join(f"# {line}\n" for line in lines)
