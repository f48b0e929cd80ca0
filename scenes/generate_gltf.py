"""Build the glTF 2.0 model behind the gallery's imported scene, from code, so that its every byte
has a known source.

    python scenes/generate_gltf.py            # rewrite scenes/models/still_life.glb and its import
    python scenes/generate_gltf.py --check    # exit 1 if a committed file differs
    python scenes/generate_gltf.py --triangles 1000000 -o big.glb   # a dense model for timing `rt import`

The model is what an exporter writes: a node tree with transforms given as translation,
rotation and scale, one mesh placed by several nodes (the fruit), indexed triangles with normals
and texture coordinates, metallic-roughness materials with a base-colour texture and the
transmission, ior and clearcoat extensions, KHR_lights_punctual lights and a perspective camera.
`rt import scenes/models/still_life.glb -o scenes/still_life.yaml` turns it into the scene the
gallery renders (scenes/still_life.yaml and scenes/still_life_assets/), which this script writes
too, exactly as the command does but for the first line naming the schema, as every shipped
scene's does. Needs pygltflib (`pip install '.[gltf]'`).
"""

from __future__ import annotations

import argparse
import io
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
MODEL = HERE / "models" / "still_life.glb"
SCENE = HERE / "still_life.yaml"
SCHEMA_LINE = "# yaml-language-server: $schema=../schemas/scene.schema.json\n"

FLOAT, UINT32 = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


class Builder:
    """One binary buffer and the accessors, meshes and materials written into it, in order."""

    def __init__(self):
        import pygltflib as g

        self.g = g
        self.blob = bytearray()
        self.doc = g.GLTF2(asset=g.Asset(version="2.0", generator="rt scenes/generate_gltf.py"))
        self.doc.extensionsUsed = []

    def _view(self, data: bytes, target=None) -> int:
        while len(self.blob) % 4:
            self.blob.append(0)
        self.doc.bufferViews.append(self.g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data), target=target))
        self.blob.extend(data)
        return len(self.doc.bufferViews) - 1

    def accessor(self, array: np.ndarray, indices: bool = False) -> int:
        if indices:
            data = np.ascontiguousarray(array, dtype=np.uint32).ravel()
            view = self._view(data.tobytes(), ELEMENT_ARRAY_BUFFER)
            acc = self.g.Accessor(bufferView=view, componentType=UINT32, count=int(data.size), type="SCALAR",
                                  min=[int(data.min())], max=[int(data.max())])
        else:
            data = np.ascontiguousarray(array, dtype=np.float32)
            view = self._view(data.tobytes(), ARRAY_BUFFER)
            kind = {2: "VEC2", 3: "VEC3"}[data.shape[1]]
            acc = self.g.Accessor(bufferView=view, componentType=FLOAT, count=int(data.shape[0]), type=kind,
                                  min=[float(x) for x in data.min(axis=0)], max=[float(x) for x in data.max(axis=0)])
        self.doc.accessors.append(acc)
        return len(self.doc.accessors) - 1

    def mesh(self, name: str, positions, normals, uvs, triangles, material: int) -> int:
        attributes = self.g.Attributes(POSITION=self.accessor(positions), NORMAL=self.accessor(normals),
                                       TEXCOORD_0=self.accessor(uvs))
        prim = self.g.Primitive(attributes=attributes, indices=self.accessor(triangles, indices=True), material=material)
        self.doc.meshes.append(self.g.Mesh(name=name, primitives=[prim]))
        return len(self.doc.meshes) - 1

    def material(self, name: str, color, metallic: float, roughness: float, texture=None, extensions=None) -> int:
        pbr = self.g.PbrMetallicRoughness(baseColorFactor=list(color) + [1.0], metallicFactor=metallic,
                                          roughnessFactor=roughness)
        if texture is not None:
            pbr.baseColorTexture = self.g.TextureInfo(index=texture)
        # Two-sided, as every rt surface is: the import then has nothing to warn about.
        mat = self.g.Material(name=name, pbrMetallicRoughness=pbr, extensions=extensions or {}, doubleSided=True)
        for ext in mat.extensions:
            if ext not in self.doc.extensionsUsed:
                self.doc.extensionsUsed.append(ext)
        self.doc.materials.append(mat)
        return len(self.doc.materials) - 1

    def png_texture(self, pixels: np.ndarray) -> int:
        from PIL import Image

        out = io.BytesIO()
        # Stored, not deflated: the same bytes from any Pillow and zlib, so --check holds everywhere.
        Image.fromarray(pixels, "RGB").save(out, format="PNG", compress_level=0)
        view = self._view(out.getvalue())
        self.doc.images.append(self.g.Image(bufferView=view, mimeType="image/png"))
        self.doc.samplers.append(self.g.Sampler(magFilter=9729, minFilter=9729))
        self.doc.textures.append(self.g.Texture(source=len(self.doc.images) - 1, sampler=len(self.doc.samplers) - 1))
        return len(self.doc.textures) - 1

    def node(self, name: str, children=(), **fields) -> int:
        self.doc.nodes.append(self.g.Node(name=name, children=list(children), **fields))
        return len(self.doc.nodes) - 1

    def save(self) -> bytes:
        self.doc.buffers = [self.g.Buffer(byteLength=len(self.blob))]
        self.doc.set_binary_blob(bytes(self.blob))
        data = b"".join(self.doc.save_to_bytes())
        return data


