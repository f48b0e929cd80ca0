"""Material models: the books' lambertian, metal, dielectric, diffuse light and isotropic, and the
microfacet families (conductor, rough and thin dielectrics, plastic, principled).

Conventions (docs/materials.md): `roughness` r is the perceptual roughness of glTF and Blender, the
GGX width alpha = r^2; `alpha` gives the width itself, as Mitsuba takes it; the two keys exclude
each other, and 0 means a smooth surface (a mirror-like delta lobe). Every surface material takes
a `normal_map` or a `bump_map`.
"""

from __future__ import annotations

from typing import Annotated, Any, ClassVar, Literal, Optional, Union

from pydantic import Discriminator, Field, StrictBool, Tag, model_validator

from .base import Color, Kelvin, Name, Number, StrictModel, field_error, slot_kind
from .blackbody import MAX_KELVIN, MIN_KELVIN, temperature_rgb
from . import metals
from .textures import TextureSlot


class ScalarTexture(StrictModel):
    """A number read from a texture: one channel of its colour, times `scale`. glTF packs
    roughness in the green channel and metalness in the blue one of one image.

    ```yaml
    texture: {type: image, file: metal_rough.png}
    channel: g
    scale: 1
    ```
    """

    texture: TextureSlot = Field(description="The texture read: a name from `textures:` or an inline texture.")
    channel: Literal["r", "g", "b"] = Field("r", description="Which channel of the texture's colour holds the number.")
    scale: Number = Field(1.0, ge=0, description="Multiplies the channel's value (glTF's factor).")


def _scalar_kind(value: Any) -> Optional[str]:
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return "number"
    if isinstance(value, (dict, StrictModel)):
        return "texture"
    return None


ScalarSlot = Annotated[
    Union[Annotated[Number, Tag("number")], Annotated[ScalarTexture, Tag("texture")]],
    Discriminator(
        _scalar_kind,
        custom_error_type="scalar_slot",
        custom_error_message="expected a number or {texture: ..., channel: r|g|b, scale: ...}",
    ),
]
"""A number, or a channel of a texture."""

MetalName = Literal[tuple(metals.names())]  # type: ignore[valid-type]

Shadowing = Literal["correlated", "separable"]
SHADOWING_DESCRIPTION = (
    "Smith's masking-shadowing: `correlated` (height-correlated, pbrt-v4's, the default) or `separable` "
    "(G1 x G1, Mitsuba 3's; choose it to match Mitsuba's images)."
)


def _in_range(value, low: float, high: float, key: str) -> None:
    if isinstance(value, (int, float)) and not low <= value <= high:
        raise field_error(key, f"`{key}` must lie in [{low:g}, {high:g}], found {value:g}")


class SurfaceMaps(StrictModel):
    """Fields every surface material takes: a normal map or a bump map, not both."""

    normal_map: Optional[TextureSlot] = Field(
        None,
        description="Tangent-space normals (glTF's convention: red along +u, green along +v, blue out of the "
        "surface, [0, 1] read as [-1, 1]): a texture, normally an image. The tangent frame follows the "
        "shape's (u, v), a mesh's texture coordinates.",
    )
    normal_scale: Number = Field(1.0, ge=0, description="Multiplies the map's x and y (glTF's normal scale).")
    bump_map: Optional[TextureSlot] = Field(
        None, description="A height field (its red channel) that tilts the shading normal as its slope does."
    )
    bump_height: Number = Field(1.0, description="World units of height per unit of the bump map's value.")

    @model_validator(mode="after")
    def _one_map(self):
        if self.normal_map is not None and self.bump_map is not None:
            raise field_error("bump_map", "give a `normal_map` or a `bump_map`, not both")
        return self


