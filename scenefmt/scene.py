"""The top-level scene model: camera, image, shutter, background, named definitions and shapes."""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal, Optional, Union

from pydantic import AfterValidator, BeforeValidator, ConfigDict, Discriminator, Field, Tag, WithJsonSchema, field_validator, model_validator

from .base import (
    field_error,
    moderate,
    MAX_DEPTH,
    MAX_IMAGE_SIDE,
    MAX_MAGNITUDE,
    MIN_MAGNITUDE,
    MAX_SAMPLES,
    Color,
    Name,
    Number,
    StrictModel,
    Vec3,
    vec_cross,
    vec_length,
    vec_sub,
)
from .lights import Light
from .materials import Material
from .media import Medium
from .shapes import Group, Shape
from .sky import SunSkyBackground
from .textures import Texture
from .transforms import MAX_KEYFRAMES

FORMAT_VERSION = 1
MAX_SHAPES = 5_000_000
MAX_INCLUDES = 256
MAX_LIGHTS = 100_000
# The integrators that sample lights at each vertex with a density (`mis`, and `guided`, which is mis
# with learned bounces): what `rt validate` reports and the kernels compile for light sampling.
LIGHT_SAMPLING_INTEGRATORS = frozenset({"mis", "guided", "caustics"})

IncludeName = Annotated[str, Field(min_length=1, max_length=4096)]
_INCLUDE_SCHEMA = {
    "anyOf": [
        {"type": "string", "minLength": 1, "maxLength": 4096},
        {"type": "array", "items": {"type": "string", "minLength": 1, "maxLength": 4096}, "maxItems": MAX_INCLUDES},
    ]
}


