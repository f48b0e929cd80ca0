"""Texture models: solid colour, checker, image and Perlin noise.

A texture slot (`albedo`, `emit`, a checker's `even`/`odd`) takes a colour triple,
the name of a texture defined under `textures:`, or an inline texture definition.
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Discriminator, Field, Tag

from .base import Color, Name, Number, StrictModel, slot_kind


class SolidTexture(StrictModel):
    """A single colour everywhere.

    ```yaml
    type: solid
    color: [0.8, 0.3, 0.3]
    ```
    """

    type: Literal["solid"] = Field("solid", description="Selects a solid-colour texture.")
    color: Color = Field((0.5, 0.5, 0.5), description="Linear RGB colour.")


class CheckerTexture(StrictModel):
    """A 3-D checkerboard: cells of side `scale` alternate between `even` and `odd` by the parity of
    floor(x/scale) + floor(y/scale) + floor(z/scale).

    ```yaml
    type: checker
    scale: 0.32
    even: [0.2, 0.3, 0.1]
    odd: [0.9, 0.9, 0.9]
    ```
    """

    type: Literal["checker"] = Field("checker", description="Selects a spatial checker texture.")
    scale: Number = Field(1.0, gt=0, description="Side length of one checker cell, in scene units.")
    even: TextureSlot = Field((0.0, 0.0, 0.0), description="Texture of cells whose index sum is even.")
    odd: TextureSlot = Field((1.0, 1.0, 1.0), description="Texture of cells whose index sum is odd.")


class ImageTexture(StrictModel):
    """An image wrapped over the surface's (u, v) coordinates; u runs left to right, v bottom to top.

    ```yaml
    type: image
    file: earthmap.png
    ```
    """

    type: Literal["image"] = Field("image", description="Selects an image texture.")
    file: str = Field(
        ...,
        min_length=1,
        max_length=4096,
        description="Image file (PNG, JPEG, ...; or OpenEXR `.exr` and PFM `.pfm`, float RGB read as linear values), "
        "relative to the folder of the file that names it.",
    )
    colorspace: Literal["srgb", "linear"] = Field(
        "srgb",
        description="How the file's values are encoded: `srgb` values are linearised on load, `linear` ones are used as "
        "they are. Float images (.exr, .pfm) are always linear.",
    )


class NoiseTexture(StrictModel):
    """Perlin noise: `plain` smooth noise, `turbulence` (a sum of octaves), or `marble` stripes
    along z perturbed by turbulence.

    ```yaml
    type: noise
    scale: 4
    form: marble
    ```
    """

    type: Literal["noise"] = Field("noise", description="Selects a Perlin-noise texture.")
    scale: Number = Field(1.0, gt=0, description="Spatial frequency of the pattern.")
    form: Literal["plain", "turbulence", "marble"] = Field(
        "marble",
        description="`plain`: 0.5 (1 + noise(scale p)); `turbulence`: turb(scale p); "
        "`marble`: 0.5 (1 + sin(scale z + 10 turb(p))), as in the books' final form.",
    )
    octaves: int = Field(7, ge=1, le=16, strict=True, description="Number of octaves summed for turbulence and marble.")
    color: Color = Field((1.0, 1.0, 1.0), description="Colour multiplied by the noise value.")
    seed: int = Field(0, ge=0, le=2**31 - 1, strict=True, description="Seed of the noise lattice tables.")


Texture = Annotated[
    Union[SolidTexture, CheckerTexture, ImageTexture, NoiseTexture],
    Field(discriminator="type"),
]
"""Any texture definition, chosen by its `type`."""

TextureSlot = Annotated[
    Union[
        Annotated[Color, Tag("color")],
        Annotated[Name, Tag("name")],
        Annotated[Texture, Tag("inline")],
    ],
    Discriminator(
        slot_kind,
        custom_error_type="texture_slot",
        custom_error_message="expected a colour [r, g, b], a texture name, or a texture definition",
    ),
]
"""A colour triple, the name of a texture under `textures:`, or an inline texture."""

CheckerTexture.model_rebuild()