class Roughness(StrictModel):
    """The GGX width of a microfacet surface, given as `roughness` (alpha = r^2) or `alpha`, with
    optional second values along the tangent's perpendicular for an anisotropic surface."""

    roughness: Optional[ScalarSlot] = Field(
        None, description="Perceptual roughness r in [0, 1] (glTF, Blender): the GGX width is r^2. 0 is smooth."
    )
    alpha: Optional[ScalarSlot] = Field(
        None, description="The GGX width alpha in [0, 1] itself (Mitsuba's `alpha`), instead of `roughness`."
    )
    roughness_v: Optional[ScalarSlot] = Field(
        None, description="Roughness along v for an anisotropic surface (`roughness` is then along u)."
    )
    alpha_v: Optional[ScalarSlot] = Field(None, description="Width along v for an anisotropic surface, instead of `roughness_v`.")
    shadowing: Shadowing = Field("correlated", description=SHADOWING_DESCRIPTION)

    @model_validator(mode="after")
    def _one_spelling(self):
        for a, b in (("roughness", "alpha"), ("roughness_v", "alpha_v")):
            if getattr(self, a) is not None and getattr(self, b) is not None:
                raise field_error(b, f"give `{a}` or `{b}`, not both: `{a}: r` means `{b}: r^2`")
        for key in ("roughness", "alpha", "roughness_v", "alpha_v"):
            _in_range(getattr(self, key), 0.0, 1.0, key)
        return self

    default_roughness: ClassVar[float] = 0.0  # the roughness when neither key is given

    def widths(self) -> tuple[tuple[Any, bool], tuple[Any, bool]]:
        """((u, squared), (v, squared)): each width as given (a number or a ScalarTexture) and whether
        it is a roughness that the kernels square; v is u when not given."""
        if self.alpha is not None:
            u = (self.alpha, False)
        elif self.roughness is not None:
            u = (self.roughness, True)
        else:
            u = (self.default_roughness, True)
        if self.alpha_v is not None:
            v = (self.alpha_v, False)
        elif self.roughness_v is not None:
            v = (self.roughness_v, True)
        else:
            v = u
        return u, v


class Lambertian(SurfaceMaps):
    """An ideal diffuse surface.

    ```yaml
    type: lambertian
    albedo: [0.73, 0.73, 0.73]
    ```
    """

    type: Literal["lambertian"] = Field("lambertian", description="Selects a diffuse material.")
    albedo: TextureSlot = Field((0.5, 0.5, 0.5), description="Fraction of light reflected, per channel: a colour or a texture.")


class Metal(SurfaceMaps):
    """A mirror, blurred by `fuzz`; a ray fuzzed below the surface is mirrored back above it, so
    nothing is lost at any fuzz (the books absorb it instead; see docs/robustness.md).

    ```yaml
    type: metal
    albedo: [0.8, 0.6, 0.2]
    fuzz: 0.3
    ```
    """

    type: Literal["metal"] = Field("metal", description="Selects a reflective metal.")
    albedo: TextureSlot = Field((0.8, 0.8, 0.8), description="Reflected fraction per channel: a colour or a texture.")
    fuzz: Number = Field(0.0, ge=0, le=1, description="Radius of the random perturbation of the mirror direction; 0 is a perfect mirror.")


class Dielectric(SurfaceMaps):
    """Clear glass-like material: reflects or refracts, choosing by the exact Fresnel reflectance
    (the books use Schlick's approximation, which reflects even at ior 1; see docs/robustness.md).

    ```yaml
    type: dielectric
    ior: 1.5
    ```
    """

    type: Literal["dielectric"] = Field("dielectric", description="Selects a refractive material.")
    ior: Number = Field(
        1.5,
        gt=0,
        description="Index of refraction of the inside relative to the outside (glass 1.5; below 1 for an air bubble in glass).",
    )