def box(size) -> tuple:
    """An axis-aligned box centred at the origin: 24 corners (flat normals), 12 triangles."""
    hx, hy, hz = (s / 2 for s in size)
    positions, normals, uvs, tris = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            u_axis, v_axis = [(1, 2), (2, 0), (0, 1)][axis]
            half = np.array([hx, hy, hz])
            base = len(positions)
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = n * half
                p[u_axis] = a * half[u_axis]
                p[v_axis] = b * half[v_axis]
                positions.append(p)
                normals.append(n)
                uvs.append(((a + 1) / 2, (b + 1) / 2))
            quad = [(base, base + 1, base + 2), (base, base + 2, base + 3)]
            if sign < 0:
                quad = [(i, k, j) for i, j, k in quad]
            tris.extend(quad)
    return np.array(positions), np.array(normals), np.array(uvs), np.array(tris)


def lathe(profile, segments: int) -> tuple:
    """A surface of revolution about +y of a profile [(radius, height), ...], bottom to top, with
    normals from the profile's slope; (u, v) = (turn, position along the profile)."""
    profile = np.asarray(profile, dtype=float)
    rings = len(profile)
    d = np.gradient(profile, axis=0)
    positions, normals, uvs = [], [], []
    for i in range(rings):
        r, y = profile[i]
        dr, dy = d[i]
        length = math.hypot(dr, dy) or 1.0
        nr, ny = dy / length, -dr / length
        for j in range(segments + 1):
            phi = 2 * math.pi * j / segments
            c, s = math.cos(phi), math.sin(phi)
            positions.append((r * c, y, -r * s))
            normals.append((nr * c, ny, -nr * s))
            uvs.append((j / segments, i / (rings - 1)))
    tris = []
    for i in range(rings - 1):
        for j in range(segments):
            a = i * (segments + 1) + j
            b, c, e = a + 1, a + segments + 1, a + segments + 2
            tris.append((a, b, e))
            tris.append((a, e, c))
    positions, normals = np.array(positions), np.array(normals)
    tris = np.array(tris)
    # Drop the triangles a profile point on the axis (radius 0) pinches to nothing.
    p = positions[tris]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    return positions, normals, np.array(uvs), tris[area > 1e-12]


def sphere_profile(radius: float, rings: int) -> list:
    return [(radius * math.sin(math.pi * k / rings), -radius * math.cos(math.pi * k / rings)) for k in range(rings + 1)]


def wood_pixels(size: int = 128) -> np.ndarray:
    """Rings of a plank: a seeded, smooth stripe pattern (no randomness from the machine)."""
    y, x = np.mgrid[0:size, 0:size] / size
    rings = 0.5 + 0.5 * np.sin(2 * math.pi * (9 * x + 0.8 * np.sin(2 * math.pi * (y + 0.3 * x))))
    light = np.array([0.80, 0.58, 0.36])
    dark = np.array([0.52, 0.33, 0.18])
    rgb = dark + (light - dark) * rings[..., None] ** 1.5
    return np.clip(np.round(rgb * 255), 0, 255).astype(np.uint8)


