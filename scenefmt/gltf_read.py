"""Reading a glTF 2.0 file (`.glb`, or `.gltf` with its buffers and images), bounded and checked.

The document itself (nodes, meshes, materials, cameras, extensions such as KHR_lights_punctual)
is parsed by pygltflib into its dataclasses: we keep glTF's own model rather than a converter's
scene (trimesh would turn the file into its own scene graph and drop what it has no place for,
the lights and most material extensions). The bytes are ours to read: the GLB container is split
here, every buffer is found and sized here, and each accessor is read with numpy after checking
that what it declares lies inside the bytes that exist. A file is untrusted, so:

- the file's real size is known before anything is read, and every length the file declares
  (GLB chunks, buffers, buffer views, accessors) is checked against bytes that exist before an
  array is made: nothing large is allocated on a number's word;
- a buffer or image named by a relative URI must lie inside the model's folder (no absolute path,
  no `..` out of it, no other scheme than `data:`), and a `data:` URI must hold what it declares;
- the JSON may not hold NaN or Infinity, and every number we use is checked finite.

Every problem is a `GltfProblem` whose message is one sentence (no part of the file quoted raw).
"""

from __future__ import annotations

import base64
import binascii
import json
import math
import os
import re
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional
from urllib.parse import unquote

import numpy as np

from .diagnostics import quote_text
from .files import FileProblem, open_regular_file

# Largest model file (.glb or .gltf) and largest buffer or image file it names.
MAX_MODEL_BYTES = 4 << 30
# Largest JSON document (the .gltf file or the GLB's JSON chunk): its numbers become Python objects.
MAX_JSON_BYTES = 64 << 20
# Most elements one accessor may declare, whatever its bytes (2^31: index arrays stay int64-safe).
MAX_ACCESSOR_COUNT = 1 << 31
_GLB_MAGIC = b"glTF"
_CHUNK_JSON = 0x4E4F534A
_CHUNK_BIN = 0x004E4942

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
COMPONENT_TYPES = {
    5120: np.dtype("<i1"),
    5121: np.dtype("<u1"),
    5122: np.dtype("<i2"),
    5123: np.dtype("<u2"),
    5125: np.dtype("<u4"),
    5126: np.dtype("<f4"),
}
_DATA_URI = re.compile(r"^data:([^,;]*)((?:;[^,;]*)*?)(;base64)?,", re.IGNORECASE)
_SCHEME = re.compile(r"^[A-Za-z][A-Za-z0-9+.\-]*:")


class GltfProblem(Exception):
    """The model cannot be imported; the message is one sentence."""


@dataclass
class GltfDocument:
    """A parsed glTF document and the bytes of its buffers."""

    gltf: Any  # pygltflib.GLTF2
    folder: Path  # the model's folder: relative URIs resolve inside it
    name: str  # the model file's name, for messages
    buffers: list = field(default_factory=list)  # bytes of each buffer, exactly its byteLength
    glb_bin: Optional[bytes] = None  # a .glb's BIN chunk


def need_pygltflib():
    """The pygltflib module, or a GltfProblem saying how to install it."""
    try:
        import pygltflib
    except ImportError:
        raise GltfProblem("importing glTF needs the pygltflib package, which is not installed: "
                          "pip install '.[gltf]' in rt's folder (or pip install pygltflib)") from None
    return pygltflib


