"""Textures: their tables, their flattening, and their lookup in the kernels.

Solid colours, 3-D checkers, images read at surface (u, v), and Perlin noise. Image texels
are linearised here, and the Perlin lattice tables made, in Python; `TextureTables` collects
a scene's texture rows as materials refer to them; `texture_value` reads them in the kernels.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from . import target
from .columns import Column, Layout
from .kernel_flags import CHECKER, IMAGE, NOISE

# Type codes.
TEX_SOLID = 0
TEX_CHECKER = 1
TEX_IMAGE = 2
TEX_NOISE = 3
NOISE_FORMS = {"plain": 0, "turbulence": 1, "marble": 2}
NOISE_PLAIN, NOISE_TURBULENCE, NOISE_MARBLE = NOISE_FORMS["plain"], NOISE_FORMS["turbulence"], NOISE_FORMS["marble"]

TEXTURE_I = Layout("tex_i", "int32", [
    Column("kind", 1, "type code: TEX_SOLID, TEX_CHECKER, TEX_IMAGE or TEX_NOISE"),
    Column("even", 1, "checker: texture row of the even cells (-1 otherwise)"),
    Column("odd", 1, "checker: texture row of the odd cells (-1 otherwise)"),
])
_COLOR = Column("color", 3, "linear RGB: the colour (solid), or what the noise value scales (noise)")
TEXTURE_WIDTH = 7
SOLID_F = Layout("tex_f solid", "float64", [_COLOR], TEXTURE_WIDTH)
CHECKER_F = Layout("tex_f checker", "float64", [_COLOR, Column("inv_scale", 1, "1 / the cell size")], TEXTURE_WIDTH)
IMAGE_F = Layout("tex_f image", "float64", [
    _COLOR,
    Column("texels", 1, "row of the image's first texel in `texels`"),
    Column("width", 1, "width in texels"),
    Column("height", 1, "height in texels"),
], TEXTURE_WIDTH)
NOISE_F = Layout("tex_f noise", "float64", [
    _COLOR,
    Column("scale", 1, "frequency of the noise"),
    Column("form", 1, "NOISE_PLAIN, NOISE_TURBULENCE or NOISE_MARBLE"),
    Column("octaves", 1, "turbulence octaves"),
    Column("table", 1, "which Perlin lattice in noise_perm and noise_vec"),
], TEXTURE_WIDTH)
for _layout in (CHECKER_F, IMAGE_F, NOISE_F):
    SOLID_F.shares(_layout, "color")
TEX_KIND, TEX_EVEN, TEX_ODD = TEXTURE_I.offsets("kind", "even", "odd")
TEX_COLOR = SOLID_F.offset("color")
TEX_INV_SCALE = CHECKER_F.offset("inv_scale")
TEX_TEXELS, TEX_WIDTH, TEX_HEIGHT = IMAGE_F.offsets("texels", "width", "height")
TEX_SCALE, TEX_FORM, TEX_OCTAVES, TEX_TABLE = NOISE_F.offsets("scale", "form", "octaves", "table")


def srgb_to_linear(values: np.ndarray) -> np.ndarray:
    """The sRGB transfer function inverted (IEC 61966-2-1), for values in [0, 1]."""
    return np.where(values <= 0.04045, values / 12.92, ((values + 0.055) / 1.055) ** 2.4)


def load_image_texels(path: Path, colorspace: str = "srgb") -> np.ndarray:
    """An (h, w, 3) float32 array of linear RGB, row 0 at the top of the image.

    OpenEXR and PFM files (by suffix) are read as float RGB, linear as stored; other images
    through Pillow, as below.

    Memory: the decoded image, its 8-bit RGB form (3 bytes a pixel) and the float32 texels
    (12 bytes a pixel), made by looking each 8-bit value up in a 256-entry table; no float64
    copy of the image is ever made (scenefmt.bounds.TEXTURE_BYTES_PER_PIXEL counts this).
    The file is opened as a regular file only, and its size is checked from its header before
    anything is decoded.
    """
    import warnings

    from PIL import Image, UnidentifiedImageError

    from scenefmt.bounds import TEXTURE_BYTES_PER_PIXEL, gib, memory_limit, memory_limit_text
    from scenefmt.files import FileProblem, open_regular_file
    from scenefmt.graph import MAX_TEXTURE_PIXELS  # the bound `rt validate` checks
    from scenefmt.hdr_files import HdrProblem, is_hdr, read_hdr

    if is_hdr(path):  # float RGB, linear as stored: `colorspace` does not apply
        try:
            return read_hdr(path, MAX_TEXTURE_PIXELS, memory_limit())
        except HdrProblem as exc:
            raise ValueError(f"{path}: {exc}") from None

    try:
        with warnings.catch_warnings(), open_regular_file(path) as fh:
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)  # bounded below, by our own limits
            with Image.open(fh) as img:
                pixels = img.width * img.height
                if pixels > MAX_TEXTURE_PIXELS:
                    raise ValueError(f"{path}: {img.width} x {img.height} is larger than the {MAX_TEXTURE_PIXELS:,} pixels allowed")
                if pixels * TEXTURE_BYTES_PER_PIXEL > memory_limit():  # checked before a pixel is decoded
                    raise ValueError(f"{path}: is {img.width} x {img.height} pixels: decoding it needs about "
                                     f"{gib(pixels * TEXTURE_BYTES_PER_PIXEL)}, more than {memory_limit_text()}")
                rgb8 = np.asarray(img.convert("RGB"), dtype=np.uint8)
    except FileProblem as exc:
        raise ValueError(f"{path}: {exc}") from None
    except (UnidentifiedImageError, Image.DecompressionBombError) as exc:
        # Not Pillow's words: they may quote the file (a PPM's header token); the kind of failure only.
        raise ValueError(f"{path}: cannot read it as an image (Pillow could not decode it: {type(exc).__name__})") from None
    except (ValueError, MemoryError):
        raise
    except Exception as exc:  # noqa: BLE001 - a decoder meets a broken file: OSError, SyntaxError, struct.error, ...
        raise ValueError(f"{path}: cannot read it as an image ({type(exc).__name__}: the file is damaged or truncated)") from None
    table = np.arange(256, dtype=np.float64) / 255.0
    if colorspace == "srgb":
        table = srgb_to_linear(table)
    return np.ascontiguousarray(table.astype(np.float32)[rgb8])


def perlin_tables(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Three 256-entry permutations and 256 random unit vectors (Perlin's lattice, after Kensler)."""
    rng = np.random.default_rng(seed)
    perm = np.empty((3, 256), np.int32)
    for axis in range(3):
        p = np.arange(256, dtype=np.int32)
        # Fisher-Yates, as the books build their tables.
        for i in range(255, 0, -1):
            j = int(rng.integers(0, i + 1))
            p[i], p[j] = p[j], p[i]
        perm[axis] = p
    vec = np.empty((256, 3))
    k = 0
    while k < 256:
        v = rng.uniform(-1.0, 1.0, 3)
        n = float(v @ v)
        if 1e-12 < n <= 1.0:  # uniform directions by rejection from the cube
            vec[k] = v / np.sqrt(n)
            k += 1
    return perm, vec