class DiffuseLight(StrictModel):
    """An emitter: emits `emit` from both faces (the books' light) or, with `sides: front`, only
    from the face its shape's normal points out of (as Mitsuba's and pbrt's area lights do: a
    quad's u x v, a triangle's (v1 - v0) x (v2 - v0), a mesh face's corners counter-clockwise
    seen from the front, a disk's `normal`, a sphere's and a box's outside). Scatters nothing.

    ```yaml
    type: diffuse_light
    emit: [15, 15, 15]
    sides: front
    ```
    """

    type: Literal["diffuse_light"] = Field("diffuse_light", description="Selects an emissive material.")
    emit: TextureSlot = Field((1.0, 1.0, 1.0), description="Emitted radiance (may exceed 1): a colour or a texture.")
    sides: Literal["both", "front"] = Field(
        "both", description="Which faces emit: `both` (the books') or `front`, the face the shape's normal points out "
                            "of (a quad's u x v, a sphere's outside); the back of a `front` light is black.")
    temperature: Optional[Kelvin] = Field(
        None, description=f"Colour temperature in kelvin ({MIN_KELVIN:g} to {MAX_KELVIN:g}): the light has a black body's "
        "colour (2700 a warm bulb, 6500 about white), and `emit` is then grey, [L, L, L], L the luminance of that colour.")

    @model_validator(mode="after")
    def _grey_with_temperature(self):
        if self.temperature is not None and not _grey(self.emit):
            raise field_error("emit", "with a temperature, `emit` is grey, [L, L, L] with L the luminance of the "
                              "temperature's colour, not another colour or a texture")
        return self

    def radiance_slot(self):
        """`emit` with the temperature's colour applied: what the renderer's emission reads."""
        return _tinted(self.emit, self.temperature)


def _grey(slot) -> bool:
    """Whether a colour slot is a constant grey [L, L, L] (not a colour, not a texture)."""
    return isinstance(slot, tuple) and slot[0] == slot[1] == slot[2]


def _tinted(slot, kelvin):
    """A grey radiance slot [L, L, L] with a black body's colour at `kelvin` (luminance 1) times
    L; the slot itself where there is no temperature."""
    if kelvin is None:
        return slot
    tint = temperature_rgb(float(kelvin))
    return tuple(c * slot[0] for c in tint)


class Isotropic(StrictModel):
    """Scatters uniformly in all directions; the phase function of a participating medium.

    ```yaml
    type: isotropic
    albedo: [1, 1, 1]
    ```
    """

    type: Literal["isotropic"] = Field("isotropic", description="Selects an isotropic scatterer.")
    albedo: TextureSlot = Field((1.0, 1.0, 1.0), description="Scattered fraction per channel: a colour or a texture.")


class Conductor(Roughness, SurfaceMaps):
    """A metal with the Fresnel reflectance of its complex index of refraction: a named measured
    metal, or `eta` and `k` per channel. Smooth by default; rough with `roughness` or `alpha` (GGX,
    sampled by visible normals, light-sampled like a diffuse surface).

    ```yaml
    type: conductor
    metal: gold
    roughness: 0.3
    ```
    """

    type: Literal["conductor"] = Field("conductor", description="Selects a conductor (a metal with measured Fresnel).")
    metal: Optional[MetalName] = Field(
        None, description="A measured metal by name (docs/materials.md lists them); aluminium if neither this nor `eta`/`k` is given."
    )
    eta: Optional[Color] = Field(None, description="Real part of the index of refraction per channel (with `k`, instead of `metal`).")
    k: Optional[Color] = Field(None, description="Imaginary part (extinction) of the index per channel (with `eta`).")
    tint: TextureSlot = Field((1.0, 1.0, 1.0), description="Multiplies the reflectance: a colour or a texture (1 for a measured metal).")

    @model_validator(mode="after")
    def _index(self):
        if (self.eta is None) != (self.k is None):
            raise field_error("k" if self.k is None else "eta", "give both `eta` and `k`, or a `metal` by name")
        if self.metal is not None and self.eta is not None:
            raise field_error("eta", "give a `metal` by name or `eta` and `k`, not both")
        return self

    def index(self) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
        """(eta, k) per channel."""
        if self.eta is not None:
            return tuple(self.eta), tuple(self.k)
        known = metals.metal(self.metal or "aluminium")
        return known.eta, known.k