def _one_or_more_files(value: Any) -> Any:
    """`include: lib.yaml` is the one-element list `[lib.yaml]`."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, list):
        return value
    kind = {True: "true", False: "false", None: "null"}.get(value) if value is None or isinstance(value, bool) else (
        "a number" if isinstance(value, (int, float)) else "a mapping" if isinstance(value, dict) else type(value).__name__)
    raise ValueError(f"expected a file name or a list of file names, found {kind}")


class CameraKeyframe(StrictModel):
    """Where the camera is and looks at one time; what a keyframe leaves out is the camera's own.

    ```yaml
    time: 1
    look_at: [1, 0, 0]
    ```
    """

    time: Number = Field(..., description="The time of this keyframe, on the shutter's clock.")
    look_from: Optional[Vec3] = Field(None, description="Position of the camera at this time; by default the camera's `look_from`.")
    look_at: Optional[Vec3] = Field(None, description="Point it looks at at this time; by default the camera's `look_at`.")
    up: Optional[Vec3] = Field(None, description="Which way is up at this time; by default the camera's `up`.")


class Camera(StrictModel):
    """A pinhole or thin-lens camera at `look_from` looking at `look_at`.

    ```yaml
    look_from: [13, 2, 3]
    look_at: [0, 0, 0]
    vfov: 20
    defocus_angle: 0.6
    focus_distance: 10
    ```
    """

    # For the JSON Schema: not both a positive aperture and a positive defocus_angle (`_well_posed`).
    model_config = ConfigDict(
        json_schema_extra={
            "not": {
                "required": ["aperture", "defocus_angle"],
                "properties": {
                    "aperture": {"type": "number", "exclusiveMinimum": 0},
                    "defocus_angle": {"type": "number", "exclusiveMinimum": 0},
                },
            }
        }
    )

    look_from: Vec3 = Field((0.0, 0.0, 0.0), description="Position of the camera.")
    look_at: Vec3 = Field((0.0, 0.0, -1.0), description="Point the camera looks at.")
    up: Vec3 = Field(
        (0.0, 1.0, 0.0),
        description="Which way is up; must not be parallel to the view direction.",
        json_schema_extra={"not": {"const": [0, 0, 0]}},
    )
    vfov: Number = Field(90.0, gt=0, lt=180, description="Vertical field of view, in degrees.")
    defocus_angle: Number = Field(
        0.0, ge=0, lt=180, description="Cone angle of rays through a pixel, in degrees; 0 is a pinhole (no defocus blur)."
    )
    aperture: Optional[Annotated[float, Field(strict=True, allow_inf_nan=False, ge=0), AfterValidator(moderate)]] = Field(
        None,
        description="Lens diameter, as in the first book; an alternative to `defocus_angle` (give one, not both).",
    )
    focus_distance: Optional[Annotated[float, Field(strict=True, allow_inf_nan=False, gt=0), AfterValidator(moderate)]] = Field(
        None,
        description="Distance from `look_from` to the plane in perfect focus; by default the distance to `look_at`.",
    )

    motion: Optional[Annotated[list[CameraKeyframe], Field(min_length=2, max_length=MAX_KEYFRAMES)]] = Field(
        None,
        description="Keyframes `{time, look_from, look_at, up}` (at least 2, times increasing; a field left out is the "
        "camera's own) that move the camera over the shutter: its position is interpolated linearly and its "
        "orientation by quaternion slerp between them, held before the first and after the last. The field of view "
        "and the lens stay as they are.",
    )

    @model_validator(mode="after")
    def _well_posed(self) -> "Camera":
        view = vec_sub(self.look_at, self.look_from)
        if vec_length(view) == 0.0:
            raise field_error("look_at", "look_from and look_at are the same point, so there is no view direction")
        if vec_length(self.up) == 0.0:
            raise field_error("up", "up must not be the zero vector")
        if vec_length(vec_cross(view, self.up)) <= 1e-12 * vec_length(view) * vec_length(self.up):
            raise field_error("up", "up is parallel to the view direction (look_at - look_from); choose another up")
        for k, key in enumerate(self.motion or ()):
            if k and not key.time > self.motion[k - 1].time:
                raise field_error("motion", f"keyframe times must increase: keyframe {k} is at {key.time:g}, "
                                  f"keyframe {k - 1} at {self.motion[k - 1].time:g}")
            look_from, look_at, up = self.frame_at_key(key)
            view = vec_sub(look_at, look_from)
            if vec_length(view) == 0.0:
                raise field_error("motion", f"keyframe {k}: look_from and look_at are the same point")
            if vec_length(up) == 0.0 or vec_length(vec_cross(view, up)) <= 1e-12 * vec_length(view) * vec_length(up):
                raise field_error("motion", f"keyframe {k}: up is zero or parallel to the view direction")
        if self.aperture is not None and self.aperture > 0 and self.defocus_angle > 0:
            raise field_error("aperture", "give either defocus_angle or aperture, not both")
        return self

    def frame_at_key(self, key: "CameraKeyframe") -> tuple:
        """(look_from, look_at, up) of a keyframe, the camera's own where it gives none."""
        return (self.look_from if key.look_from is None else key.look_from,
                self.look_at if key.look_at is None else key.look_at,
                self.up if key.up is None else key.up)

    @property
    def moves(self) -> bool:
        """Whether its keyframes place it in more than one way (keyframes all alike stand still)."""
        return bool(self.motion) and len({self.frame_at_key(key) for key in self.motion}) > 1

    @property
    def focus(self) -> float:
        """The focus distance in effect."""
        if self.focus_distance is not None:
            return self.focus_distance
        return vec_length(vec_sub(self.look_at, self.look_from))

    @property
    def lens_radius(self) -> float:
        """Radius of the lens disk that ray origins are drawn from; 0 for a pinhole."""
        if self.aperture is not None and self.aperture > 0:
            return self.aperture / 2.0
        return self.focus * math.tan(math.radians(self.defocus_angle) / 2.0)


# The display transforms a PNG can be made with (renderer/display.py implements them, under the
# same names: tests/test_display.py keeps the two lists equal).
DisplayName = Literal["gamma2", "srgb", "agx", "aces"]

_RATIO = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*[:/]\s*(\d+(?:\.\d+)?)\s*$")


