"""What a valid scene implies, checked before the renderer derives or allocates it.

Each number of a file is bounded where it is written (`base.MAX_MAGNITUDE`), but a scene can
still ask for the impossible through what the renderer derives from several numbers:

- transforms: a chain of steps, and instances nested in instances, multiply; a product can
  overflow, underflow to a singular map, or flatten a shape (`check_transform`, and the walk
  over groups in `check_scene`);
- colours: a path's weight is a product of reflectances and its value an emitted radiance; a
  reflectance above 1 grows without bound with depth, and a radiance near 1e300 overflows
  the film's sums of squares (`check_colours`);
- size: nested instances multiply (ten groups of ten instances each are 10^10 shapes), image
  textures decode to 12 bytes a pixel and more, and the film holds several arrays of doubles a
  pixel (`estimate_memory`), against a share of this machine's physical memory.

Everything is pure Python over the node graph; each problem is placed at the line and column of
the value that causes it.
"""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from typing import Callable, Optional

from .affine import Affine, compose, step_matrix
from .diagnostics import Diagnostic

# A path's throughput is a product of reflectances: at most 1 each, so it cannot grow with depth.
MAX_REFLECTANCE = 1.0
# Emitted and background radiance; far above any light of the books (15), far below overflow:
# squared and summed over 1e6 samples per pixel it stays below 1e31.
MAX_RADIANCE = 1e12
# World-space bounds of every shape after all its transforms: squares and triple products of
# such lengths stay finite and non-zero in float64.
MAX_EXTENT = 1e60
MIN_SIZE = 1e-60
# A map may stretch one direction at most this much more than another (a shape flattened further
# is numerically a plane: the inverse the renderer needs loses every digit).
MAX_ANISOTROPY = 1e12
# Instances flattened into the top-level tree: each costs a transform, its inverse and tree nodes.
MAX_PLACEMENTS = 5_000_000
# The share of physical memory a scene may need, by the estimate below (the rest is the system's,
# the interpreter's and the kernels' own).
MEMORY_SHARE = 0.75
# Bytes per unit, with the working copies the renderer makes: the film holds sums and sums of
# squares of float64 RGB, the sums of its 8 batches (renderer.config.BATCHES), its peak sample, a
# count and a flag (renderer.film.PixelSums), then the mean, its 8-bit form and the noise
# estimate's temporaries (four RGB images: it reads the batches in place);
# a texture is decoded (up to 8 bytes a pixel), converted to 8-bit RGB, then to float32 texels
# that are copied once more when all images are joined; a placement and a primitive are Python
# rows while flattening, then numpy rows and tree nodes.
FILM_BYTES_PER_PIXEL = (2 + 8 + 1) * 3 * 8 + 8 + 1 + 4 * 3 * 8
TEXTURE_BYTES_PER_PIXEL = 8 + 3 + 12 + 12
# A float image (.exr, .pfm): the file's bytes (at most 12 a pixel uncompressed), the decoded
# float32 pixels, a contiguous copy, and the joined texels.
HDR_TEXTURE_BYTES_PER_PIXEL = 12 + 12 + 12 + 12
# A grid medium's cell, per shape holding it: its value in the kernels' table, and the table's
# assembly (a copy at most); the array as read, 8 bytes, counts once per medium.
GRID_BYTES_PER_CELL = 8 + 8
# An environment map: read as a texture is (8-bit or float), its float32 radiance, and the
# sampling tables renderer/environment.py builds in float64: the luminance times sin(theta), each
# texel's density and its row's cumulative sum, with one temporary of each.
ENVIRONMENT_EXTRA_BYTES_PER_PIXEL = 12 + 6 * 8
# A sun_sky background's map (renderer/sky.py: MAP_WIDTH x MAP_HEIGHT texels, whatever the scene):
# its directions and the model's temporaries while it is computed (40 MB measured at the peak),
# then a map's radiance and sampling tables.
SUN_SKY_MAP_PIXELS = 512 * 256
SUN_SKY_BYTES = 40_000_000 + SUN_SKY_MAP_PIXELS * ENVIRONMENT_EXTRA_BYTES_PER_PIXEL
PLACEMENT_BYTES = 1500
PRIMITIVE_BYTES = 1000
# A light row per emitting primitive per placement (renderer/lights.py: 5 integers and 26 doubles,
# 228 bytes), two nodes of a light tree (renderer/light_tree.py: 4 integers and 11 doubles each),
# and what building the tree holds at its peak: 1,870 bytes a light in all, measured with
# tracemalloc for 12,000 instanced spheres (tests/renderer/test_light_tree.py). The light table
# grows with instancing like placements do.
LIGHT_BYTES = 2_500
# A mesh triangle at its peak while flattening: vertices, indices and per-triangle rows (about
# 100 bytes kept, docs/meshes.md) plus the boxes, centroids and build arrays of its tree.
MESH_TRIANGLE_BYTES = 300
# A guided render's training (renderer/guide_training.py) at its peak: the last iteration's record
# buffer (2^18 paths, plus a row's rounding, x 3 records x 13 doubles: 82 MB), the rows kept and the
# guide's arrays made from them (44 MB), numpy's temporaries while the guide is built, and the guide
# itself (renderer/guide_build.py caps its nodes); its scratch film is counted as the film is.
GUIDE_TRAINING_BYTES = 260_000_000
# integrator caustics: a pass's photon shares of every pixel (at most renderer.local_passes.SPLAT_BYTES,
# 64 MiB) and its photons' values (a pixel index and a colour each: 4/3 of that) while they are added up.
CAUSTIC_PASS_BYTES = (1 << 26) * 7 // 3