def as_int(value: Any, what: str, low: int = 0, high: int = 2**62) -> int:
    """`value` as an integer in [low, high], or a GltfProblem naming `what`."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise GltfProblem(f"{what} must be an integer, found {_kind(value)}")
    if not low <= value <= high:
        raise GltfProblem(f"{what} is {value}, outside [{low:,}, {high:,}]")
    return value


def as_float(value: Any, what: str, default: Optional[float] = None) -> float:
    """`value` as a finite float (`default` when it is None), or a GltfProblem naming `what`."""
    if value is None and default is not None:
        return default
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise GltfProblem(f"{what} must be a finite number, found {_kind(value)}")
    return float(value)


def as_floats(value: Any, n: int, what: str, default=None) -> tuple:
    """A list of `n` finite floats, or a GltfProblem."""
    if value is None and default is not None:
        return tuple(default)
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise GltfProblem(f"{what} must be a list of {n} numbers, found {_kind(value)}")
    return tuple(as_float(x, what) for x in value)


def _kind(value: Any) -> str:
    if value is None:
        return "nothing"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return repr(value) if isinstance(value, int) or math.isfinite(value) else "a non-finite number"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)}"
    return f"a {type(value).__name__}"


def _read_bounded(path: Path, limit: int, what: str) -> bytes:
    """The bytes of a regular file of at most `limit` bytes (its size checked before reading)."""
    try:
        with open_regular_file(path) as fh:
            size = os.fstat(fh.fileno()).st_size
            if size > limit:
                raise GltfProblem(f"{what} is {size:,} bytes, more than the {limit:,} allowed")
            _check_memory(size, what)
            data = fh.read(size + 1)
    except FileProblem as exc:
        raise GltfProblem(f"{what}: {exc}") from None
    except OSError as exc:
        raise GltfProblem(f"{what}: {exc.strerror or type(exc).__name__}") from None
    if len(data) > size:
        raise GltfProblem(f"{what} grew while it was read")
    return data


def _check_memory(size: int, what: str) -> None:
    from .bounds import gib, memory_limit, memory_limit_text

    if size > memory_limit():
        raise GltfProblem(f"{what} needs about {gib(size)}, more than {memory_limit_text()}")


def load(path) -> GltfDocument:
    """The document of a `.glb` or `.gltf` file and the bytes of every buffer, checked."""
    pygltflib = need_pygltflib()
    path = Path(path)
    name = quote_text(path.name)
    data = _read_bounded(path, MAX_MODEL_BYTES, f"the model {name}")
    glb_bin = None
    if data[:4] == _GLB_MAGIC:
        text, glb_bin = _split_glb(data)
    else:
        if len(data) > MAX_JSON_BYTES:
            raise GltfProblem(f"the glTF JSON is {len(data):,} bytes, more than the {MAX_JSON_BYTES:,} allowed")
        text = data
    del data
    gltf = _parse_json(pygltflib, text)
    doc = GltfDocument(gltf=gltf, folder=path.resolve().parent, name=name, glb_bin=glb_bin)
    version = getattr(gltf.asset, "version", None) if gltf.asset is not None else None
    if not isinstance(version, str) or not version.startswith("2."):
        raise GltfProblem("the file is not glTF 2.0 (its asset.version is missing or not 2.x)")
    doc.buffers = [_buffer_bytes(doc, i) for i in range(len(gltf.buffers or []))]
    return doc


def _split_glb(data: bytes) -> tuple[bytes, Optional[bytes]]:
    """The JSON and BIN chunks of a GLB container, every length checked against the real size."""
    if len(data) < 20:
        raise GltfProblem("the .glb file is shorter than its 12-byte header and first chunk header")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise GltfProblem(f"the .glb container is version {version}, not 2")
    if length > len(data):
        raise GltfProblem(f"the .glb header declares {length:,} bytes but the file has {len(data):,}")
    chunks = []
    at = 12
    while at + 8 <= length:
        size, kind = struct.unpack_from("<II", data, at)
        at += 8
        if size > length - at:
            raise GltfProblem(f"a .glb chunk declares {size:,} bytes but only {length - at:,} remain in the file")
        chunks.append((kind, at, size))
        at += size
    if not chunks or chunks[0][0] != _CHUNK_JSON:
        raise GltfProblem("the .glb file's first chunk is not its JSON")
    _, start, size = chunks[0]
    if size > MAX_JSON_BYTES:
        raise GltfProblem(f"the glTF JSON is {size:,} bytes, more than the {MAX_JSON_BYTES:,} allowed")
    text = data[start:start + size]
    blob = None
    if len(chunks) > 1 and chunks[1][0] == _CHUNK_BIN:
        _, start, size = chunks[1]
        blob = data[start:start + size]
    return text, blob


def _no_constants(name: str):
    raise ValueError(f"the JSON holds {name}, which glTF does not allow")


def _parse_json(pygltflib, text: bytes):
    try:
        decoded = text.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise GltfProblem("the glTF JSON is not UTF-8 text") from None
    try:
        raw = json.loads(decoded, parse_constant=_no_constants)
    except RecursionError:
        raise GltfProblem("the glTF JSON nests too deeply") from None
    except ValueError as exc:
        message = str(exc) if "glTF does not allow" in str(exc) else f"it does not parse ({exc.__class__.__name__} at character {getattr(exc, 'pos', '?')})"
        raise GltfProblem(f"the glTF JSON is not valid: {message}") from None
    if not isinstance(raw, dict):
        raise GltfProblem("the glTF JSON is not an object")
    for key in ("nodes", "meshes", "accessors", "bufferViews", "buffers", "materials", "textures", "images",
                "cameras", "scenes", "samplers"):
        if key in raw and not isinstance(raw[key], list):
            raise GltfProblem(f"the glTF JSON's {key!r} is not a list")
        for item in raw.get(key) or []:
            if not isinstance(item, dict):
                raise GltfProblem(f"an entry of the glTF JSON's {key!r} is not an object")
    try:
        return pygltflib.GLTF2.from_json(json.dumps(raw), infer_missing=True)
    except RecursionError:
        raise GltfProblem("the glTF JSON nests too deeply") from None
    except Exception as exc:  # noqa: BLE001 - dataclasses_json raises what the types it meets raise
        raise GltfProblem(f"the glTF JSON does not have glTF's structure ({type(exc).__name__})") from None


def _uri_path(doc: GltfDocument, uri: str, what: str) -> Path:
    """The file a relative URI names, inside the model's folder."""
    if _SCHEME.match(uri) or uri.startswith(("/", "\\")) or re.match(r"^[A-Za-z]:", uri):
        raise GltfProblem(f"{what} names {quote_text(uri[:80])}, which is no relative path inside the model's folder "
                          "(absolute paths and URLs are refused)")
    name = unquote(uri)
    if "\x00" in name:
        raise GltfProblem(f"{what} has a NUL byte in its URI")
    target = (doc.folder / name)
    try:
        real = target.resolve()
    except (OSError, RuntimeError, ValueError):
        raise GltfProblem(f"{what} names {quote_text(uri[:80])}, which cannot be resolved") from None
    if not real.is_relative_to(doc.folder):
        raise GltfProblem(f"{what} names {quote_text(uri[:80])}, which lies outside the model's folder")
    return real


