"""glTF 2.0 files built for rt import's tests, through pygltflib and numpy."""

from __future__ import annotations

import base64
import io
from pathlib import Path

import numpy as np

FLOAT, UINT, USHORT, UBYTE = 5126, 5125, 5123, 5121


class Builder:
    """A glTF document under construction: arrays go into one binary buffer, objects into pygltflib's lists."""

    def __init__(self):
        import pygltflib

        self.g = pygltflib
        self.gltf = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0"))
        self.blob = bytearray()

    def accessor(self, array, component=FLOAT, kind=None) -> int:
        g = self.g
        dtype = {FLOAT: "<f4", UINT: "<u4", USHORT: "<u2", UBYTE: "u1"}[component]
        a = np.ascontiguousarray(np.asarray(array).astype(dtype))
        while len(self.blob) % 4:
            self.blob.append(0)
        offset = len(self.blob)
        self.blob += a.tobytes()
        self.gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=offset, byteLength=a.nbytes))
        kind = kind or {1: "SCALAR", 2: "VEC2", 3: "VEC3", 4: "VEC4"}[1 if a.ndim == 1 else a.shape[1]]
        acc = g.Accessor(bufferView=len(self.gltf.bufferViews) - 1, componentType=component, count=len(a), type=kind)
        if component == FLOAT and a.ndim == 2:
            acc.min, acc.max = a.min(axis=0).tolist(), a.max(axis=0).tolist()
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1

    def mesh(self, positions, indices=None, normals=None, uvs=None, material=None, name=None, mode=4,
             index_type=UINT) -> int:
        g = self.g
        attrs = g.Attributes(POSITION=self.accessor(positions))
        if normals is not None:
            attrs.NORMAL = self.accessor(normals)
        if uvs is not None:
            attrs.TEXCOORD_0 = self.accessor(uvs)
        prim = g.Primitive(attributes=attrs, material=material, mode=mode)
        if indices is not None:
            prim.indices = self.accessor(np.asarray(indices).reshape(-1), index_type)
        self.gltf.meshes.append(g.Mesh(primitives=[prim], name=name))
        return len(self.gltf.meshes) - 1

    def node(self, root=True, **kw) -> int:
        self.gltf.nodes.append(self.g.Node(**kw))
        index = len(self.gltf.nodes) - 1
        if root:
            if not self.gltf.scenes:
                self.gltf.scenes.append(self.g.Scene(nodes=[]))
                self.gltf.scene = 0
            self.gltf.scenes[0].nodes.append(index)
        return index

    def material(self, **kw) -> int:
        self.gltf.materials.append(self.g.Material(**kw))
        return len(self.gltf.materials) - 1

    def image_texture(self, png: bytes) -> int:
        """A texture of a PNG stored in the buffer."""
        g = self.g
        while len(self.blob) % 4:
            self.blob.append(0)
        self.gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(png)))
        self.blob += png
        self.gltf.images.append(g.Image(bufferView=len(self.gltf.bufferViews) - 1, mimeType="image/png"))
        self.gltf.textures.append(g.Texture(source=len(self.gltf.images) - 1))
        return len(self.gltf.textures) - 1

    def lights(self, lights: list) -> None:
        self.gltf.extensions["KHR_lights_punctual"] = {"lights": lights}
        self.gltf.extensionsUsed.append("KHR_lights_punctual")

    def save_glb(self, path) -> Path:
        self.gltf.buffers = [self.g.Buffer(byteLength=len(self.blob))]
        self.gltf.set_binary_blob(bytes(self.blob))
        self.gltf.save_binary(str(path))
        return Path(path)

    def save_gltf(self, path, embed: bool = False) -> Path:
        """A .gltf with its buffer in a .bin beside it, or embedded as a data: URI."""
        path = Path(path)
        if embed:
            uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.blob)).decode()
        else:
            uri = path.stem + ".bin"
            (path.parent / uri).write_bytes(bytes(self.blob))
        self.gltf.buffers = [self.g.Buffer(byteLength=len(self.blob), uri=uri)]
        path.write_text(self.gltf.to_json(), encoding="utf-8")
        return path


def png(rgb) -> bytes:
    """PNG bytes of an (H, W, 3) uint8 array."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.asarray(rgb, np.uint8), "RGB").save(buf, format="PNG")
    return buf.getvalue()


# A unit quad in the z = 0 plane facing +z, as two triangles over four corners.
QUAD_POSITIONS = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
QUAD_INDICES = np.array([0, 1, 2, 0, 2, 3])
QUAD_UVS = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)  # glTF's: v = 0 at the image's top
QUAD_NORMALS = np.array([[0, 0, 1]] * 4, np.float32)