def physical_memory() -> int:
    """Bytes of physical memory of this machine (8 GiB where the system does not say)."""
    try:
        pages, page_size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
        if pages > 0 and page_size > 0:
            return int(pages) * int(page_size)
    except (AttributeError, ValueError, OSError):
        pass
    return 8 << 30


def address_space_left() -> Optional[int]:
    """Bytes this process may still map under its address-space limit (`ulimit -v`, `prlimit
    --as`), or None where it has none: past it every allocation fails, whatever the machine has."""
    try:
        import resource

        soft = resource.getrlimit(resource.RLIMIT_AS)[0]
        if soft == resource.RLIM_INFINITY or soft <= 0:
            return None
        with open("/proc/self/statm", "rb") as fh:
            mapped = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        return max(0, soft - mapped)
    except (ImportError, OSError, ValueError, IndexError):
        return None


def memory_limit() -> int:
    """The bytes a scene and its files may need: a share of physical memory, and never more than
    the address space this process has left."""
    limit = int(MEMORY_SHARE * physical_memory())
    left = address_space_left()
    return limit if left is None else min(limit, left)


def memory_limit_text() -> str:
    """'the 12.0 GiB allowed on this machine (75% of its 16.0 GiB of memory)', or the address-space
    limit where that is the smaller."""
    limit = memory_limit()
    if limit < int(MEMORY_SHARE * physical_memory()):
        return f"the {gib(limit)} this process may still allocate (its address-space limit, ulimit -v)"
    return f"the {gib(limit)} allowed on this machine ({MEMORY_SHARE:.0%} of its {gib(physical_memory())} of memory)"


# ----------------------------------------------------------------------------------------------
# Documents: what reading a scene file costs before any of it is checked

# Bytes a value of a document costs once read, at the peak of reading it: the value itself, its
# place in its list or mapping, its key path and its line and column (kept for diagnostics).
# Measured with tracemalloc while reading YAML: 245 a value for a flat list of numbers, 273 for
# compact spheres (`{type: sphere, center: [x, y, z], radius: r, material: m}`, 12 values each);
# the resident size grew by 243 a value refusing a list of 2,000,000 numbers. Rounded up.
DOCUMENT_VALUE_BYTES = 300
# The share of the memory budget that reading a document may take: what is read stays alive
# (diagnostics point into it) beside the models, the graph and the renderer's tables made from it.
DOCUMENT_SHARE = 0.5


def document_value_limit() -> int:
    """The most values a document may hold on this machine."""
    return int(DOCUMENT_SHARE * memory_limit()) // DOCUMENT_VALUE_BYTES


def gib(n: float) -> str:
    if n >= 1 << 30:
        return f"{n / (1 << 30):.1f} GiB"
    return f"{n / (1 << 20):.1f} MiB"


# ----------------------------------------------------------------------------------------------
# Transforms


