"""The background: its table, its flattening, and the radiance of a ray that meets nothing.

A solid colour and the books' sky are read here; an image background (an environment map) has
a row here too, and its texels and sampling tables in `environment.py`, which fills the row in.
So has a `sun_sky` background: its sky is computed into such a map (sky.py), and its sun is a
light (sun.py) whose row `lights.light_tables` writes into the map's row.
"""


from scenefmt.scene import ImageBackground, SkyBackground
from scenefmt.sky import SunSkyBackground

from . import target
from .columns import Column, Layout
from .kernel_flags import SKY
from .numerics.vec import unit

BACKGROUND_SOLID = 0
BACKGROUND_SKY = 1
BACKGROUND_IMAGE = 2

_KIND = Column("kind", 1, "BACKGROUND_SOLID, BACKGROUND_SKY or BACKGROUND_IMAGE")
SOLID_BACKGROUND = Layout("background solid", "float64", [_KIND, Column("color", 3, "linear RGB")], 7)
SKY_BACKGROUND = Layout("background sky", "float64", [
    _KIND,
    Column("bottom", 3, "linear RGB straight down"),
    Column("top", 3, "linear RGB straight up; the books' blend between them by the direction's y"),
])
IMAGE_BACKGROUND = Layout("background image", "float64", [
    _KIND,
    Column("width", 1, "texels across (u, once around +y)"),
    Column("height", 1, "texels down (v, from straight up to straight down)"),
    Column("cos_rotate", 1, "cosine of the map's turn about +y"),
    Column("sin_rotate", 1, "its sine"),
    Column("sun", 1, "the light row of the sun of a sun_sky background, looked up by rays that escape; -1 for none"),
], 7)
SOLID_BACKGROUND.shares(SKY_BACKGROUND, "kind")
SOLID_BACKGROUND.shares(IMAGE_BACKGROUND, "kind")
BG_KIND, BG_COLOR = SOLID_BACKGROUND.offsets("kind", "color")
BG_BOTTOM, BG_TOP = SKY_BACKGROUND.offsets("bottom", "top")
(BG_SUN,) = IMAGE_BACKGROUND.offsets("sun")


def background_row(graph) -> list[float]:
    """The background row of a scene graph (an image's row is completed by environment.environment_tables,
    a sun_sky's, which is an image's, also by lights.light_tables)."""
    bg = graph.background
    if isinstance(bg, (ImageBackground, SunSkyBackground)):
        return IMAGE_BACKGROUND.row(kind=float(BACKGROUND_IMAGE), sun=-1.0)
    if isinstance(bg, SkyBackground):
        return SKY_BACKGROUND.row(kind=float(BACKGROUND_SKY), bottom=tuple(map(float, bg.bottom)), top=tuple(map(float, bg.top)))
    return SOLID_BACKGROUND.row(kind=float(BACKGROUND_SOLID), color=tuple(map(float, bg.color)))


@target.device
def background(bg, d):
    """The radiance of a ray that meets nothing, for a solid or sky background row. An image
    row (BACKGROUND_IMAGE) is environment.environment_radiance's, which also gives the density
    its MIS weight needs; lights.radiance_escaped asks that one, never this, for an image."""
    lo, hi = BG_BOTTOM, BG_TOP
    if SKY and bg[BG_KIND] == BACKGROUND_SKY:
        a = 0.5 * (unit(d)[1] + 1.0)
        return ((1.0 - a) * bg[lo] + a * bg[hi], (1.0 - a) * bg[lo + 1] + a * bg[hi + 1], (1.0 - a) * bg[lo + 2] + a * bg[hi + 2])
    return (bg[BG_COLOR], bg[BG_COLOR + 1], bg[BG_COLOR + 2])