class RoughDielectric(Roughness, SurfaceMaps):
    """Glass with a rough surface (GGX microfacets, Walter et al. 2007): frosted glass. It reflects
    and refracts by the exact Fresnel equations at each microfacet.

    ```yaml
    type: rough_dielectric
    ior: 1.5
    roughness: 0.3
    ```
    """

    type: Literal["rough_dielectric"] = Field("rough_dielectric", description="Selects a rough refractive material.")
    ior: Number = Field(1.5, gt=0, description="Index of refraction of the inside relative to the outside.")
    tint: TextureSlot = Field((1.0, 1.0, 1.0), description="Multiplies what is reflected and transmitted: a colour or a texture.")
    default_roughness: ClassVar[float] = 0.3


class ThinDielectric(SurfaceMaps):
    """A thin sheet of glass, such as a window pane: it reflects (counting the light bounced
    between its two faces) and lets the rest through without bending it.

    ```yaml
    type: thin_dielectric
    ior: 1.5
    ```
    """

    type: Literal["thin_dielectric"] = Field("thin_dielectric", description="Selects a thin sheet of glass.")
    ior: Number = Field(1.5, gt=0, description="Index of refraction of the sheet relative to the air around it.")
    tint: TextureSlot = Field((1.0, 1.0, 1.0), description="Multiplies what is transmitted: a colour or a texture.")


class Plastic(Roughness, SurfaceMaps):
    """A diffuse base under a clear dielectric coat (smooth by default, rough with `roughness` or
    `alpha`), with the light reflected inside the coat accounted for, as in Mitsuba's `plastic`
    and `roughplastic`.

    ```yaml
    type: plastic
    albedo: [0.1, 0.3, 0.8]
    roughness: 0.2
    ```
    """

    type: Literal["plastic"] = Field("plastic", description="Selects a coated diffuse material.")
    albedo: TextureSlot = Field((0.5, 0.5, 0.5), description="Reflectance of the diffuse base: a colour or a texture.")
    ior: Number = Field(1.5, ge=1, description="Index of refraction of the coat (1: no coat, a diffuse surface).")
    nonlinear: StrictBool = Field(
        False, description="Account for the colour shift of light bounced several times inside the coat (Mitsuba's `nonlinear`)."
    )


class Principled(SurfaceMaps):
    """The metallic-roughness material of glTF 2.0 and its common extensions (transmission, ior,
    specular, clearcoat, emissive strength): what imported assets use. A mix of a diffuse base, a
    GGX specular layer, a metal, a transmissive layer and a clear coat.

    ```yaml
    type: principled
    base_color: [0.8, 0.1, 0.1]
    metallic: 0
    roughness: 0.4
    clearcoat: 1
    ```
    """

    type: Literal["principled"] = Field("principled", description="Selects the principled (glTF metallic-roughness) material.")
    base_color: TextureSlot = Field((0.8, 0.8, 0.8), description="Base colour: the diffuse albedo, or a metal's reflectance at normal incidence.")
    metallic: ScalarSlot = Field(0.0, description="1 for a metal, 0 for a dielectric (glTF's metallicFactor).")
    roughness: ScalarSlot = Field(0.5, description="Perceptual roughness r in [0, 1]: the GGX width is r^2.")
    ior: Number = Field(1.5, gt=0, description="Index of refraction of the dielectric part (KHR_materials_ior).")
    specular: ScalarSlot = Field(1.0, description="Strength of the dielectric specular reflection (KHR_materials_specular).")
    specular_color: Color = Field((1.0, 1.0, 1.0), description="Colour of the dielectric specular reflection at normal incidence (KHR_materials_specular).")
    transmission: ScalarSlot = Field(0.0, description="Fraction of the dielectric base that is transmitted rather than diffuse (KHR_materials_transmission).")
    clearcoat: ScalarSlot = Field(0.0, description="Strength of a clear coat over everything (KHR_materials_clearcoat).")
    clearcoat_roughness: ScalarSlot = Field(0.0, description="Perceptual roughness of the clear coat.")
    emission: TextureSlot = Field((0.0, 0.0, 0.0), description="Emitted radiance before `emission_strength`: a colour or a texture.")
    emission_strength: Number = Field(1.0, ge=0, description="Multiplies `emission` (KHR_materials_emissive_strength).")
    emission_temperature: Optional[Kelvin] = Field(
        None, description=f"Colour temperature of the emission in kelvin ({MIN_KELVIN:g} to {MAX_KELVIN:g}): a black body's "
        "colour, and `emission` is then grey, [L, L, L], L the luminance of that colour.")
    thin_walled: StrictBool = Field(False, description="Transmission through a thin sheet (glTF without KHR_materials_volume: rays pass straight through, blurred by roughness) instead of refraction into a solid (false: a closed shape reads as glass).")
    shadowing: Shadowing = Field("correlated", description=SHADOWING_DESCRIPTION)

    @model_validator(mode="after")
    def _ranges(self):
        for key in ("metallic", "roughness", "specular", "transmission", "clearcoat", "clearcoat_roughness"):
            _in_range(getattr(self, key), 0.0, 1.0, key)
        if self.emission_temperature is not None and not _grey(self.emission):
            raise field_error("emission", "with an emission_temperature, `emission` is grey, [L, L, L] with L the "
                              "luminance of the temperature's colour, not another colour or a texture")
        return self

    def radiance_slot(self):
        """`emission` with its colour temperature applied: what the renderer's emission reads."""
        return _tinted(self.emission, self.emission_temperature)