def _linear_stats(m: Affine) -> tuple[float, float, float]:
    """(Frobenius norm of the linear part, |det|, largest |translation|)."""
    a = [row[:3] for row in m]
    norm = math.sqrt(sum(x * x for row in a for x in row))
    det = (
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
        - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
        + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    )
    return norm, abs(det), max(abs(row[3]) for row in m)


@dataclass(frozen=True)
class Stretch:
    """Bounds on how a map changes lengths: it stretches none by more than `most` and shrinks
    none below `least` of itself; `shift` is its largest translation."""

    most: float
    least: float
    shift: float

    @classmethod
    def of(cls, m: Affine) -> "Stretch":
        norm, det, shift = _linear_stats(m)
        # The singular values s1 >= s2 >= s3 have s1 <= norm and s1 s2 s3 = det, so s3 >= det / norm^2.
        least = det / (norm * norm) if norm > 0 else 0.0
        return cls(norm, least, shift)


def transform_problem(m: Affine) -> Optional[str]:
    """Why the map `m` cannot be rendered (overflow, singular, flattened), or None."""
    norm, det, shift = _linear_stats(m)
    if not (math.isfinite(norm) and math.isfinite(shift)) or norm > MAX_EXTENT or shift > MAX_EXTENT:
        return f"the steps up to here multiply to a map with entries beyond {MAX_EXTENT:g}"
    least = det / (norm * norm) if norm > 0 else 0.0
    if not least >= MIN_SIZE:
        return f"the steps up to here multiply to a map that shrinks some direction below {MIN_SIZE:g} of its length (singular)"
    if norm / least > MAX_ANISOTROPY:
        return (
            f"the steps up to here multiply to a map that stretches one direction {norm / least:.3g} times more than "
            f"another (at most {MAX_ANISOTROPY:g}): it flattens the shape"
        )
    return None


def check_transform(steps, path: tuple, report: Callable[[tuple, str], None]) -> None:
    """Report at the first step after which the product of `steps` is unusable."""
    if not steps:
        return  # the identity
    m: Affine = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0))
    for i, step in enumerate(steps):
        m = compose(step_matrix(step), m)
        problem = transform_problem(m)
        if problem:
            report(path + ("transform", i), problem)
            return


# ----------------------------------------------------------------------------------------------
# Shapes: their extent (largest coordinate) and smallest size, in their own coordinates


def _norm(v) -> float:
    return math.sqrt(sum(float(x) * float(x) for x in v))


def _sup(v) -> float:
    return max(abs(float(x)) for x in v)


def shape_extent_and_size(model, mesh=None) -> tuple[float, float]:
    kind = model.type
    if kind == "mesh":
        return _mesh_extent_and_size(mesh)
    if kind == "sphere":
        x, y, z = model.center  # floats: _sup inlined, for the millions a generated scene holds
        return max(abs(x), abs(y), abs(z)) + model.radius, model.radius
    if kind == "moving_sphere":
        return max(_sup(model.center0), _sup(model.center1)) + model.radius, model.radius
    if kind == "disk":
        return _sup(model.center) + model.radius, model.radius
    if kind == "quad":
        lu, lv = _norm(model.u), _norm(model.v)
        cross = _norm(_cross(model.u, model.v))
        return _sup(model.q) + lu + lv, min(lu, lv, cross / max(lu, lv))
    if kind == "triangle":
        p0, p1, p2 = model.vertices
        edges = [_norm(_sub(b, a)) for a, b in ((p0, p1), (p1, p2), (p2, p0))]
        area2 = _norm(_cross(_sub(p1, p0), _sub(p2, p0)))
        return max(_sup(p) for p in model.vertices), min(min(edges), area2 / max(edges))
    if kind == "box":
        return max(_sup(model.min), _sup(model.max)), min(hi - lo for lo, hi in zip(model.min, model.max))
    raise TypeError(kind)


# Triangles measured at a time: about 300 bytes of temporaries each.
_MESH_CHUNK = 1 << 20