def _data_uri(uri: str, what: str, limit: int) -> tuple[bytes, str]:
    """The bytes and media type of a `data:` URI, its length checked before it is decoded."""
    m = _DATA_URI.match(uri)
    if not m:
        raise GltfProblem(f"{what} has a malformed data: URI")
    payload = uri[m.end():]
    if not m.group(3):
        raise GltfProblem(f"{what} has a data: URI that is not base64")
    if len(payload) // 4 * 3 > limit:
        raise GltfProblem(f"{what}'s data: URI holds about {len(payload) // 4 * 3:,} bytes, more than the {limit:,} expected")
    try:
        return base64.b64decode(payload, validate=True), m.group(1).lower()
    except (binascii.Error, ValueError):
        raise GltfProblem(f"{what}'s data: URI is not valid base64") from None


def _buffer_bytes(doc: GltfDocument, index: int) -> bytes:
    buf = doc.gltf.buffers[index]
    what = f"buffer {index}"
    length = as_int(buf.byteLength, f"{what}'s byteLength", 0, MAX_MODEL_BYTES)
    uri = buf.uri
    if uri is None:
        if index != 0 or doc.glb_bin is None:
            raise GltfProblem(f"{what} has no uri and there is no .glb binary chunk for it")
        data = doc.glb_bin
    elif not isinstance(uri, str):
        raise GltfProblem(f"{what}'s uri is not a string")
    elif uri[:5].lower() == "data:":
        data, _ = _data_uri(uri, what, length + 3)
    else:
        path = _uri_path(doc, uri, what)
        # Sized before it is read: a declared byteLength beyond the real file is an error, not an allocation.
        try:
            size = os.stat(path).st_size
        except OSError as exc:
            raise GltfProblem(f"{what}: its file {quote_text(uri[:80])} cannot be read ({exc.strerror})") from None
        if size < length:
            raise GltfProblem(f"{what} declares {length:,} bytes but its file has {size:,}")
        data = _read_bounded(path, MAX_MODEL_BYTES, f"{what}'s file")[:length]
    if len(data) < length:
        raise GltfProblem(f"{what} declares {length:,} bytes but holds {len(data):,}")
    return data[:length] if len(data) > length else data


def view_bytes(doc: GltfDocument, index: Any, what: str) -> tuple[bytes, int, int, Optional[int]]:
    """(buffer bytes, offset, length, stride) of a buffer view, checked to lie inside its buffer."""
    views = doc.gltf.bufferViews or []
    index = as_int(index, f"{what}'s bufferView", 0, len(views) - 1) if views else _missing(what, "bufferView")
    view = views[index]
    vwhat = f"bufferView {index}"
    b = as_int(view.buffer, f"{vwhat}'s buffer", 0, len(doc.buffers) - 1) if doc.buffers else _missing(vwhat, "buffer")
    offset = as_int(view.byteOffset or 0, f"{vwhat}'s byteOffset")
    length = as_int(view.byteLength, f"{vwhat}'s byteLength")
    data = doc.buffers[b]
    if offset + length > len(data):
        raise GltfProblem(f"{vwhat} reaches byte {offset + length:,} of buffer {b}, which has {len(data):,}")
    stride = None if view.byteStride is None else as_int(view.byteStride, f"{vwhat}'s byteStride", 1, 252)
    return data, offset, length, stride