SURFACE_MAP_KEYS = tuple(SurfaceMaps.model_fields)
MICROFACET_TYPES = ("conductor", "rough_dielectric", "thin_dielectric", "plastic", "principled")

Material = Annotated[
    Union[Lambertian, Metal, Dielectric, DiffuseLight, Isotropic, Conductor, RoughDielectric, ThinDielectric, Plastic,
          Principled],
    Field(discriminator="type"),
]
"""Any material definition, chosen by its `type`."""

MaterialSlot = Annotated[
    Union[Annotated[Name, Tag("name")], Annotated[Material, Tag("inline")]],
    Discriminator(
        slot_kind,
        custom_error_type="material_slot",
        custom_error_message="expected a material name or a material definition",
    ),
]
"""The name of a material under `materials:`, or an inline material."""


# Every field of a material that may hold a texture, and what its values mean: a reflectance
# (at most 1), a radiance, a map (normals or heights) or a scalar parameter (a ScalarTexture).
COLOUR_SLOTS = {"albedo": "reflectance", "tint": "reflectance", "base_color": "reflectance", "emit": "radiance",
                "emission": "radiance"}
MAP_SLOTS = ("normal_map", "bump_map")
SCALAR_SLOTS = ("roughness", "alpha", "roughness_v", "alpha_v", "metallic", "specular", "transmission", "clearcoat",
                "clearcoat_roughness")


def texture_fields(model) -> list[tuple[str, Any, str]]:
    """(field, texture slot value, role) for every field of a material model that holds a texture:
    role "reflectance" or "radiance" for a colour, "map" for a normal or bump map, "scalar" for a
    parameter read from a texture (the value is then the ScalarTexture's `texture`)."""
    found = []
    fields = type(model).model_fields
    for key, role in COLOUR_SLOTS.items():
        if key in fields:
            # An emission with its colour temperature applied, if it has one.
            value = model.radiance_slot() if role == "radiance" else getattr(model, key)
            found.append((key, value, role))
    for key in MAP_SLOTS:
        if key in fields and getattr(model, key) is not None:
            found.append((key, getattr(model, key), "map"))
    for key in SCALAR_SLOTS:
        value = getattr(model, key, None) if key in fields else None
        if isinstance(value, ScalarTexture):
            found.append((key, value.texture, "scalar"))
    return found


def emits(model) -> bool:
    """Whether a material model sends light: the books' diffuse light always, a principled
    material when its emission is not a constant black and its strength is above 0 (a textured
    emission counts as light whatever its texels)."""
    if model.type == "diffuse_light":
        return True
    if model.type == "principled":
        e = model.emission
        return model.emission_strength > 0 and not (isinstance(e, tuple) and max(e) <= 0)
    return False
