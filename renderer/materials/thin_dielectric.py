"""A thin dielectric: a sheet of glass too thin to offset the rays it lets through (a window
pane modelled as one quad), in the local shading frame of the material interface (z the
shading normal on the ray's side, wo.z > 0).

Light meets two parallel interfaces. With R the exact Fresnel reflectance of one interface at
the angle of entry and T = 1 - R, the sheet reflects R, then T R T, T R^3 T, ... (the light
bouncing between its faces), in all

    R' = R + T^2 R / (1 - R^2) = 2 R / (1 + R),

and lets through T' = 1 - R' along the direction it came (wi = -wo), since the two refractions
undo each other. Both lobes are deltas: `thin_dielectric_sample` chooses one with probability
R' (so the Fresnel terms cancel from the weight) and `_eval` and `_pdf` are 0.

The tint filters the transmitted light only; the reflection stays white. That is what Mitsuba
3's `thindielectric` does with its two factors (`specular_reflectance` multiplies the reflected
sample's weight, `specular_transmittance` the transmitted one's, both 1 by default) when the
tint is given as the transmittance: a coloured pane seen against the light is coloured, while
its reflection comes mostly from the first face, before any glass was crossed.
"""

from .. import target

from .fresnel import fresnel_dielectric


@target.device
def thin_dielectric_reflectance(ior, cos_i):
    """R' = 2R / (1 + R): the share of light a sheet of index `ior` (in a medium of index 1)
    reflects, every internal bounce summed, for light arriving at cosine `cos_i` in [0, 1].
    Both faces have the same reflectance R: the angle inside is the same at each, and Fresnel
    reflectance is the same from either side of an interface at corresponding angles."""
    if ior == 1.0:
        # No sheet at all. Asked, fresnel_dielectric would round 1 - cos^2 to 1 below a cosine
        # of about 1e-8 and answer total internal reflection there.
        return 0.0
    r = fresnel_dielectric(cos_i, 1.0 / ior)[0]
    return 2.0 * r / (1.0 + r)


@target.device
def thin_dielectric_sample(ior, tint, wo, u0, u1, u2):
    """(wi, weight, pdf, delta) of a sheet of index `ior` and transmission tint `tint` for the
    unit direction wo (local frame): the mirror direction with probability R', weight white,
    else straight through (wi = -wo), weight `tint`. Always a delta (pdf 0). u1 and u2 are not
    read. A wo at or below the surface (a normal map can bend the normal past it) gives no
    sample: direction (0, 0, 0) and weight black, on which the path tracer ends the path."""
    if not wo[2] > 0.0:
        return (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0, True
    if u0 < thin_dielectric_reflectance(ior, min(wo[2], 1.0)):
        return (-wo[0], -wo[1], wo[2]), (1.0, 1.0, 1.0), 0.0, True
    return (-wo[0], -wo[1], -wo[2]), (tint[0], tint[1], tint[2]), 0.0, True


@target.device
def thin_dielectric_eval(ior, tint, wo, wi):
    """f . |cos| of the sheet without its delta lobes: nothing, for every pair of directions."""
    return (0.0, 0.0, 0.0)


@target.device
def thin_dielectric_pdf(ior, tint, wo, wi):
    """The density without the delta lobes: 0."""
    return 0.0