def _missing(what: str, key: str):
    raise GltfProblem(f"{what} names a {key}, but the file has none")


def read_accessor(doc: GltfDocument, index: Any, what: str, types: tuple = ("SCALAR", "VEC2", "VEC3", "VEC4"),
                  max_count: Optional[int] = None) -> np.ndarray:
    """Accessor `index` as a (count, components) array (float64 for floats and normalised integers,
    int64 for integers), after checking that every element lies inside its buffer view and that the
    view lies inside its buffer; `what` says what it is for, in messages."""
    accessors = doc.gltf.accessors or []
    index = as_int(index, f"{what}'s accessor", 0, len(accessors) - 1) if accessors else _missing(what, "accessor")
    acc = accessors[index]
    awhat = f"accessor {index} ({what})"
    if acc.type not in types:
        raise GltfProblem(f"{awhat} has type {quote_text(str(acc.type)[:20])}, expected {' or '.join(types)}")
    n = COMPONENTS[acc.type]
    if acc.componentType not in COMPONENT_TYPES:
        raise GltfProblem(f"{awhat} has an unknown componentType")
    dtype = COMPONENT_TYPES[acc.componentType]
    count = as_int(acc.count, f"{awhat}'s count", 1, max_count or MAX_ACCESSOR_COUNT)
    if acc.sparse is not None:
        raise GltfProblem(f"{awhat} is sparse, which rt import does not read")
    element = n * dtype.itemsize
    if acc.bufferView is None:
        # No bytes behind it: glTF's zeros; bounded by the size of the largest buffer a real one could use.
        limit = max((len(b) for b in doc.buffers), default=0) // element + 1
        if count > limit:
            raise GltfProblem(f"{awhat} declares {count:,} zero elements with no buffer view, more than the file holds")
        return np.zeros((count, n), np.float64 if dtype.kind == "f" or acc.normalized else np.int64)
    data, offset, length, stride = view_bytes(doc, acc.bufferView, awhat)
    stride = stride or element
    if stride < element:
        raise GltfProblem(f"{awhat}'s elements are {element} bytes but its buffer view's stride is {stride}")
    start = as_int(acc.byteOffset or 0, f"{awhat}'s byteOffset")
    end = start + (count - 1) * stride + element
    if end > length:
        raise GltfProblem(f"{awhat} needs bytes {start:,} to {end:,} of its buffer view, which has {length:,}")
    _check_memory(count * n * 8, f"reading {awhat}")  # the float64 or int64 array made below
    raw = np.ndarray((count, n), dtype=dtype, buffer=data, offset=offset + start, strides=(stride, dtype.itemsize))
    if dtype.kind == "f":
        out = raw.astype(np.float64)
        if not np.isfinite(out).all():
            raise GltfProblem(f"{awhat} holds a NaN or infinite number")
        return out
    if acc.normalized:
        if dtype.kind == "u":
            return raw.astype(np.float64) / float(np.iinfo(dtype).max)
        return np.maximum(raw.astype(np.float64) / float(np.iinfo(dtype).max), -1.0)
    return raw.astype(np.int64)


def image_bytes(doc: GltfDocument, index: int, limit: int = MAX_MODEL_BYTES) -> tuple[bytes, str]:
    """(bytes, suffix) of image `index`: ".png" or ".jpg" by its first bytes; GltfProblem for other formats."""
    images = doc.gltf.images or []
    index = as_int(index, "a texture's source image", 0, len(images) - 1) if images else _missing("a texture", "image")
    img = images[index]
    what = f"image {index}"
    if img.uri is not None:
        if not isinstance(img.uri, str):
            raise GltfProblem(f"{what}'s uri is not a string")
        if img.uri[:5].lower() == "data:":
            data, _ = _data_uri(img.uri, what, limit)
        else:
            data = _read_bounded(_uri_path(doc, img.uri, what), limit, f"{what}'s file")
    elif img.bufferView is not None:
        buf, offset, length, _ = view_bytes(doc, img.bufferView, what)
        data = buf[offset:offset + length]
    else:
        raise GltfProblem(f"{what} has neither a uri nor a bufferView")
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        return data, ".png"
    if data[:3] == b"\xff\xd8\xff":
        return data, ".jpg"
    raise GltfProblem(f"{what} is neither PNG nor JPEG data")
