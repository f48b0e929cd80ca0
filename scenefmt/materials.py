"""Material models: lambertian, metal, dielectric, diffuse light and isotropic."""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Discriminator, Field, Tag

from .base import Name, Number, StrictModel, slot_kind
from .textures import TextureSlot


class Lambertian(StrictModel):
    """An ideal diffuse surface.

    ```yaml
    type: lambertian
    albedo: [0.73, 0.73, 0.73]
    ```
    """

    type: Literal["lambertian"] = Field("lambertian", description="Selects a diffuse material.")
    albedo: TextureSlot = Field((0.5, 0.5, 0.5), description="Fraction of light reflected, per channel: a colour or a texture.")


class Metal(StrictModel):
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


class Dielectric(StrictModel):
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
    """An emitter: emits `emit` from both faces and scatters nothing.

    ```yaml
    type: diffuse_light
    emit: [15, 15, 15]
    ```
    """

    type: Literal["diffuse_light"] = Field("diffuse_light", description="Selects an emissive material.")
    emit: TextureSlot = Field((1.0, 1.0, 1.0), description="Emitted radiance (may exceed 1): a colour or a texture.")


class Isotropic(StrictModel):
    """Scatters uniformly in all directions; the phase function of a participating medium.

    ```yaml
    type: isotropic
    albedo: [1, 1, 1]
    ```
    """

    type: Literal["isotropic"] = Field("isotropic", description="Selects an isotropic scatterer.")
    albedo: TextureSlot = Field((1.0, 1.0, 1.0), description="Scattered fraction per channel: a colour or a texture.")


Material = Annotated[
    Union[Lambertian, Metal, Dielectric, DiffuseLight, Isotropic],
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