def _mesh_extent_and_size(mesh) -> tuple[float, float]:
    """Largest coordinate and smallest triangle size (twice its area over its longest edge),
    kept on the mesh: shapes that share a mesh (one file named by several) measure it once."""
    import numpy as np

    if getattr(mesh, "extent_and_size", None) is not None:
        return mesh.extent_and_size
    v, f = mesh.vertices, mesh.faces
    least = math.inf
    for lo in range(0, len(f), _MESH_CHUNK):  # a chunk at a time: the temporaries stay bounded
        part = f[lo:lo + _MESH_CHUNK]
        p0, p1, p2 = v[part[:, 0]], v[part[:, 1]], v[part[:, 2]]
        edges = np.stack([np.linalg.norm(p1 - p0, axis=1), np.linalg.norm(p2 - p1, axis=1), np.linalg.norm(p0 - p2, axis=1)])
        area2 = np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)
        least = min(least, float(np.min(np.minimum(edges.min(axis=0), area2 / edges.max(axis=0)))))
    mesh.extent_and_size = (float(np.abs(v).max()), least)
    return mesh.extent_and_size


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


# ----------------------------------------------------------------------------------------------
# The whole scene: extents through instances, placements, memory


@dataclass
class GroupFacts:
    extent: float = 0.0  # largest coordinate of anything in the group, in its coordinates
    size: float = math.inf  # smallest size of anything in it
    placements: int = 0  # top-level instances the renderer makes when it places the group
    shapes: int = 0  # shapes after every instance is expanded
    lights: int = 0  # emitting primitives after every instance is expanded (rows of the light table)


@dataclass
class MemoryEstimate:
    """Bytes the renderer will need, by part, and where in the file each part comes from."""

    film: int = 0
    textures: int = 0
    instances: int = 0
    primitives: int = 0
    lights: int = 0
    guide: int = 0  # a guided render's training and guide
    media: int = 0  # the density grids of grid media, as read and as the kernels hold them
    placements: int = 0
    expanded_shapes: int = 0
    parts: dict = field(default_factory=dict)  # part -> key path of its biggest cause

    @property
    def total(self) -> int:
        return self.film + self.textures + self.instances + self.primitives + self.lights + self.guide + self.media

    def describe(self) -> str:
        shown = [(self.film, "film"), (self.textures, "textures"), (self.instances, "instances"), (self.primitives, "shapes and trees"),
                 (self.lights, "lights"), (self.guide, "guide or photons"), (self.media, "media")]
        return ", ".join(f"{name} {gib(n)}" for n, name in shown if n >= 1 << 20) or "under 1 MiB"


class SceneBounds:
    """Walks a resolved graph once, memoising per group; `problems` lists what it found."""

    def __init__(self, graph, diagnostic: Callable[[tuple, str], Diagnostic]):
        self.graph = graph
        self.diagnostic = diagnostic
        self.problems: list[Diagnostic] = []
        self.facts: dict[int, GroupFacts] = {}
        self.biggest_instance: tuple[int, tuple] = (0, ())
        self.groups_seen: dict[int, object] = {}

    def report(self, path: tuple, message: str) -> None:
        self.problems.append(self.diagnostic(path, message))

    def group(self, group) -> GroupFacts:
        key = id(group)
        if key in self.facts:
            return self.facts[key]
        facts = GroupFacts()
        self.facts[key] = facts  # cycles are refused before this walk; this guards it anyway
        self.groups_seen[key] = group
        has_own = False
        stretches: dict = {}  # a group's many shapes share a few transforms
        for member in group.members:
            stretch = stretches.get(member.transform)
            if stretch is None:
                stretch = stretches[member.transform] = Stretch.of(member.transform)
            path = member.path
            if member.kind == "instance":
                inner = self.group(member.group)
                extent, size = inner.extent, inner.size
                facts.placements += inner.placements
                facts.shapes += inner.shapes
                facts.lights += inner.lights
                # The outermost instance of the most placements (groups are walked inside out).
                if inner.placements >= self.biggest_instance[0]:
                    self.biggest_instance = (inner.placements, member.path)
            elif member.kind == "sphere_run":
                has_own = True
                facts.shapes += len(member)
                facts.lights += _run_lights(member)
                worst, extent, size = _run_extent_and_size(member)
                path = member.path_of(worst)  # a problem with the run is reported at this sphere
            else:
                extent, size = shape_extent_and_size(member.model, member.mesh)
                has_own = True
                facts.shapes += 1
                if member.material is not None and member.material.kind == "diffuse_light":
                    facts.lights += _rows(member)  # a light row per emitting primitive
                if member.kind in ("sphere", "moving_sphere") and member.transform != _IDENTITY:
                    facts.placements += 1  # an ellipsoid gets a tree and a placement of its own
            placed_extent = stretch.most * extent + stretch.shift
            placed_size = stretch.least * size
            where = path + (("transform",) if member.transform != _IDENTITY else ())
            if not placed_extent <= MAX_EXTENT:
                self.report(where, f"placed here, the shape reaches {placed_extent:.3g} from the origin, beyond the {MAX_EXTENT:g} allowed")
                continue  # reported once, here, not again by every instance around it
            if size != math.inf and not placed_size >= MIN_SIZE:
                self.report(where, f"placed here, the shape is {placed_size:.3g} across in some direction, below the {MIN_SIZE:g} allowed")
                continue
            facts.extent = max(facts.extent, placed_extent)
            facts.size = min(facts.size, placed_size)
        if has_own:
            facts.placements += 1
        return facts


