"""The sun and sky background: its model, and where the sun stands at a date, time and place.

Pure Python (math only), so that `rt validate` can check a `sun_sky` background, including a sun
placed by date and time, without loading numpy. The sky's radiance and the sun's disc are
computed when flattening (renderer/sky.py, renderer/sun.py).

Directions: +y is up; the azimuth is a compass bearing, in degrees clockwise seen from above,
from north, which is -z (where the default camera looks), through east (+x), south (+z) and
west (-x). So `azimuth: 0` puts the sun ahead of the default camera (against the light), 180
behind it, 90 to its right.
"""

from __future__ import annotations

import datetime
import math
import re
from typing import Literal, Optional

from pydantic import Field, field_validator, model_validator

from .base import Number, StrictModel, field_error

# The real sun's angular diameter seen from the earth (degrees): 2 x 0.2666.
SUN_DIAMETER = 0.5332


class SunSkyBackground(StrictModel):
    """A clear sky and its sun, by the physically based model of Hosek and Wilkie (2012): the sky
    becomes an environment map (sampled by brightness like any map), the sun a light of the right
    angular size and radiance (docs/lights.md, "Sun and sky").

    Place the sun either by `elevation` and `azimuth`, or by `date`, `time`, `latitude` and
    `longitude` (not both). The sky is in units where a white floor under a clear midday sun
    and sky renders near 1: one unit of radiance is 100000/pi cd/m^2.

    ```yaml
    type: sun_sky
    elevation: 35
    azimuth: 220
    turbidity: 3
    ```
    """

    type: Literal["sun_sky"] = Field("sun_sky", description="Selects the physically based sun and sky.")
    elevation: Optional[Number] = Field(
        None, ge=0, le=90,
        description="The sun's height above the horizon in degrees, 0 to 90 (the sky model covers no sun below the "
        "horizon). Give it with `azimuth`, or give `date` and `time` instead.")
    azimuth: Optional[Number] = Field(
        None, ge=-360, le=360,
        description="The sun's compass bearing in degrees, clockwise seen from above: 0 is north (-z, where the "
        "default camera looks), 90 east (+x), 180 south (+z), 270 west (-x).")
    date: Optional[str] = Field(
        None, pattern=r"^\d{4}-\d{2}-\d{2}$",
        description="The day, as YYYY-MM-DD: with `time`, `latitude` and `longitude`, places the sun where it stands "
        "then and there (NOAA's solar position formulas, a few hundredths of a degree).")
    time: Optional[str] = Field(
        None, pattern=r"^\d{1,2}:\d{2}(:\d{2})?$",
        description="Local clock time as HH:MM or HH:MM:SS, in the zone `timezone` hours from UTC.")
    timezone: Number = Field(0.0, ge=-14, le=14, description="The clock's offset from UTC in hours (2 for UTC+2).")
    latitude: Number = Field(0.0, ge=-90, le=90, description="Degrees north of the equator (negative: south).")
    longitude: Number = Field(0.0, ge=-180, le=180, description="Degrees east of Greenwich (negative: west).")
    turbidity: Number = Field(
        3.0, ge=1, le=10,
        description="Haze, 1 to 10: 2 a very clear day, 3 a clear one, 6 a hazy one, 10 a thick haze (Linke's "
        "turbidity, as the model defines it).")
    ground_albedo: Number = Field(
        0.3, ge=0, le=1,
        description="Reflectance of the ground the sky is fitted over (it brightens the sky near the horizon), and of "
        "the ground shown below the horizon, lit by the sun and sky.")
    sun: bool = Field(True, description="Whether the sun's disc shines (as a light of its own).")
    sky: bool = Field(True, description="Whether the sky shines; without it only the sun does, on black.")
    sun_size: Number = Field(
        SUN_DIAMETER, gt=0, le=20,
        description="The sun's angular diameter in degrees (the real sun's is 0.5332): a larger sun casts softer "
        "shadows with the same irradiance.")
    strength: Number = Field(1.0, ge=0, description="Scales the radiance of the sky and the sun.")

    @field_validator("date")
    @classmethod
    def _real_day(cls, value: Optional[str]) -> Optional[str]:
        if value is not None:
            try:
                datetime.date.fromisoformat(value)
            except ValueError:
                raise ValueError(f"'{value}' is not a day of the calendar (YYYY-MM-DD)") from None
        return value

    @field_validator("time")
    @classmethod
    def _real_time(cls, value: Optional[str]) -> Optional[str]:
        if value is not None:
            parts = [int(p) for p in value.split(":")]
            if parts[0] > 23 or parts[1] > 59 or (len(parts) > 2 and parts[2] > 59):
                raise ValueError(f"'{value}' is not a time of day (HH:MM, 00:00 to 23:59)")
        return value

    @model_validator(mode="after")
    def _one_way_to_place_the_sun(self) -> "SunSkyBackground":
        by_angles = self.elevation is not None or self.azimuth is not None
        by_clock = self.date is not None or self.time is not None
        if by_angles and by_clock:
            raise field_error("date", "place the sun either by elevation and azimuth or by date and time, not both")
        if by_angles and (self.elevation is None or self.azimuth is None):
            missing = "azimuth" if self.azimuth is None else "elevation"
            raise field_error(missing, f"the sun's {missing} is missing: give both elevation and azimuth")
        if by_clock and (self.date is None or self.time is None):
            missing = "time" if self.time is None else "date"
            raise field_error(missing, f"the {missing} is missing: give both date and time")
        if not by_angles and not by_clock:
            raise field_error("elevation", "place the sun by elevation and azimuth, or by date and time")
        if by_clock:
            elevation, _ = self.sun_position()
            if elevation < 0.0:
                raise field_error("time", f"the sun is {-elevation:.1f} degrees below the horizon then and there: the sky "
                                  "model covers only a sun above it")
        return self

    def sun_position(self) -> tuple[float, float]:
        """(elevation, azimuth) of the sun in degrees, as given or from the date, time and place."""
        if self.elevation is not None:
            return float(self.elevation), float(self.azimuth)
        return solar_position(self.date, self.time, self.timezone, self.latitude, self.longitude)

    def sun_direction(self) -> tuple[float, float, float]:
        """The unit direction from the scene toward the sun (+y up, azimuth 0 toward -z, 90 toward +x)."""
        return direction(*self.sun_position())