class Image(StrictModel):
    """Output size and sampling.

    ```yaml
    width: 400
    aspect_ratio: "16:9"
    samples_per_pixel: 100
    max_depth: 50
    seed: 7
    ```
    """

    # For the JSON Schema: not both a height and an aspect_ratio (`_one_of_height_or_ratio`).
    model_config = ConfigDict(
        json_schema_extra={
            "not": {
                "required": ["height", "aspect_ratio"],
                "properties": {"height": {"not": {"type": "null"}}, "aspect_ratio": {"not": {"type": "null"}}},
            }
        }
    )

    width: int = Field(100, strict=True, ge=1, le=MAX_IMAGE_SIDE, description="Width in pixels.")
    height: Optional[int] = Field(
        None, strict=True, ge=1, le=MAX_IMAGE_SIDE, description="Height in pixels; by default width / aspect_ratio."
    )
    aspect_ratio: Optional[Union[Number, Annotated[str, Field(pattern=_RATIO.pattern)]]] = Field(
        None,
        description='Width over height (> 0), as a number or a string "W:H" or "W/H" such as "16:9" (default 1); give either this or height.',
    )
    samples_per_pixel: int = Field(10, strict=True, ge=1, le=MAX_SAMPLES, description="Paths traced per pixel.")
    max_depth: int = Field(10, strict=True, ge=1, le=MAX_DEPTH, description="Most bounces a path may take.")
    seed: int = Field(0, strict=True, ge=0, le=2**63 - 1, description="Seed of the random numbers; the same seed gives the same image.")
    integrator: Literal["mis", "path", "guided", "caustics"] = Field(
        "mis",
        description="How light is found: mis samples points on the lights at every diffuse or medium vertex and "
        "weighs them against the path's own hits (multiple importance sampling, with Russian roulette past a few "
        "bounces); path is the books' estimator, which finds a light only by chance; caustics is mis with the "
        "light that reaches a matte surface the camera sees through glass or mirror spheres (a caustic, a lamp "
        "inside a glass ball) traced from the lights instead, which mis finds only by chance (one process, not a "
        "cluster); guided is mis whose bounces also follow where light was learned to come from by a short "
        "training render (a trial that did not beat mis on our scenes; docs/integrators.md).",
    )
    sampler: Literal["independent", "sobol"] = Field(
        "independent",
        description="Where the samples fall: independent draws a fresh random number for every sample and "
        "dimension (the books'); sobol uses Owen-scrambled Sobol points, spread more evenly, in independently "
        "scrambled batches so that the reported error stays honest.",
    )

    display: DisplayName = Field(
        "gamma2",
        description="How the PNG shows the image's linear radiance (the --hdr image is never changed): gamma2, the "
        "books' square root, clamped and truncated (the default); srgb, the sRGB standard's curve, clamped; agx, a "
        "filmic curve after Sobotka's AgX (Wrensch's fit) whose highlights roll off and bright colours pass to white; "
        "aces, the ACES RRT and sRGB output transform in Hill's fit (darker mid tones). `rt render --display` "
        "overrides it; the PNG's metadata names it (key rt:display).",
    )

    @field_validator("aspect_ratio", mode="before")
    @classmethod
    def _positive_ratio(cls, value: Any) -> Any:
        if value is None:
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float, str)) or (
            isinstance(value, str) and not _RATIO.match(value)
        ):
            raise ValueError(f'expected a number or "W:H" such as "16:9", found {value!r}')
        ratio = _parse_ratio(value)
        if not ratio > 0:
            raise ValueError(f"the aspect ratio must be > 0, found {value!r}")
        if not MIN_MAGNITUDE <= ratio <= MAX_MAGNITUDE:
            raise ValueError(f"the aspect ratio must be between {MIN_MAGNITUDE:g} and {MAX_MAGNITUDE:g}, found {value!r} = {ratio:g}")
        return value

    @model_validator(mode="after")
    def _one_of_height_or_ratio(self) -> "Image":
        if self.height is not None and self.aspect_ratio is not None:
            raise field_error("aspect_ratio", "give either height or aspect_ratio, not both")
        if self.height is None and self.width / self.ratio >= MAX_IMAGE_SIDE + 1:
            raise field_error(
                "aspect_ratio",
                f"the image height width / aspect_ratio = {self.width / self.ratio:.6g} pixels is more than the "
                f"{MAX_IMAGE_SIDE} allowed",
            )
        return self

    @property
    def ratio(self) -> float:
        return 1.0 if self.aspect_ratio is None else _parse_ratio(self.aspect_ratio)

    @property
    def pixel_height(self) -> int:
        """The height in effect: as given, or int(width / aspect_ratio), at least 1."""
        if self.height is not None:
            return self.height
        height = self.width / self.ratio  # finite: the ratio is at least 1e-50
        return max(1, min(MAX_IMAGE_SIDE, int(height))) if height == height else 1