class TextureTables:
    """A scene's texture rows, made as materials and media refer to texture nodes (each node once)."""

    def __init__(self):
        self.ints: list[list] = []
        self.floats: list[list] = []
        self.texel_chunks: list[np.ndarray] = []
        self.texel_count = 0
        self.noise_seeds: list[int] = []
        self._rows: dict[int, int] = {}
        self._white: int | None = None
        # (file identity, colorspace) -> (first texel, width, height): a file named by several
        # textures (or spellings of its path) is decoded once and its texels shared.
        self._images: dict[tuple, tuple[int, int, int]] = {}

    def add(self, node, data: bool = False) -> int:
        """The row of texture node `node` (a scenefmt.graph.TextureNode), added with its children.

        `data`: the texture holds numbers, not colours (a normal or bump map, a roughness): an
        image whose `colorspace` the file leaves unsaid is then read as linear, as glTF and
        every renderer read such maps (an sRGB decode would bend every normal). The same node
        used both ways gets a row for each."""
        key = (id(node), data)
        if key in self._rows:
            return self._rows[key]
        m = node.model
        index = len(self.ints)
        self._rows[key] = index
        self.ints.append([])  # reserve the slot; children come after
        self.floats.append([])
        ints = TEXTURE_I.row(kind=TEX_SOLID, even=-1, odd=-1)
        if m.type == "solid":
            floats = SOLID_F.row(color=m.color)
        elif m.type == "checker":
            ints = TEXTURE_I.row(kind=TEX_CHECKER, even=self.add(node.inputs["even"], data),
                                 odd=self.add(node.inputs["odd"], data))
            floats = CHECKER_F.row(inv_scale=1.0 / m.scale)
        elif m.type == "image":
            from scenefmt.diagnostics import format_path

            colorspace = "linear" if data and "colorspace" not in m.model_fields_set else m.colorspace
            first, w, h = self._image(node, colorspace, format_path)
            ints = TEXTURE_I.row(kind=TEX_IMAGE, even=-1, odd=-1)
            floats = IMAGE_F.row(texels=float(first), width=float(w), height=float(h))
        else:
            ints = TEXTURE_I.row(kind=TEX_NOISE, even=-1, odd=-1)
            floats = NOISE_F.row(color=m.color, scale=m.scale, form=float(NOISE_FORMS[m.form]),
                                 octaves=float(m.octaves), table=float(len(self.noise_seeds)))
            self.noise_seeds.append(m.seed)
        self.ints[index], self.floats[index] = ints, floats
        return index

    def _image(self, node, colorspace: str, format_path) -> tuple[int, int, int]:
        """(first texel, width, height) of an image texture's file, decoded on its first use only."""
        from scenefmt.assets import file_identity
        from scenefmt.hdr_files import is_hdr

        identity = file_identity(node.image_path)
        key = (identity, "linear" if is_hdr(node.image_path) else colorspace)
        if identity is not None and key in self._images:
            return self._images[key]
        try:
            texels = load_image_texels(node.image_path, colorspace)
        except ValueError as exc:
            raise ValueError(f"image texture at {format_path(node.path)}: {exc}") from None
        h, w = texels.shape[:2]
        placed = (self.texel_count, w, h)
        self.texel_chunks.append(texels.reshape(-1, 3))
        self.texel_count += w * h
        if identity is not None:
            self._images[key] = placed
        return placed

    def white(self) -> int:
        """The row of a solid white texture, added once (a dielectric attenuates by it)."""
        if self._white is None:
            self._white = len(self.ints)
            self.ints.append(TEXTURE_I.row(kind=TEX_SOLID, even=-1, odd=-1))
            self.floats.append(SOLID_F.row(color=(1.0, 1.0, 1.0)))
        return self._white

    def reads_uv(self, row: int) -> bool:
        """Whether texture `row` looks at surface coordinates: an image, or a checker over one.

        The kernels compute a hit's (u, v) only for such materials: on a sphere that takes an
        arc cosine and an arc tangent, which every other texture would pay for nothing.
        """
        ints = self.ints[row]
        if ints[TEX_KIND] == TEX_IMAGE:
            return True
        return ints[TEX_KIND] == TEX_CHECKER and (self.reads_uv(ints[TEX_EVEN]) or self.reads_uv(ints[TEX_ODD]))

    def arrays(self) -> dict[str, np.ndarray]:
        """The FlatScene fields of the textures: tex_i, tex_f, texels, noise_perm, noise_vec."""
        n = len(self.ints)
        texels = (np.concatenate(self.texel_chunks).astype(np.float32) if self.texel_chunks
                  else np.zeros((1, 3), np.float32))
        if self.noise_seeds:
            lattices = [perlin_tables(seed) for seed in self.noise_seeds]
            noise_perm = np.stack([p for p, _ in lattices]).astype(np.int32)
            noise_vec = np.stack([v for _, v in lattices]).astype(np.float64)
        else:
            noise_perm = np.zeros((1, 3, 256), np.int32)
            noise_vec = np.zeros((1, 256, 3), np.float64)
        return {
            "tex_i": np.array(self.ints, np.int32).reshape(n, TEXTURE_I.width),
            "tex_f": np.array(self.floats, np.float64).reshape(n, TEXTURE_WIDTH),
            "texels": texels,
            "noise_perm": noise_perm,
            "noise_vec": noise_vec,
        }


