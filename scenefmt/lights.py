"""Light models that are no shape: point, spot and directional lights (`lights:` of a scene).

Units are radiometric, as in Mitsuba 3 and pbrt-v4: a point or spot light's `intensity` is in
W/sr, its `power` in watts (the flux it sends in all directions); a directional light's
`irradiance` in W/m^2 on a surface facing it. An amount is a number (grey, or the luminance of a
`temperature`'s colour) or an RGB triple (linear sRGB). Positions and directions are in world
space: lights are top-level, never in groups, and no transform applies to them.

Each model says what the renderer sends: `intensity_rgb()` (point, spot) or `irradiance_rgb()`
(directional), and its flux as the light choice weighs it (`flux()`, luminance). docs/lights.md
states the formulas; `renderer/punctual.py` makes the rows.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal, Optional, Union

from pydantic import AfterValidator, Discriminator, Field, Tag, model_validator

from .base import Color, Kelvin, Number, StrictModel, Vec3, field_error, vec_length, vec_sub
from .blackbody import MAX_KELVIN, MIN_KELVIN, luminance, temperature_rgb


def _amount_kind(value: Any) -> Optional[str]:
    if isinstance(value, bool):
        return None
    if isinstance(value, (int, float)):
        return "number"
    if isinstance(value, (list, tuple)):
        return "color"
    return None


def _not_negative(value: float) -> float:
    if value < 0:
        raise ValueError(f"expected a number >= 0, found {value:g}")
    return value


Amount = Annotated[
    Union[Annotated[Annotated[Number, AfterValidator(_not_negative)], Tag("number")], Annotated[Color, Tag("color")]],
    Discriminator(
        _amount_kind,
        custom_error_type="amount",
        custom_error_message="expected a number >= 0 or a colour [r, g, b]",
    ),
]
"""A number >= 0 (grey, or the luminance of a temperature's colour) or a linear RGB triple."""

TEMPERATURE_DESCRIPTION = (
    f"Colour temperature in kelvin ({MIN_KELVIN:g} to {MAX_KELVIN:g}): the light has a black body's colour "
    "(2700 a warm bulb, 6500 about white), and its amount is a number, the luminance of that colour."
)


def _colour(amount, temperature: Optional[float]) -> tuple[float, float, float]:
    """An amount as RGB: a number is grey, or a temperature's colour of that luminance."""
    if isinstance(amount, (int, float)):
        tint = temperature_rgb(float(temperature)) if temperature is not None else (1.0, 1.0, 1.0)
        return (tint[0] * amount, tint[1] * amount, tint[2] * amount)
    return (float(amount[0]), float(amount[1]), float(amount[2]))


def _number_with_temperature(model, keys: tuple[str, ...]) -> None:
    """A temperature gives the colour: the amounts must then be numbers."""
    if model.temperature is None:
        return
    for key in keys:
        value = getattr(model, key)
        if value is not None and not isinstance(value, (int, float)):
            raise field_error(key, f"with a temperature, `{key}` is a number (the luminance of the temperature's colour), not a colour")


def _unit(v, key: str) -> tuple[float, float, float]:
    length = vec_length(v)
    if not length > 0.0:
        raise field_error(key, f"`{key}` must not be the zero vector: it gives the light's direction")
    return (v[0] / length, v[1] / length, v[2] / length)


def spot_solid_angle(cutoff_deg: float, beam_deg: float) -> float:
    """The integral over the sphere of the spot profile (Mitsuba 3's: 1 within the beam angle b,
    falling linearly in angle to 0 at the cutoff angle c), in steradians:

        2 pi [1 - cos m sin(h) / h],  m = (c + b) / 2, h = (c - b) / 2,

    which is 2 pi (1 - (sin c - sin b) / (c - b)) written without the cancellation as b nears c
    (then it is 2 pi (1 - cos c), a cone's solid angle). docs/lights.md derives it."""
    c, b = math.radians(cutoff_deg), math.radians(beam_deg)
    m, h = 0.5 * (c + b), 0.5 * (c - b)
    # 1 - cos m sinc(h) = (1 - cos m) + cos m (1 - sinc h), each term >= 0; the second from its
    # series where the difference would cancel.
    one_minus_sinc = 1.0 - math.sin(h) / h if h > 1e-4 else h * h / 6.0 - h ** 4 / 120.0
    return 2.0 * math.pi * (2.0 * math.sin(0.5 * m) ** 2 + math.cos(m) * one_minus_sinc)


class PointLight(StrictModel):
    """A point sending the same intensity in every direction, with light falling off as the inverse
    square of the distance. With `radius`, it is a sphere of that radius for its shadows (soft
    ones), sending the same light; the sphere is never seen by camera or reflected rays.

    ```yaml
    type: point
    position: [278, 500, 278]
    power: 2000
    temperature: 2700
    ```
    """

    type: Literal["point"] = Field("point", description="Selects a point light.")
    position: Vec3 = Field(..., description="Where the light is, in world space.")
    intensity: Optional[Amount] = Field(
        None, description="Radiant intensity in W/sr: a number or a colour [r, g, b] (1 when neither this nor `power` is given)."
    )
    power: Optional[Amount] = Field(
        None, description="Instead of `intensity`: the flux sent in all directions, in watts; intensity = power / (4 pi)."
    )
    temperature: Optional[Kelvin] = Field(None, description=TEMPERATURE_DESCRIPTION)
    radius: Number = Field(
        0.0, ge=0, description="Radius of the sphere the light is sampled as, for soft shadows (0: a point). Camera and "
        "reflected rays never see it."
    )

    @model_validator(mode="after")
    def _one_amount(self) -> "PointLight":
        if self.intensity is not None and self.power is not None:
            raise field_error("power", "give either `intensity` or `power`, not both")
        _number_with_temperature(self, ("intensity", "power"))
        return self

    def intensity_rgb(self) -> tuple[float, float, float]:
        """Radiant intensity per channel, W/sr."""
        if self.power is not None:
            flux = _colour(self.power, self.temperature)
            return tuple(c / (4.0 * math.pi) for c in flux)
        return _colour(1.0 if self.intensity is None else self.intensity, self.temperature)

    def flux(self) -> float:
        """The luminance of the flux it sends: 4 pi I."""
        return 4.0 * math.pi * luminance(self.intensity_rgb())


class SpotLight(StrictModel):
    """A point sending light in a cone about an axis, with Mitsuba 3's profile: the full intensity
    within `beam_width` of the axis, falling linearly in angle to nothing at `cutoff_angle`.

    ```yaml
    type: spot
    position: [278, 540, 278]
    look_at: [278, 0, 278]
    intensity: 3000
    cutoff_angle: 30
    beam_width: 20
    ```
    """

    type: Literal["spot"] = Field("spot", description="Selects a spot light.")
    position: Vec3 = Field(..., description="Where the light is, in world space.")
    look_at: Optional[Vec3] = Field(None, description="A point on the spot's axis (give this or `direction`).")
    direction: Optional[Vec3] = Field(None, description="The direction of the spot's axis, any length but 0 (give this or `look_at`).")
    intensity: Optional[Amount] = Field(
        None, description="Radiant intensity on the axis, in W/sr: a number or a colour [r, g, b] (1 when neither this nor `power` is given)."
    )
    power: Optional[Amount] = Field(
        None, description="Instead of `intensity`: the flux the spot sends, in watts; intensity = power / the profile's "
        "solid angle, 2 pi (1 - cos m sin(h) / h) with m = (cutoff + beam) / 2, h = (cutoff - beam) / 2."
    )
    temperature: Optional[Kelvin] = Field(None, description=TEMPERATURE_DESCRIPTION)
    cutoff_angle: Number = Field(
        20.0, gt=0, le=90, description="Half-angle of the cone, in degrees, beyond which the spot sends nothing."
    )
    beam_width: Optional[Number] = Field(
        None, gt=0, description="Half-angle, in degrees, within which the spot sends its full intensity; at most "
        "`cutoff_angle` (default 3/4 of it, as Mitsuba's)."
    )

    @model_validator(mode="after")
    def _well_posed(self) -> "SpotLight":
        if self.intensity is not None and self.power is not None:
            raise field_error("power", "give either `intensity` or `power`, not both")
        _number_with_temperature(self, ("intensity", "power"))
        if (self.look_at is None) == (self.direction is None):
            raise field_error("direction" if self.direction is not None else "look_at",
                              "give either `look_at` or `direction` for the spot's axis, not both" if self.direction is not None
                              else "give `look_at` or `direction`: the spot's axis")
        if self.direction is not None:
            _unit(self.direction, "direction")
        elif vec_length(vec_sub(self.look_at, self.position)) == 0.0:
            raise field_error("look_at", "`look_at` is the spot's `position`, so it gives no direction")
        if self.beam_width is not None and self.beam_width > self.cutoff_angle:
            raise field_error("beam_width", f"`beam_width` ({self.beam_width:g}) must be at most `cutoff_angle` ({self.cutoff_angle:g})")
        return self

    @property
    def beam(self) -> float:
        """The beam width in effect, degrees."""
        return 0.75 * self.cutoff_angle if self.beam_width is None else self.beam_width

    def axis(self) -> tuple[float, float, float]:
        """The unit direction of the spot's axis."""
        return _unit(self.direction if self.direction is not None else vec_sub(self.look_at, self.position), "direction")

    def solid_angle(self) -> float:
        """The profile integrated over the sphere, steradians (`spot_solid_angle`)."""
        return spot_solid_angle(self.cutoff_angle, self.beam)

    def intensity_rgb(self) -> tuple[float, float, float]:
        """Radiant intensity on the axis per channel, W/sr."""
        if self.power is not None:
            flux = _colour(self.power, self.temperature)
            return tuple(c / self.solid_angle() for c in flux)
        return _colour(1.0 if self.intensity is None else self.intensity, self.temperature)

    def flux(self) -> float:
        """The luminance of the flux it sends: I times the profile's solid angle."""
        return self.solid_angle() * luminance(self.intensity_rgb())


class DirectionalLight(StrictModel):
    """Parallel light from one direction at infinity (a distant sun without a disc): every point it
    reaches receives the same irradiance, times the cosine of the angle to the surface's normal.

    ```yaml
    type: directional
    direction: [-1, -2, -0.5]
    irradiance: 3
    ```
    """

    type: Literal["directional"] = Field("directional", description="Selects a directional light.")
    direction: Vec3 = Field(..., description="The way the light travels (from the light into the scene), any length but 0.")
    irradiance: Amount = Field(
        1.0, description="Irradiance in W/m^2 on a surface facing the light: a number or a colour [r, g, b]."
    )
    temperature: Optional[Kelvin] = Field(None, description=TEMPERATURE_DESCRIPTION)

    @model_validator(mode="after")
    def _well_posed(self) -> "DirectionalLight":
        _unit(self.direction, "direction")
        _number_with_temperature(self, ("irradiance",))
        return self

    def toward_light(self) -> tuple[float, float, float]:
        """The unit direction from the scene toward the light."""
        d = _unit(self.direction, "direction")
        return (-d[0], -d[1], -d[2])

    def irradiance_rgb(self) -> tuple[float, float, float]:
        """Irradiance per channel, W/m^2."""
        return _colour(self.irradiance, self.temperature)

    def flux(self, scene_radius: float) -> float:
        """The luminance of the flux it sends into a scene of bounding radius R: pi R^2 E."""
        return math.pi * scene_radius ** 2 * luminance(self.irradiance_rgb())


Light = Annotated[Union[PointLight, SpotLight, DirectionalLight], Field(discriminator="type")]
"""Any light that is no shape, chosen by its `type`."""

LIGHT_CLASSES = (PointLight, SpotLight, DirectionalLight)