_IDENTITY: Affine = ((1.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 0.0), (0.0, 0.0, 1.0, 0.0))


def _run_extent_and_size(run) -> tuple[int, float, float]:
    """(index of the sphere reaching furthest, or the smallest if one is below MIN_SIZE; the
    run's extent; its smallest size) of a graph.SphereRunNode, in numpy."""
    import numpy as np

    reach = np.abs(run.centers).max(axis=1) + run.radii
    far, small = int(np.argmax(reach)), int(np.argmin(run.radii))
    size = float(run.radii[small])
    return (small if not size >= MIN_SIZE else far), float(reach[far]), size


def _run_lights(run) -> int:
    """Emitting spheres of a graph.SphereRunNode."""
    return sum(count for node, count in zip(run.materials, run.material_count.tolist()) if node.kind == "diffuse_light")


def _rows(member) -> int:
    """Primitives a group member adds to its tree: a box's six faces, a mesh's triangles, a run's
    spheres, one of any other shape; an instance none."""
    kind = member.kind
    if kind == "box":
        return 6
    if kind == "mesh":
        return len(member.mesh.faces) if member.mesh is not None else 0
    if kind == "sphere_run":
        return len(member)
    return 0 if kind == "instance" else 1


def _image_pixels(node) -> int:
    """Pixels of an image texture node, from the header the graph read (never the file again)."""
    if node.image_size is not None:
        width, height = node.image_size
        return width * height
    return 0


def _estimate_media(est: MemoryEstimate, walk: SceneBounds) -> None:
    """Grid media: each grid as read (once per medium) and each shape's copy in the kernels' table."""
    biggest = (0, ())
    read: set = set()
    for group in walk.groups_seen.values():
        for m in group.members:
            medium = getattr(m, "interior", None)
            if medium is None or medium.grid is None:
                continue
            n = medium.grid.size * GRID_BYTES_PER_CELL
            if id(medium) not in read:
                read.add(id(medium))
                n += medium.grid.size * 8
            est.media += n
            if n > biggest[0]:
                biggest = (n, medium.path + ("file",))
    est.parts["media"] = biggest[1]


def estimate_memory(graph, walk: Optional[SceneBounds] = None) -> MemoryEstimate:
    """The memory a render of `graph` will need, by part (see the constants above)."""
    if walk is None:
        walk = SceneBounds(graph, lambda path, message: Diagnostic("<scene>", 0, 0, path, message))
    root = walk.group(graph.root)
    est = MemoryEstimate()
    image = graph.image
    est.film = image.width * image.pixel_height * FILM_BYTES_PER_PIXEL
    est.parts["film"] = ("image", "width")
    biggest = (0, ())
    images = [(node, 0) for node in graph.textures]
    if graph.environment is not None:  # read as an image texture is, then made into sampling tables
        images.append((graph.environment, ENVIRONMENT_EXTRA_BYTES_PER_PIXEL))
    for node, extra in images:
        if node.image_path is not None:
            per_pixel = HDR_TEXTURE_BYTES_PER_PIXEL if node.image_peak is not None else TEXTURE_BYTES_PER_PIXEL
            n = _image_pixels(node) * (per_pixel + extra)
            est.textures += n
            if n > biggest[0]:
                biggest = (n, node.path + ("file",))
    if getattr(graph.background, "type", None) == "sun_sky":
        est.textures += SUN_SKY_BYTES
        if SUN_SKY_BYTES > biggest[0]:
            biggest = (SUN_SKY_BYTES, ("background",))
    est.parts["textures"] = biggest[1]
    est.placements = root.placements
    est.expanded_shapes = root.shapes
    est.instances = root.placements * PLACEMENT_BYTES
    est.parts["instances"] = walk.biggest_instance[1]
    primitives = triangles = 0  # a mesh's triangle costs less than another primitive
    for group in walk.groups_seen.values():
        for m in group.members:
            if m.kind == "mesh":
                triangles += _rows(m)
            else:
                primitives += _rows(m)
    est.primitives = primitives * PRIMITIVE_BYTES + triangles * MESH_TRIANGLE_BYTES
    est.parts["shapes and trees"] = ("shapes",)
    # A row per emitting primitive placed, and one per light under `lights:`.
    est.lights = (root.lights + len(graph.lights)) * LIGHT_BYTES
    est.parts["lights"] = ("lights",) if len(graph.lights) > root.lights else ("shapes",)
    _estimate_media(est, walk)
    if image.integrator == "guided":
        est.guide = GUIDE_TRAINING_BYTES + est.film
        est.parts["guide"] = ("image", "integrator")
    elif image.integrator == "caustics":
        est.guide = CAUSTIC_PASS_BYTES
        est.parts["guide"] = ("image", "integrator")
    return est