# --- the kernels ------------------------------------------------------------------------------


@target.device_noinline
def perlin(perm, vec, q, x, y, z):
    """Gradient noise at (x, y, z) from table set q, in about [-1, 1]; continuous everywhere."""
    fx, fy, fz = math.floor(x), math.floor(y), math.floor(z)
    u, v, w = x - fx, y - fy, z - fz
    i, j, k = int(fx), int(fy), int(fz)
    # Hermite smoothing once, inside the interpolation (the weight vectors use the raw offsets).
    uu, vv, ww = u * u * (3.0 - 2.0 * u), v * v * (3.0 - 2.0 * v), w * w * (3.0 - 2.0 * w)
    accum = 0.0
    for di in range(2):
        for dj in range(2):
            for dk in range(2):
                h = perm[q, 0, (i + di) & 255] ^ perm[q, 1, (j + dj) & 255] ^ perm[q, 2, (k + dk) & 255]
                gx, gy, gz = vec[q, h, 0], vec[q, h, 1], vec[q, h, 2]
                dot = gx * (u - di) + gy * (v - dj) + gz * (w - dk)
                accum += (
                    (di * uu + (1 - di) * (1.0 - uu))
                    * (dj * vv + (1 - dj) * (1.0 - vv))
                    * (dk * ww + (1 - dk) * (1.0 - ww))
                    * dot
                )
    return accum