def _parse_ratio(value: Union[float, str]) -> float:
    if isinstance(value, str):
        m = _RATIO.match(value)
        w, h = float(m.group(1)), float(m.group(2))  # digits only: never negative, perhaps inf or 0
        ratio = w / h if h > 0 else 0.0
        return ratio if ratio == ratio else 0.0  # inf / inf
    return float(value)


class Shutter(StrictModel):
    """When the shutter opens and closes; each ray gets a time drawn uniformly in [open, close).

    ```yaml
    open: 0
    close: 1
    ```
    """

    open: Number = Field(0.0, description="Time the shutter opens.")
    close: Number = Field(1.0, description="Time the shutter closes; open == close freezes all motion.")

    @model_validator(mode="after")
    def _ordered(self) -> "Shutter":
        if self.open > self.close:
            raise field_error("close", f"the shutter closes ({self.close:g}) before it opens ({self.open:g})")
        return self


class SolidBackground(StrictModel):
    """One colour for every ray that leaves the scene (a bare `[r, g, b]` means the same).

    ```yaml
    type: solid
    color: [0.7, 0.8, 1.0]
    ```
    """

    type: Literal["solid"] = Field("solid", description="Selects a solid background.")
    color: Color = Field((0.0, 0.0, 0.0), description="Radiance of the background.")


class SkyBackground(StrictModel):
    """The first book's sky: a blend from `bottom` (straight down) to `top` (straight up) by the ray's height.

    ```yaml
    type: sky
    bottom: [1, 1, 1]
    top: [0.5, 0.7, 1.0]
    ```
    """

    type: Literal["sky"] = Field("sky", description="Selects the vertical gradient sky.")
    bottom: Color = Field((1.0, 1.0, 1.0), description="Radiance looking straight down.")
    top: Color = Field((0.5, 0.7, 1.0), description="Radiance looking straight up.")


class ImageBackground(StrictModel):
    """An environment map: an equirectangular (latitude-longitude) image of the radiance arriving
    from every direction, as if from infinitely far away.

    The image's top row is straight up (+y), its bottom row straight down; across the width u
    runs once around: u = 0 (the left edge) is +z, u = 1/4 is -x, the centre (u = 1/2) is -z
    (where the default camera looks), u = 3/4 is +x. That is, the direction of texel (u, v)
    (v = 0 at the top) is (-sin theta sin phi, cos theta, sin theta cos phi) with theta = pi v and
    phi = 2 pi u, so looking at the centre, the image reads left to right as it does on a screen.
    With `integrator: mis`, the map is importance-sampled by brightness like a light (a shadow ray
    toward a direction drawn by luminance, weighed against the path's own escape by multiple
    importance sampling); with `integrator: path` a path finds it only by escaping. Solid and sky
    backgrounds are never sampled as lights: they are smooth and fill every direction, so the
    cosine-weighted ray a diffuse surface sends already follows their contribution closely
    (exactly, for a solid colour), and a shadow ray would add cost, not accuracy.

    ```yaml
    type: image
    file: sky.pfm
    rotate: 90
    strength: 1.5
    ```
    """

    type: Literal["image"] = Field("image", description="Selects an environment map.")
    file: str = Field(
        ...,
        min_length=1,
        max_length=4096,
        description="Equirectangular image, relative to the folder of the file that names it: OpenEXR `.exr` or PFM "
        "`.pfm` (float RGB, linear radiance as stored), or an 8-bit image such as PNG (read as sRGB and linearised).",
    )
    rotate: Number = Field(
        0.0,
        ge=-360,
        le=360,
        description="Turns the map about +y by this many degrees (right-handed: 90 moves what was at -z to -x).",
    )
    strength: Number = Field(1.0, ge=0, description="Scales the map's radiance.")