def still_life() -> bytes:
    """The gallery's model: a wooden table on a floor, a glass vase, a gold bowl holding three of
    one fruit (a mesh placed three times), a clear-coated jug, a spot and a point light, a camera."""
    b = Builder()
    g = b.g
    wood = b.material("wood", (1, 1, 1), 0.0, 0.55, texture=b.png_texture(wood_pixels()))
    floor = b.material("floor", (0.55, 0.55, 0.52), 0.0, 0.8)
    glass = b.material("glass", (1, 1, 1), 0.0, 0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.5},
        # A volume makes it a solid of glass rather than a thin sheet (the vase is closed at its top).
        "KHR_materials_volume": {"thicknessFactor": 0.1}})
    gold = b.material("gold", (1.0, 0.78, 0.34), 1.0, 0.25)
    fruit = b.material("fruit", (0.65, 0.06, 0.04), 0.0, 0.35)
    jug = b.material("glazed", (0.10, 0.22, 0.55), 0.0, 0.5, extensions={
        "KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.05}})

    top = b.mesh("table_top", *box((1.6, 0.06, 0.9)), wood)
    leg = b.mesh("table_leg", *box((0.07, 0.72, 0.07)), wood)
    ground = b.mesh("floor", *box((8.0, 0.02, 8.0)), floor)
    wall = b.mesh("wall", *box((8.0, 4.0, 0.02)), b.material("plaster", (0.62, 0.6, 0.56), 0.0, 0.9))
    window = b.material("window", (0.0, 0.0, 0.0), 0.0, 1.0)
    # An emissive panel, as exporters write an area light: emissiveFactor times the strength extension.
    b.doc.materials[window].emissiveFactor = [1.0, 0.95, 0.88]
    b.doc.materials[window].extensions = {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}}
    b.doc.extensionsUsed.append("KHR_materials_emissive_strength")
    panel = b.mesh("window", *box((1.4, 1.4, 0.02)), window)
    vase_profile = [(0.0, 0.0), (0.07, 0.0), (0.09, 0.05), (0.1, 0.12), (0.07, 0.22), (0.045, 0.3), (0.055, 0.34), (0.0, 0.34)]
    vase = b.mesh("vase", *lathe(vase_profile, 48), glass)
    bowl_profile = [(0.0, 0.0), (0.08, 0.0), (0.15, 0.04), (0.19, 0.1), (0.185, 0.1), (0.145, 0.045), (0.0, 0.012)]
    bowl = b.mesh("bowl", *lathe(bowl_profile, 48), gold)
    apple = b.mesh("fruit", *lathe(sphere_profile(0.05, 16), 24), fruit)
    jug_profile = [(0.0, 0.0), (0.08, 0.0), (0.1, 0.08), (0.09, 0.18), (0.06, 0.24), (0.065, 0.27)]
    jug_mesh = b.mesh("jug", *lathe(jug_profile, 40), jug)

    legs = [b.node(f"leg{k}", mesh=leg, translation=[x, 0.36, z])
            for k, (x, z) in enumerate(((-0.72, -0.38), (0.72, -0.38), (-0.72, 0.38), (0.72, 0.38)))]
    fruits = [b.node(f"fruit{k}", mesh=apple, translation=t, scale=[s, s, s])
              for k, (t, s) in enumerate((([0.05, 0.05, 0.02], 1.0), ([-0.055, 0.05, -0.02], 0.95), ([0.0, 0.1, 0.0], 1.05)))]
    bowl_node = b.node("bowl", children=fruits, mesh=bowl, translation=[0.35, 0.75, 0.05])
    vase_node = b.node("vase", mesh=vase, translation=[-0.35, 0.75, -0.1])
    # A quarter turn about y, as a unit quaternion (x, y, z, w): rotations are written as exporters write them.
    turn = [0.0, math.sin(math.radians(20)), 0.0, math.cos(math.radians(20))]
    jug_node = b.node("jug", mesh=jug_mesh, translation=[-0.05, 0.75, 0.25], rotation=turn)
    top_node = b.node("top", mesh=top, translation=[0.0, 0.75, 0.0])
    table = b.node("table", children=[top_node, *legs, bowl_node, vase_node, jug_node], translation=[0.0, 0.0, 0.0])
    floor_node = b.node("floor", mesh=ground, translation=[0.0, -0.01, 0.0])
    wall_node = b.node("wall", mesh=wall, translation=[0.0, 2.0, -1.6])
    # The panel stands to the left, turned 60 degrees about y to face the table.
    face = [0.0, math.sin(math.radians(30)), 0.0, math.cos(math.radians(30))]
    panel_node = b.node("window", mesh=panel, translation=[-2.4, 1.6, 0.4], rotation=face)

    b.doc.extensionsUsed.append("KHR_lights_punctual")
    b.doc.extensions = {"KHR_lights_punctual": {"lights": [
        {"type": "spot", "name": "key", "color": [1.0, 0.92, 0.8], "intensity": 4000.0,
         "spot": {"innerConeAngle": 0.45, "outerConeAngle": 0.8}},
        {"type": "point", "name": "fill", "color": [0.7, 0.8, 1.0], "intensity": 800.0},
    ]}}
    # The spot hangs above the table and looks straight down (glTF lights shine along -z).
    down = [-math.sin(math.pi / 4), 0.0, 0.0, math.cos(math.pi / 4)]
    key = b.node("key_light", translation=[0.1, 2.4, 0.3], rotation=down, extensions={"KHR_lights_punctual": {"light": 0}})
    fill = b.node("fill_light", translation=[-1.6, 1.6, 1.8], extensions={"KHR_lights_punctual": {"light": 1}})

    b.doc.cameras.append(g.Camera(type="perspective", perspective=g.Perspective(yfov=math.radians(32), aspectRatio=1.5,
                                                                                 znear=0.05)))
    # Looking at the table top from the front, a little above it: a turn down about x.
    tilt = math.radians(-16)
    cam = b.node("camera", camera=0, translation=[0.0, 1.35, 2.3], rotation=[math.sin(tilt / 2), 0.0, 0.0, math.cos(tilt / 2)])
    b.doc.scenes.append(g.Scene(name="still life", nodes=[table, floor_node, wall_node, panel_node, key, fill, cam]))
    b.doc.scene = 0
    return b.save()


def dense(triangles: int) -> bytes:
    """A model of about `triangles` triangles: one finely divided lathe (a vase), for timing an import."""
    b = Builder()
    mat = b.material("white", (0.8, 0.8, 0.8), 0.0, 0.5)
    segments = max(8, int(math.sqrt(triangles / 2)))
    rings = max(2, triangles // (2 * segments) + 1)
    t = np.linspace(0.0, 1.0, rings)
    profile = list(zip(0.3 + 0.15 * np.sin(2 * math.pi * t), t))
    mesh = b.mesh("dense", *lathe(profile, segments), mat)
    b.doc.scenes.append(b.g.Scene(nodes=[b.node("dense", mesh=mesh)]))
    b.doc.scene = 0
    return b.save()


def imported(model: bytes) -> dict:
    """What `rt import` writes for the model (relative name -> bytes): the scene file, the schema
    line put first, and every file of its assets folder."""
    import tempfile

    sys.path.insert(0, str(HERE.parent))
    from rt.importing import import_gltf

    with tempfile.TemporaryDirectory() as tmp:
        glb = Path(tmp) / MODEL.name
        glb.write_bytes(model)
        out = Path(tmp) / "out"
        out.mkdir()
        result = import_gltf(glb, out / SCENE.name)
        files = {SCENE.name: SCHEMA_LINE.encode() + result.scene.read_bytes()}
        for f in sorted(result.assets.iterdir()):
            files[f"{result.assets.name}/{f.name}"] = f.read_bytes()
    return files


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="exit 1 if a committed file differs")
    parser.add_argument("--triangles", type=int, help="write a dense model of about this many triangles instead")
    parser.add_argument("-o", "--output", type=Path, help="where to write the dense model")
    args = parser.parse_args(argv)
    if args.triangles:
        out = args.output or Path("dense.glb")
        data = dense(args.triangles)
        out.write_bytes(data)
        print(f"wrote {out} ({len(data)} bytes)")
        return 0
    model = still_life()
    files = {f"models/{MODEL.name}": model, **imported(model)}
    assets = HERE / f"{SCENE.stem}_assets"
    if args.check:
        stale = [name for name, data in files.items() if not (HERE / name).is_file() or (HERE / name).read_bytes() != data]
        extra = sorted(f.name for f in assets.iterdir() if f"{assets.name}/{f.name}" not in files) if assets.is_dir() else []
        if stale or extra:
            print("differs from what scenes/generate_gltf.py writes: " + ", ".join(stale + extra), file=sys.stderr)
            return 1
        print(f"{len(files)} files up to date")
        return 0
    if assets.is_dir():
        for f in assets.iterdir():
            f.unlink()
    for name, data in files.items():
        (HERE / name).parent.mkdir(parents=True, exist_ok=True)
        (HERE / name).write_bytes(data)
    print(f"wrote {len(files)} files: the model, {SCENE.name} and {assets.name}/")
    return 0


if __name__ == "__main__":
    sys.exit(main())
