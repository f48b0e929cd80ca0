"""Shape models: sphere, moving sphere, quad, triangle, disk, box, mesh, and instances of groups.

Every shape takes a `material` and an optional `transform`; closed shapes (sphere,
moving sphere, box) may also hold a participating medium as their `interior`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Annotated, Any, Literal, Optional, Union

from pydantic import BeforeValidator, ConfigDict, Discriminator, Field, Tag, WithJsonSchema, field_validator, model_validator

from .base import MAX_MAGNITUDE, MIN_MAGNITUDE, Name, Number, StrictModel, Vec3, field_error, slot_kind, vec_cross, vec_length, vec_sub
from .materials import MaterialSlot
from .media import MediumSlot
from .transforms import Motion, Transform

# Relative threshold below which two edge vectors count as parallel (a zero-area face).
_DEGENERATE = 1e-12

NEGATIVE_RADIUS_HINT = (
    "a sphere's radius must be > 0; the old book's negative-radius 'hollow glass' trick is not "
    "supported: model the air bubble as a second, smaller sphere of dielectric with ior 1/1.5"
)


def _reject_negative_radius(value: Any) -> Any:
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value < 0:
        raise ValueError(NEGATIVE_RADIUS_HINT)
    return value


class ShapeBase(StrictModel):
    """Fields every shape has."""

    transform: Transform = Field(
        default_factory=list, description="Transform steps applied to the shape, first to last."
    )
    motion: Optional[Motion] = Field(
        None,
        description="Keyframes `{time, transform}` (at least 2, times increasing) that move the shape over the "
        "shutter: at each time its `transform` is followed by the keyframe's; in between, translation and scale "
        "are interpolated linearly and rotation by quaternion slerp (pbrt-v4's rule), held before the first and "
        "after the last. Keyframes that all place it alike are a still transform.",
    )


class SurfaceBase(ShapeBase):
    """A shape that is only a surface (it encloses nothing), so it must have a material."""

    material: MaterialSlot = Field(..., description="Surface material: a name from `materials:` or an inline material.")


class ClosedShapeBase(ShapeBase):
    """A shape that encloses a volume, so it can hold a medium as well as (or instead of) a surface."""

    # The rule of `_material_or_interior`, for the JSON Schema: a non-null material or interior.
    model_config = ConfigDict(
        json_schema_extra={
            "anyOf": [
                {"required": ["material"], "properties": {"material": {"not": {"type": "null"}}}},
                {"required": ["interior"], "properties": {"interior": {"not": {"type": "null"}}}},
            ]
        }
    )

    material: Optional[MaterialSlot] = Field(
        None, description="Surface material: a name from `materials:` or an inline material."
    )
    interior: Optional[MediumSlot] = Field(
        None,
        description="A medium filling the inside: a name from `media:` or an inline medium. "
        "Without a `material` the surface itself is invisible.",
    )

    @model_validator(mode="after")
    def _material_or_interior(self) -> "ClosedShapeBase":
        if self.material is None and self.interior is None:
            raise field_error("material", "a shape needs a `material`, an `interior` medium, or both")
        return self


class Sphere(ClosedShapeBase):
    """A sphere. The radius must be positive: the first book's negative-radius trick for a hollow
    glass ball is not supported; model the air bubble as a smaller sphere of dielectric with
    ior 1/1.5 inside the glass one (as `scenes/weekend_glass.yaml` does).

    ```yaml
    type: sphere
    center: [0, 1, 0]
    radius: 1
    material: glass
    ```
    """

    type: Literal["sphere"] = Field("sphere", description="Selects a sphere.")
    center: Vec3 = Field(..., description="Centre point.")
    radius: Number = Field(..., gt=0, description="Radius, > 0.")

    _check_radius = field_validator("radius", mode="before")(classmethod(lambda cls, v: _reject_negative_radius(v)))


# --- Plain spheres in bulk ------------------------------------------------------------------
# A generated scene may hold a million spheres written `{type: sphere, center: [x, y, z], radius:
# r, material: name}`. Validating each through pydantic calls eight Python validators a sphere
# (9 us); `plain_spheres` checks the same rules for all of them at once in numpy and builds each
# model as `model_validate` would have. A mapping it cannot vouch for is left to pydantic, which
# reports it with its position as for any shape.
_PLAIN_SPHERE_KEYS = frozenset({"type", "center", "radius", "material"})
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
PLAIN_SPHERES_AT_ONCE = 1000  # fewer are validated one by one: numpy's set-up would cost more


def _plain_sphere_items(items: list) -> list[int]:
    """Indices of the mappings of `items` shaped as a plain sphere (keys and value types)."""
    keys, number = _PLAIN_SPHERE_KEYS, (int, float)
    return [
        i for i, d in enumerate(items)
        if type(d) is dict and d.keys() == keys and d["type"] == "sphere" and type(d["material"]) is str
        and type(d["center"]) is list and len(d["center"]) == 3 and type(d["radius"]) in number
        and type(d["center"][0]) in number and type(d["center"][1]) in number and type(d["center"][2]) in number
    ]


def is_plain_sphere(model) -> bool:
    """Whether a validated shape is a plain sphere: a `sphere` with a named material and no
    transform (none, or an empty list) or interior of its own. The one rule: the graph joins runs
    of these (SphereColumns.of_models), and every sphere `plain_spheres` builds in bulk is one."""
    return (type(model) is Sphere and not model.transform and model.interior is None and type(model.material) is str
            and model.motion is None)


def sphere_values(models) -> "np.ndarray":
    """(n, 4) float64: centre x, y, z and radius of each sphere model, in their order."""
    import numpy as np

    centers = np.array([s.center for s in models], np.float64).reshape(-1, 3)
    return np.column_stack([centers, np.fromiter((s.radius for s in models), np.float64, len(centers))])


@dataclass
class SphereColumns:
    """The plain spheres of a shape list as columns: the graph makes its runs of spheres from them
    without reading a million models back. `plain_spheres` makes them for the spheres it validates
    in bulk; `of_models` for a list of validated shapes."""

    index: "np.ndarray"  # (n,) int64: their places in the list, ascending
    values: "np.ndarray"  # (n, 4) float64: centre x, y, z and radius
    material_code: "np.ndarray"  # (n,) int32: each one's material, an entry of `names`
    names: list[str]

    @classmethod
    def of_models(cls, models: list, bulk: Optional["SphereColumns"] = None) -> "SphereColumns":
        """The plain spheres (`is_plain_sphere`) of the validated shapes `models`, their material
        names coded in the order first used. `bulk`, the columns `plain_spheres` made of some of
        them, is taken as it is: only the other shapes are read (a sphere written with
        `transform: []`, say, which the bulk check leaves to pydantic)."""
        import numpy as np

        if bulk is None:
            at = [i for i, s in enumerate(models) if is_plain_sphere(s)]
            codes: dict[str, int] = {}
        else:
            taken = np.zeros(len(models), bool)
            taken[bulk.index] = True
            at = [i for i in np.flatnonzero(~taken).tolist() if is_plain_sphere(models[i])]
            if not at:
                return bulk
            codes = {name: k for k, name in enumerate(bulk.names)}
        spheres = [models[i] for i in at] if len(at) < len(models) else models
        code = np.fromiter((codes.setdefault(s.material, len(codes)) for s in spheres), np.int32, len(at))
        index, values = np.asarray(at, np.int64), sphere_values(spheres)
        if bulk is not None:  # the two sets of places, merged in order
            index = np.concatenate([bulk.index, index])
            order = np.argsort(index, kind="stable")
            index = index[order]
            values = np.concatenate([bulk.values, values])[order]
            code = np.concatenate([bulk.material_code, code])[order]
        return cls(index, values, code, list(codes))


def plain_spheres(items: Any) -> tuple[Any, Optional[SphereColumns]]:
    """`items` (a `shapes:` list as parsed) with every plain sphere whose values pass the checks
    of `Sphere` replaced by its model, and those spheres as columns; the same list and None if
    there are few."""
    import numpy as np

    if type(items) is not list or len(items) < PLAIN_SPHERES_AT_ONCE:
        return items, None
    at = _plain_sphere_items(items)
    if len(at) < PLAIN_SPHERES_AT_ONCE:
        return items, None
    def numbers(at):
        for i in at:
            x, y, z = items[i]["center"]
            yield x
            yield y
            yield z
            yield items[i]["radius"]

    try:
        values = np.fromiter(numbers(at), np.float64, 4 * len(at)).reshape(-1, 4)
    except OverflowError:  # an integer beyond a float: left to pydantic, which says so at its place
        at = [i for i in at if all(-1e300 < v < 1e300 for v in items[i]["center"] + [items[i]["radius"]])]
        values = np.fromiter(numbers(at), np.float64, 4 * len(at)).reshape(-1, 4)
    # Number: finite, 0 or of magnitude MIN_MAGNITUDE to MAX_MAGNITUDE; the radius above 0.
    size = np.abs(values)
    good = ((values == 0) | ((size >= MIN_MAGNITUDE) & (size <= MAX_MAGNITUDE))).all(axis=1) & (values[:, 3] > 0)
    # Each material name's code, or -1 for a name that is not a valid one.
    codes: dict[str, int] = {}
    names: list[str] = []  # the valid ones, each at its code
    for name in dict.fromkeys(items[i]["material"] for i in at):  # in the order first used
        valid = _NAME.fullmatch(name) is not None and len(name) <= 64
        codes[name] = len(names) if valid else -1
        if valid:
            names.append(name)
    code = np.fromiter((codes[items[i]["material"]] for i in at), np.int32, len(at))
    good &= code >= 0
    out = list(items)
    fields = tuple(Sphere.model_fields)
    assert fields == ("transform", "motion", "material", "interior", "type", "center", "radius"), fields
    new, setattr_ = Sphere.__new__, object.__setattr__
    kept = np.flatnonzero(good)
    index = np.asarray(at, np.int64)[kept]
    # One set of the keys given for all: the models are frozen, so nothing adds to it (a copy
    # made with model_copy gets a set of its own).
    given = {"type", "center", "radius", "material"}
    for i, (x, y, z, r) in zip(index.tolist(), values[kept].tolist()):
        # What model_validate makes of it (pydantic's own model_construct, at 1/150 of its cost).
        model = new(Sphere)
        setattr_(model, "__dict__", {"transform": [], "motion": None, "material": items[i]["material"], "interior": None, "type": "sphere",
                                     "center": (x, y, z), "radius": r})
        setattr_(model, "__pydantic_fields_set__", given)
        setattr_(model, "__pydantic_extra__", None)
        setattr_(model, "__pydantic_private__", None)
        out[i] = model
    return out, SphereColumns(index, values[kept], code[kept], names)


class MovingSphere(ClosedShapeBase):
    """A sphere whose centre moves in a straight line from `center0` when the shutter opens to
    `center1` when it closes (motion blur).

    ```yaml
    type: moving_sphere
    center0: [400, 400, 200]
    center1: [430, 400, 200]
    radius: 50
    material: orange
    ```
    """

    type: Literal["moving_sphere"] = Field("moving_sphere", description="Selects a moving sphere.")
    center0: Vec3 = Field(..., description="Centre when the shutter opens.")
    center1: Vec3 = Field(..., description="Centre when the shutter closes.")
    radius: Number = Field(..., gt=0, description="Radius, > 0.")

    _check_radius = field_validator("radius", mode="before")(classmethod(lambda cls, v: _reject_negative_radius(v)))


class Quad(SurfaceBase):
    """A parallelogram with corner `q` and edges `u` and `v`; its front face is on the side of u x v.

    ```yaml
    type: quad
    q: [343, 554, 332]
    u: [-130, 0, 0]
    v: [0, 0, -105]
    material: light
    ```
    """

    type: Literal["quad"] = Field("quad", description="Selects a parallelogram.")
    q: Vec3 = Field(..., description="One corner.")
    u: Vec3 = Field(..., description="First edge from `q`.")
    v: Vec3 = Field(..., description="Second edge from `q`.")

    @model_validator(mode="after")
    def _nonzero_area(self) -> "Quad":
        if vec_length(vec_cross(self.u, self.v)) <= _DEGENERATE * vec_length(self.u) * vec_length(self.v) or (
            vec_length(self.u) == 0 or vec_length(self.v) == 0
        ):
            raise field_error("v", "the quad has zero area: `u` and `v` must be non-zero and not parallel")
        return self


class Triangle(SurfaceBase):
    """A triangle through three vertices; its front face is on the side of (p1 - p0) x (p2 - p0).

    ```yaml
    type: triangle
    vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    material: white
    ```
    """

    type: Literal["triangle"] = Field("triangle", description="Selects a triangle.")
    vertices: tuple[Vec3, Vec3, Vec3] = Field(..., description="The three corners, [p0, p1, p2].")

    @field_validator("vertices", mode="before")
    @classmethod
    def _three_vertices(cls, value: Any) -> Any:
        if isinstance(value, (list, tuple)) and len(value) != 3:
            raise ValueError(f"expected 3 vertices, found {len(value)}")
        return value

    @model_validator(mode="after")
    def _nonzero_area(self) -> "Triangle":
        p0, p1, p2 = self.vertices
        e1, e2 = vec_sub(p1, p0), vec_sub(p2, p0)
        if vec_length(vec_cross(e1, e2)) <= _DEGENERATE * vec_length(e1) * vec_length(e2) or (
            vec_length(e1) == 0 or vec_length(e2) == 0
        ):
            raise field_error("vertices", "the triangle has zero area: its vertices are collinear or repeated")
        return self


class Disk(SurfaceBase):
    """A flat disk; its front face is on the side its `normal` points to.

    ```yaml
    type: disk
    center: [0, 0, 0]
    normal: [0, 1, 0]
    radius: 2
    material: white
    ```
    """

    type: Literal["disk"] = Field("disk", description="Selects a disk.")
    center: Vec3 = Field(..., description="Centre point.")
    normal: Vec3 = Field(
        (0.0, 1.0, 0.0),
        description="Direction the front face looks to; need not be unit length.",
        json_schema_extra={"not": {"const": [0, 0, 0]}},
    )
    radius: Number = Field(..., gt=0, description="Radius, > 0.")

    @field_validator("normal")
    @classmethod
    def _normal_nonzero(cls, normal: Any) -> Any:
        if vec_length(normal) == 0:
            raise ValueError("a disk's normal must not be the zero vector")
        return normal


class Box(ClosedShapeBase):
    """An axis-aligned box between two opposite corners, made of six outward-facing quads.

    ```yaml
    type: box
    min: [0, 0, 0]
    max: [165, 330, 165]
    material: white
    transform: [{rotate: {axis: y, degrees: 15}}, {translate: [265, 0, 295]}]
    ```
    """

    type: Literal["box"] = Field("box", description="Selects an axis-aligned box.")
    min: Vec3 = Field(..., description="Corner with the smallest coordinates.")
    max: Vec3 = Field(..., description="Corner with the largest coordinates; larger than `min` on every axis.")

    @model_validator(mode="after")
    def _positive_size(self) -> "Box":
        for axis, lo, hi in zip("xyz", self.min, self.max):
            if not hi > lo:
                raise field_error("max", f"the box has no positive size along {axis}: max.{axis} ({hi:g}) must exceed min.{axis} ({lo:g})")
        return self


# Inline meshes: a Python builder may hand numpy arrays; a file gives lists. Both are kept as
# read-only numpy arrays, so a generated mesh of a million triangles is not a million tuples.
MAX_INLINE_VERTICES = 50_000_000


def _vertex_array(value: Any) -> Any:
    import numpy as np

    if value is None:
        return None
    if isinstance(value, (list, tuple)):
        for k, item in enumerate(value):
            if not isinstance(item, (list, tuple)) or len(item) != 3 or any(
                isinstance(x, bool) or not isinstance(x, (int, float)) for x in item
            ):
                raise ValueError(f"vertex {k}: expected a list of 3 numbers [x, y, z], found {item!r}")
    try:
        array = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError("expected a list of vertices [x, y, z]") from None
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"expected a list of vertices [x, y, z], found an array of shape {array.shape}")
    if len(array) > MAX_INLINE_VERTICES:
        raise ValueError(f"more than {MAX_INLINE_VERTICES:,} vertices")
    bad = ~np.isfinite(array).all(axis=1)
    if bad.any():
        raise ValueError(f"vertex {int(np.argmax(bad))} has a NaN or infinite coordinate")
    big = np.abs(array) > 1e50
    if big.any():
        raise ValueError(f"vertex {int(np.argmax(big.any(axis=1)))} has a coordinate beyond 1e+50")
    array.setflags(write=False)
    return array


def _face_array(value: Any) -> Any:
    import numpy as np

    if value is None:
        return None
    if isinstance(value, (list, tuple)):
        for k, face in enumerate(value):
            if not isinstance(face, (list, tuple)) or len(face) < 3 or any(
                isinstance(i, bool) or not isinstance(i, int) for i in face
            ):
                raise ValueError(f"face {k}: expected a list of at least 3 vertex indices, found {face!r}")
        if len({len(face) for face in value}) > 1:
            return tuple(tuple(face) for face in value)  # polygons of several sizes
    array = np.asarray(value)
    if array.dtype.kind not in "iu" or array.ndim != 2 or array.shape[1] < 3:
        raise ValueError(f"expected a list of faces of at least 3 vertex indices, found an array of {array.dtype} {array.shape}")
    array = array.astype(np.int64)
    array.setflags(write=False)
    return array


_VERTICES_SCHEMA = {"type": "array", "items": {"type": "array", "items": {"type": "number"}, "minItems": 3, "maxItems": 3}}
_FACES_SCHEMA = {"type": "array", "items": {"type": "array", "items": {"type": "integer", "minimum": 0}, "minItems": 3}}
Vertices = Annotated[Any, BeforeValidator(_vertex_array), WithJsonSchema(_VERTICES_SCHEMA)]
"""A list of points [x, y, z] (a numpy array of shape (V, 3) from Python)."""
Faces = Annotated[Any, BeforeValidator(_face_array), WithJsonSchema(_FACES_SCHEMA)]
"""A list of polygons, each a list of at least 3 vertex indices from 0 (a numpy (T, 3) array from Python)."""


class Mesh(SurfaceBase):
    """A triangle mesh, from an OBJ or PLY file or given inline. Faces with more than three
    corners are cut into triangles; triangles of zero area are dropped (with a warning). With
    `smooth`, normals are interpolated across each triangle from the file's vertex normals (or,
    where it has none, from the average of the faces around each vertex). Texture coordinates
    from the file drive image textures. Each face's front is on the side its corners turn
    counter-clockwise around. An OBJ file's own materials (its `.mtl` library, `usemtl` per
    face) are used when `material` is left out, each entry as the nearest of ours
    (docs/meshes.md, "Materials from a .mtl file").

    ```yaml
    type: mesh
    file: bunny.ply
    smooth: true
    material: white
    transform: [{scale: 10}, {translate: [0, 1, 0]}]
    ```
    """

    type: Literal["mesh"] = Field("mesh", description="Selects a triangle mesh.")
    file: Optional[str] = Field(
        None,
        min_length=1,
        max_length=4096,
        description="OBJ or PLY file (by its suffix, `.obj` or `.ply`), relative to the folder of the file that names "
        "it (an included file's own folder). Give either `file` or `vertices` and `faces`.",
    )
    vertices: Vertices = Field(None, description="Inline mesh: the vertex positions, a list of [x, y, z].")
    faces: Faces = Field(
        None, description="Inline mesh: the faces, each a list of at least 3 indices into `vertices`, counted from 0."
    )
    smooth: bool = Field(False, strict=True, description="Interpolate vertex normals across each triangle (shading only).")
    material: Optional[MaterialSlot] = Field(
        None,
        description="Surface material: a name from `materials:` or an inline material. Required, except for an OBJ "
        "file with a material library (`mtllib`): left out, each face gets the nearest material to its `usemtl` entry "
        "(docs/meshes.md); given, it replaces the library's materials for every face.",
    )

    @model_validator(mode="after")
    def _one_source(self) -> "Mesh":
        if self.material is None and (self.file is None or not self.file.lower().endswith(".obj")):
            # Only an OBJ can carry its own materials; the message is the one any surface gets.
            raise field_error("material", "missing required key 'material' (only a mesh from an .obj file with a "
                              "material library may leave it out)")
        inline = self.vertices is not None or self.faces is not None
        if self.file is not None and inline:
            raise field_error("file", "give either `file` or `vertices` and `faces`, not both")
        if self.file is None and not inline:
            raise field_error("file", "a mesh needs a `file` or `vertices` and `faces`")
        if self.file is None:
            if self.vertices is None:
                raise field_error("vertices", "an inline mesh needs `vertices` as well as `faces`")
            if self.faces is None:
                raise field_error("faces", "an inline mesh needs `faces` as well as `vertices`")
            n = len(self.vertices)
            if len(self.faces) == 0:
                raise field_error("faces", "the mesh has no faces")
            for k, face in enumerate(self.faces if isinstance(self.faces, tuple) else ()):
                for i in face:
                    if not 0 <= i < n:
                        raise field_error("faces", f"face {k} refers to vertex {i}, but there are {n} (indices count from 0)")
            if not isinstance(self.faces, tuple):
                bad = (self.faces < 0) | (self.faces >= n)
                if bad.any():
                    k = int(bad.any(axis=1).argmax())
                    i = int(self.faces[k][bad[k]][0])
                    raise field_error("faces", f"face {k} refers to vertex {i}, but there are {n} (indices count from 0)")
        return self


class Group(StrictModel):
    """A set of shapes defined once and placed any number of times by `instance` shapes.

    ```yaml
    type: group
    shapes:
      - {type: sphere, center: [0, 0, 0], radius: 10, material: white}
    ```
    """

    type: Literal["group"] = Field("group", description="Marks a group; may be left out.")
    shapes: list[Shape] = Field(..., min_length=1, description="The shapes of the group, in the group's own coordinates.")


class Instance(StrictModel):
    """One placement of a group, with its own transform.

    ```yaml
    type: instance
    group: cluster
    transform: [{rotate: {axis: y, degrees: 15}}, {translate: [-100, 270, 395]}]
    ```
    """

    type: Literal["instance"] = Field("instance", description="Selects an instance of a group.")
    group: GroupSlot = Field(..., description="A name from `groups:`, or an inline group.")
    transform: Transform = Field(default_factory=list, description="Transform steps that place the group, first to last.")
    motion: Optional[Motion] = Field(
        None,
        description="Keyframes `{time, transform}` (at least 2, times increasing) that move the group over the "
        "shutter: at each time the instance's `transform` is followed by the keyframe's; in between, translation and scale "
        "are interpolated linearly and rotation by quaternion slerp (pbrt-v4's rule), held before the first and "
        "after the last. Keyframes that all place it alike are a still transform.",
    )


Shape = Annotated[
    Union[Sphere, MovingSphere, Quad, Triangle, Disk, Box, Mesh, Instance],
    Field(discriminator="type"),
]
"""Any shape, chosen by its `type`."""

GroupSlot = Annotated[
    Union[Annotated[Name, Tag("name")], Annotated[Group, Tag("inline")]],
    Discriminator(
        slot_kind,
        custom_error_type="group_slot",
        custom_error_message="expected a group name or a group definition",
    ),
]
"""The name of a group under `groups:`, or an inline group."""

SHAPE_CLASSES = (Sphere, MovingSphere, Quad, Triangle, Disk, Box, Mesh, Instance)

Group.model_rebuild()
Instance.model_rebuild()