def direction(elevation: float, azimuth: float) -> tuple[float, float, float]:
    """The unit vector at `elevation` degrees above the horizon and compass bearing `azimuth`."""
    el, az = math.radians(elevation), math.radians(azimuth)
    return (math.sin(az) * math.cos(el), math.sin(el), -math.cos(az) * math.cos(el))


def solar_position(date: str, clock: str, timezone: float, latitude: float, longitude: float) -> tuple[float, float]:
    """The sun's (elevation, azimuth) in degrees on `date` (YYYY-MM-DD) at local clock time
    `clock` (HH:MM[:SS]) in the zone `timezone` hours from UTC, seen from `latitude` degrees north
    and `longitude` degrees east: NOAA's formulas (the fractional year's Fourier series for the
    equation of time and the declination; the General Solar Position of Spencer 1971), good to a
    few hundredths of a degree in elevation for years near ours. No refraction: the sun's
    true, geometric position."""
    day = datetime.date.fromisoformat(date)
    parts = [int(p) for p in re.split(":", clock)] + [0]
    minutes = parts[0] * 60.0 + parts[1] + parts[2] / 60.0
    leap = day.year % 4 == 0 and (day.year % 100 != 0 or day.year % 400 == 0)
    year_days = 366.0 if leap else 365.0
    # The fractional year (radians), from the hour in UTC.
    g = 2.0 * math.pi / year_days * (day.timetuple().tm_yday - 1 + (minutes / 60.0 - timezone - 12.0) / 24.0)
    equation_of_time = 229.18 * (0.000075 + 0.001868 * math.cos(g) - 0.032077 * math.sin(g)
                                 - 0.014615 * math.cos(2 * g) - 0.040849 * math.sin(2 * g))  # minutes
    declination = (0.006918 - 0.399912 * math.cos(g) + 0.070257 * math.sin(g) - 0.006758 * math.cos(2 * g)
                   + 0.000907 * math.sin(2 * g) - 0.002697 * math.cos(3 * g) + 0.00148 * math.sin(3 * g))  # radians
    # True solar time (minutes): the clock, moved to the place's meridian and by the equation of time.
    solar = minutes + equation_of_time + 4.0 * longitude - 60.0 * timezone
    hour_angle = math.radians(solar / 4.0 - 180.0)
    lat = math.radians(latitude)
    sin_el = math.sin(lat) * math.sin(declination) + math.cos(lat) * math.cos(declination) * math.cos(hour_angle)
    elevation = math.degrees(math.asin(max(-1.0, min(1.0, sin_el))))
    # Bearing from north, clockwise: measured from south by the hour angle's side, then turned.
    from_south = math.atan2(math.sin(hour_angle),
                            math.cos(hour_angle) * math.sin(lat) - math.tan(declination) * math.cos(lat))
    azimuth = (math.degrees(from_south) + 180.0) % 360.0
    return elevation, azimuth
