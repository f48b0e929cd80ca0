"""Participating media: a volume of constant density filling a closed shape."""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Discriminator, Field, Tag

from .base import Name, Number, StrictModel, slot_kind
from .textures import TextureSlot


class ConstantMedium(StrictModel):
    """A homogeneous medium (smoke, fog, mist) that scatters isotropically. It fills the inside of
    every closed shape that names it as `interior`.

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
    albedo: TextureSlot = Field((1.0, 1.0, 1.0), description="Scattered fraction per channel: a colour or a texture.")


Medium = Annotated[Union[ConstantMedium], Field(discriminator="type")]
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