@target.device_noinline
def turbulence(perm, vec, q, x, y, z, octaves):
    accum = 0.0
    weight = 1.0
    for _ in range(octaves):
        accum += weight * perlin(perm, vec, q, x, y, z)
        weight *= 0.5
        x, y, z = x * 2.0, y * 2.0, z * 2.0
    return abs(accum)


@target.device
def texture_value(tex_i, tex_f, texels, noise_perm, noise_vec, t, u, v, p):
    """Colour of texture t at surface coordinates (u, v) and point p."""
    # Checkers choose a child texture: descend iteratively (kernels avoid recursion).
    while CHECKER and tex_i[t, TEX_KIND] == TEX_CHECKER:
        inv = tex_f[t, TEX_INV_SCALE]
        s = math.floor(inv * p[0]) + math.floor(inv * p[1]) + math.floor(inv * p[2])
        t = tex_i[t, TEX_EVEN] if int(s) % 2 == 0 else tex_i[t, TEX_ODD]
    kind = tex_i[t, TEX_KIND]
    if kind == TEX_SOLID:
        return (tex_f[t, TEX_COLOR], tex_f[t, TEX_COLOR + 1], tex_f[t, TEX_COLOR + 2])
    if IMAGE and kind == TEX_IMAGE:
        offset, width, height = int(tex_f[t, TEX_TEXELS]), int(tex_f[t, TEX_WIDTH]), int(tex_f[t, TEX_HEIGHT])
        uc = min(1.0, max(0.0, u))
        vc = 1.0 - min(1.0, max(0.0, v))  # image rows run top to bottom
        i = min(width - 1, int(uc * width))
        j = min(height - 1, int(vc * height))
        k = offset + j * width + i
        return (float(texels[k, 0]), float(texels[k, 1]), float(texels[k, 2]))
    if NOISE:  # the only kind left: TEX_NOISE
        scale, form, octaves, q = tex_f[t, TEX_SCALE], int(tex_f[t, TEX_FORM]), int(tex_f[t, TEX_OCTAVES]), int(tex_f[t, TEX_TABLE])
        if form == NOISE_PLAIN:
            value = 0.5 * (1.0 + perlin(noise_perm, noise_vec, q, scale * p[0], scale * p[1], scale * p[2]))
        elif form == NOISE_MARBLE:
            value = 0.5 * (1.0 + math.sin(scale * p[2] + 10.0 * turbulence(noise_perm, noise_vec, q, p[0], p[1], p[2], octaves)))
        else:
            value = turbulence(noise_perm, noise_vec, q, scale * p[0], scale * p[1], scale * p[2], octaves)
        return (tex_f[t, TEX_COLOR] * value, tex_f[t, TEX_COLOR + 1] * value, tex_f[t, TEX_COLOR + 2] * value)
    return (tex_f[t, TEX_COLOR], tex_f[t, TEX_COLOR + 1], tex_f[t, TEX_COLOR + 2])  # unreachable: the scene has no noise texture


def texture_peak(tex_i: np.ndarray, tex_f: np.ndarray, texels: np.ndarray, row: int, depth: int = 0) -> float:
    """An upper bound of the largest channel texture row `row` can return (numpy, at flattening
    time): a solid colour's, a checker's brighter cell's, an image's colour times its brightest
    texel (of all images: a bound, not the exact one), a noise texture's colour."""
    kind = tex_i[row, TEX_KIND]
    if kind == TEX_CHECKER and depth < 64:
        return max(texture_peak(tex_i, tex_f, texels, int(tex_i[row, TEX_EVEN]), depth + 1),
                   texture_peak(tex_i, tex_f, texels, int(tex_i[row, TEX_ODD]), depth + 1))
    colour = float(np.max(tex_f[row, 0:3]))
    if kind == TEX_IMAGE and texels.size:
        return colour * float(np.max(texels))
    return colour