def check_scene(graph, diagnostic: Callable[[tuple, str], Diagnostic]) -> tuple[list[Diagnostic], MemoryEstimate]:
    """Every problem of what `graph` implies (extents, placements, colours, memory) and the estimate."""
    walk = SceneBounds(graph, diagnostic)
    estimate = estimate_memory(graph, walk)
    problems = walk.problems
    if estimate.placements > MAX_PLACEMENTS:
        problems.append(
            diagnostic(
                estimate.parts["instances"],
                f"the instances expand to {estimate.placements:,} placements ({estimate.expanded_shapes:,} shapes), "
                f"more than the {MAX_PLACEMENTS:,} allowed",
            )
        )
    problems += memory_problems(estimate, diagnostic)
    return problems, estimate


def memory_problems(estimate: MemoryEstimate, diagnostic: Callable[[tuple, str], Diagnostic]) -> list[Diagnostic]:
    limit = memory_limit()
    if estimate.total <= limit:
        return []
    parts = {"film": estimate.film, "textures": estimate.textures, "instances": estimate.instances, "shapes and trees": estimate.primitives,
             "lights": estimate.lights, "guide": estimate.guide, "media": estimate.media}
    worst = max(parts, key=parts.get)
    return [
        diagnostic(
            estimate.parts.get(worst, ()),
            f"rendering this scene needs about {gib(estimate.total)} ({estimate.describe()}), more than "
            f"{memory_limit_text()}",
        )
    ]


# ----------------------------------------------------------------------------------------------
# Colours


def texture_peak(node) -> tuple[float, tuple]:
    """The largest component a texture can take (noise: of its colour) and the node whose colour
    it is, with the key of that colour: ("color",) for a texture definition, () for a bare [r, g, b]."""
    m = node.model
    if m.type == "checker":
        peaks = [texture_peak(child) for child in node.inputs.values()]
        return max(peaks, key=lambda p: p[0]) if peaks else (0.0, node.path)
    if m.type in ("solid", "noise"):
        return max(m.color), node.path
    if node.image_peak is not None:  # a float image (.exr, .pfm), read by the graph
        return node.image_peak, node.path
    return 1.0, node.path  # an 8-bit image: at most 1 in either colour space


def check_memory(graph, document=None) -> MemoryEstimate:
    """The memory estimate of `graph` (as changed after loading: `rt render --width`); raises
    SceneError, placed in `document`, when this machine cannot hold it."""
    from .diagnostics import SceneError

    def diagnostic(path: tuple, message: str) -> Diagnostic:
        if document is not None:
            return document.diagnostic(path, message)
        return Diagnostic(graph.source or "<scene>", 0, 0, tuple(path), message)

    if graph.memory is not None:
        # Only the film changes after loading: the rest was estimated with the graph, and walking
        # a million shapes again took seconds.
        estimate = dataclasses.replace(graph.memory, parts=dict(graph.memory.parts))
        estimate.film = graph.image.width * graph.image.pixel_height * FILM_BYTES_PER_PIXEL
    else:
        estimate = estimate_memory(graph)
    problems = memory_problems(estimate, diagnostic)
    if problems:
        raise SceneError(problems)
    return estimate