def _background_kind(value: Any) -> str | None:
    if isinstance(value, (list, tuple)):
        return "color"
    if isinstance(value, dict):
        return value.get("type") if isinstance(value.get("type"), str) else None
    if isinstance(value, (SolidBackground, SkyBackground, ImageBackground, SunSkyBackground)):
        return value.type
    return None


Background = Annotated[
    Union[
        Annotated[Color, Tag("color")],
        Annotated[SolidBackground, Tag("solid")],
        Annotated[SkyBackground, Tag("sky")],
        Annotated[ImageBackground, Tag("image")],
        Annotated[SunSkyBackground, Tag("sun_sky")],
    ],
    Discriminator(
        _background_kind,
        custom_error_type="background",
        custom_error_message="expected a colour [r, g, b], {type: solid, ...}, {type: sky, ...}, {type: image, ...} or {type: sun_sky, ...}",
    ),
]
"""A colour triple, a solid background, the sky gradient, an environment map or the sun and sky."""


class Scene(StrictModel):
    """A whole scene file.

    ```yaml
    version: 1
    camera: {look_from: [0, 0, 9], look_at: [0, 0, 0], vfov: 80}
    image: {width: 400, aspect_ratio: 1, samples_per_pixel: 100, max_depth: 50}
    background: [0.7, 0.8, 1.0]
    materials:
      red: {type: lambertian, albedo: [1.0, 0.2, 0.2]}
    shapes:
      - {type: quad, q: [-3, -2, 5], u: [0, 0, -4], v: [0, 4, 0], material: red}
    ```
    """

    version: Literal[1] = Field(FORMAT_VERSION, description="Version of the scene format; this release reads version 1.")
    description: str = Field("", max_length=10_000, description="Free text about the scene.")
    include: Annotated[
        list[IncludeName], BeforeValidator(_one_or_more_files), WithJsonSchema(_INCLUDE_SCHEMA)
    ] = Field(
        default_factory=list,
        max_length=MAX_INCLUDES,
        description="A file, or a list of files (relative to this one), whose named `textures`, `materials`, `media`, "
        "`groups` and `shapes` are merged into this scene; a name defined twice is an error. Included files may "
        "include others (not themselves); a file included twice is read once. Like every file a scene names, an "
        "included file must lie inside the main scene's folder unless `--allow-path` allows another.",
    )
    camera: Camera = Field(default_factory=Camera, description="The camera.")
    image: Image = Field(default_factory=Image, description="Image size and sampling.")
    shutter: Shutter = Field(default_factory=Shutter, description="Shutter interval, for motion blur.")
    background: Background = Field(
        default_factory=SkyBackground,
        description="Radiance of rays that leave the scene: a colour, `solid`, `sky`, an `image` (an environment "
        "map) or `sun_sky` (a physically based sun and sky). The default is the first "
        "book's sky gradient, so a scene without lights is still visible; the second book's scenes set it explicitly.",
    )
    textures: dict[Name, Texture] = Field(default_factory=dict, description="Named textures.")
    materials: dict[Name, Material] = Field(default_factory=dict, description="Named materials.")
    media: dict[Name, Medium] = Field(default_factory=dict, description="Named participating media.")
    groups: dict[Name, Group] = Field(default_factory=dict, description="Named groups of shapes, placed by `instance` shapes.")
    shapes: list[Shape] = Field(default_factory=list, max_length=MAX_SHAPES, description="The shapes of the scene.")
    lights: list[Light] = Field(
        default_factory=list,
        max_length=MAX_LIGHTS,
        description="Lights that are no shape: `point`, `spot` and `directional`, in world space (no transform or "
        "group applies to them). Emitting shapes (a `diffuse_light` material) are lights too, without being listed here.",
    )
