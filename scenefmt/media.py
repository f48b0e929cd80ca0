"""Participating media: a volume filling a closed shape, of constant density, of a density read
from a 3-D grid, or of a density drawn from Perlin noise; each with an albedo and a phase function."""

from __future__ import annotations

from typing import Annotated, Literal, Optional, Union

from pydantic import Discriminator, Field, Tag, model_validator

from .base import Name, Number, StrictModel, Vec3, field_error, slot_kind
from .textures import TextureSlot

# The largest grid a medium may read: 256^3 cells (the kernels hold it as float64, 8 bytes each).
MAX_GRID_CELLS = 256 ** 3
# The largest side of a grid, whatever its cell count.
MAX_GRID_SIDE = 4096


class IsotropicPhase(StrictModel):
    """Scatters equally in every direction (the books' phase function).

    ```yaml
    type: isotropic
    ```
    """

    type: Literal["isotropic"] = Field("isotropic", description="Selects the isotropic phase function.")


class HenyeyGreensteinPhase(StrictModel):
    """Henyey and Greenstein's phase function: forward scattering for g > 0 (haze, clouds), backward
    for g < 0, isotropic at 0. `g` is the mean cosine between the ray's direction before and after
    scattering.

    ```yaml
    type: henyey_greenstein
    g: 0.6
    ```
    """

    type: Literal["henyey_greenstein"] = Field("henyey_greenstein", description="Selects the Henyey-Greenstein phase function.")
    g: Number = Field(..., gt=-1, lt=1, description="Asymmetry: the mean cosine of the scattering angle, in (-1, 1).")


Phase = Annotated[Union[IsotropicPhase, HenyeyGreensteinPhase], Field(discriminator="type")]
"""A phase function, chosen by its `type`."""


def _albedo():
    return Field((1.0, 1.0, 1.0), description="Scattered fraction per channel: a colour or a texture.")


def _phase():
    return Field(IsotropicPhase(), description="How the medium scatters: `isotropic` (the default) or "
                 "`henyey_greenstein` with its asymmetry `g`.")


class _MediumBase(StrictModel):
    # Each kind declares its fields itself, `albedo` and `phase` last, so that a written scene
    # keeps the order it always had (type, density, albedo).

    @property
    def phase_g(self) -> float:
        """The phase function's asymmetry: 0 for isotropic."""
        return float(getattr(self.phase, "g", 0.0))


class ConstantMedium(_MediumBase):
    """A homogeneous medium (smoke, fog, mist). It fills the inside of every closed shape that
    names it as `interior`.

    ```yaml
    type: constant
    density: 0.01
    albedo: [1, 1, 1]
    ```
    """

    type: Literal["constant"] = Field("constant", description="Selects a medium of constant density.")
    density: Number = Field(
        ..., gt=0, description="Scattering events per unit length; the mean free path is 1/density."
    )
    albedo: TextureSlot = _albedo()
    phase: Phase = _phase()


class GridMedium(_MediumBase):
    """A medium whose density is read from a 3-D array of cells (a simulation's smoke, a cloud),
    stretched over the box `bounds` in the space of the shape that holds it (the shape's
    transform places both); outside that box the density is 0. Cell [i, j, k] of the array covers
    the i-th part along x, the j-th along y and the k-th along z.

    ```yaml
    type: grid
    file: smoke.npz
    key: density
    bounds: [[-1, 0, -1], [1, 2, 1]]
    interpolation: trilinear
    density: 4
    ```
    """

    type: Literal["grid"] = Field("grid", description="Selects a medium whose density is read from a grid.")
    file: str = Field(
        ..., min_length=1, max_length=4096,
        description="A `.npy` file holding a 3-D array, or a `.npz` file holding one under `key`; relative to the folder "
        "of the file that names it. Finite values, none negative, at most 256^3 cells.",
    )
    key: Optional[str] = Field(None, min_length=1, max_length=256, description="The array's name in an `.npz` file.")
    bounds: tuple[Vec3, Vec3] = Field(
        ..., description="The grid's box as [min corner, max corner], in the space of the shape that holds the medium."
    )
    interpolation: Literal["nearest", "trilinear"] = Field(
        ..., description="`nearest`: each cell's value fills the cell; `trilinear`: values are at cell centres and "
        "blended between them (the edge cells' values hold out to the box)."
    )
    density: Number = Field(1.0, ge=0, description="Scale of the grid's values: scattering events per unit length per unit value.")
    albedo: TextureSlot = _albedo()
    phase: Phase = _phase()

    @model_validator(mode="after")
    def _check(self) -> "GridMedium":
        lo, hi = self.bounds
        for axis, a, b in zip("xyz", lo, hi):
            if not b > a:
                raise field_error("bounds", f"the grid's box has no positive size along {axis}: max {b:g} must exceed min {a:g}")
        suffix = self.file.lower().rsplit(".", 1)[-1] if "." in self.file else ""
        if suffix not in ("npy", "npz"):
            raise field_error("file", f"a grid is read from a .npy or .npz file, not {self.file!r}")
        if suffix == "npz" and self.key is None:
            raise field_error("key", "an .npz file holds several arrays: name the grid's with `key`")
        if suffix == "npy" and self.key is not None:
            raise field_error("key", "a .npy file holds one array: `key` is only for .npz files")
        return self


class NoiseMedium(_MediumBase):
    """A medium whose density is Perlin noise, the field of the `noise` texture: `density` times
    the texture's value at the point (`plain`, `turbulence` or `marble`), clamped at 0.

    ```yaml
    type: noise
    scale: 0.5
    form: turbulence
    octaves: 4
    density: 2
    ```
    """

    type: Literal["noise"] = Field("noise", description="Selects a medium whose density is Perlin noise.")
    scale: Number = Field(1.0, gt=0, description="Spatial frequency of the noise, in the space of the shape that holds it.")
    form: Literal["plain", "turbulence", "marble"] = Field(
        "turbulence", description="The noise texture's forms: `plain` 0.5 (1 + noise), `turbulence`, `marble`.")
    octaves: int = Field(7, ge=1, le=16, strict=True, description="Number of octaves summed for turbulence and marble.")
    density: Number = Field(1.0, gt=0, description="Scattering events per unit length per unit of the noise's value.")
    seed: int = Field(0, ge=0, le=2**31 - 1, strict=True, description="Seed of the noise lattice tables.")
    albedo: TextureSlot = _albedo()
    phase: Phase = _phase()


Medium = Annotated[Union[ConstantMedium, GridMedium, NoiseMedium], Field(discriminator="type")]
"""Any medium definition, chosen by its `type`."""

MediumSlot = Annotated[
    Union[Annotated[Name, Tag("name")], Annotated[Medium, Tag("inline")]],
    Discriminator(
        slot_kind,
        custom_error_type="medium_slot",
        custom_error_message="expected a medium name or a medium definition",
    ),
]
"""The name of a medium under `media:`, or an inline medium."""
