"""The microfacet families by kind, in the local shading frame: which family's functions answer
for a row of kind CONDUCTOR and up, with the row's columns and the hit's parameter slots read
into each family's own arguments. `dispatch.py` turns world directions into this frame and back.

Every function here takes wo (toward the viewer, wo.z > 0 in the normal case) and wi in the frame
whose z is the shading normal on the viewer's side; dielectric families get eta, the index on the
far side over the index on the near side, chosen here from the side the ray hit.
"""

from .. import target

from ..kernel_flags import CONDUCTORS, PLASTICS, PRINCIPLED, ROUGH_DIELECTRICS
from .conductor import conductor_eval, conductor_is_smooth, conductor_pdf, conductor_sample
from .plastic import plastic_eval, plastic_pdf, plastic_sample
from .principled import principled_eval, principled_has_density, principled_pdf, principled_sample
from .rough_dielectric import (rough_dielectric_eval, rough_dielectric_is_smooth, rough_dielectric_pdf,
                               rough_dielectric_sample)
from .table import (CONDUCTOR, MAT_CORRELATED, MAT_ETA, MAT_IOR, MAT_K, MAT_NONLINEAR, MAT_SPECULAR_COLOR, MAT_THIN_WALLED,
                    PLASTIC, ROUGH_DIELECTRIC, SLOT_ALPHA_U, SLOT_ALPHA_V, SLOT_CLEARCOAT, SLOT_CLEARCOAT_ALPHA,
                    SLOT_METALLIC, SLOT_SPECULAR, SLOT_TRANSMISSION, THIN_DIELECTRIC)
from .table import PRINCIPLED as PRINCIPLED_KIND  # (PRINCIPLED is the kernel flag here)
from .thin_dielectric import thin_dielectric_sample

_BLACK = (0.0, 0.0, 0.0)
_UP = (0.0, 0.0, 1.0)


@target.device
def _row3(mat_f, mat, at):
    return (mat_f[mat, at], mat_f[mat, at + 1], mat_f[mat, at + 2])


@target.device
def _eta(mat_f, mat, front_face):
    """The far side's index over the near side's for a dielectric row: the row's ior when the ray
    hit the outward side (coming from outside, index 1), its inverse from inside."""
    ior = mat_f[mat, MAT_IOR]
    return ior if front_face else 1.0 / ior


@target.device
def family_sample(kind, mat_i, mat_f, mat, color, params, front_face, wo, u0, u1, u2):
    """(wi, weight, pdf, delta) of the family of `kind`; see each family's `_sample`."""
    correlated = mat_i[mat, MAT_CORRELATED] != 0
    if CONDUCTORS and kind == CONDUCTOR:
        return conductor_sample(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], _row3(mat_f, mat, MAT_ETA),
                                _row3(mat_f, mat, MAT_K), color, correlated, wo, u0, u1, u2)
    if ROUGH_DIELECTRICS and kind == ROUGH_DIELECTRIC:
        return rough_dielectric_sample(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], _eta(mat_f, mat, front_face), color,
                                       correlated, wo, u0, u1, u2)
    if ROUGH_DIELECTRICS and kind == THIN_DIELECTRIC:
        # A sheet has air on both sides: its ior, whichever side was hit.
        return thin_dielectric_sample(mat_f[mat, MAT_IOR], color, wo, u0, u1, u2)
    if PRINCIPLED and kind == PRINCIPLED_KIND:
        return principled_sample(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], params[SLOT_METALLIC],
                                 params[SLOT_TRANSMISSION], params[SLOT_CLEARCOAT], params[SLOT_CLEARCOAT_ALPHA],
                                 params[SLOT_SPECULAR], _row3(mat_f, mat, MAT_SPECULAR_COLOR), _eta(mat_f, mat, front_face),
                                 mat_i[mat, MAT_THIN_WALLED] != 0, color, correlated, wo, u0, u1, u2)
    if PLASTICS and kind == PLASTIC:
        # Opaque, coated on whichever side was hit (as a lambertian surface is two-sided): the
        # row's ior is the coat's over the air's, front or back.
        return plastic_sample(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], mat_f[mat, MAT_IOR], color,
                              mat_i[mat, MAT_NONLINEAR] != 0, correlated, wo, u0, u1, u2)
    return _UP, _BLACK, 0.0, True


@target.device
def family_eval(kind, mat_i, mat_f, mat, color, params, front_face, wo, wi):
    """f(wo, wi) |cos theta_i| as RGB, the delta parts excluded."""
    correlated = mat_i[mat, MAT_CORRELATED] != 0
    if CONDUCTORS and kind == CONDUCTOR:
        return conductor_eval(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], _row3(mat_f, mat, MAT_ETA),
                              _row3(mat_f, mat, MAT_K), color, correlated, wo, wi)
    if ROUGH_DIELECTRICS and kind == ROUGH_DIELECTRIC:
        return rough_dielectric_eval(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], _eta(mat_f, mat, front_face), color,
                                     correlated, wo, wi)
    if PRINCIPLED and kind == PRINCIPLED_KIND:
        return principled_eval(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], params[SLOT_METALLIC],
                               params[SLOT_TRANSMISSION], params[SLOT_CLEARCOAT], params[SLOT_CLEARCOAT_ALPHA],
                               params[SLOT_SPECULAR], _row3(mat_f, mat, MAT_SPECULAR_COLOR), _eta(mat_f, mat, front_face),
                               mat_i[mat, MAT_THIN_WALLED] != 0, color, correlated, wo, wi)
    if PLASTICS and kind == PLASTIC:
        return plastic_eval(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], mat_f[mat, MAT_IOR], color,
                            mat_i[mat, MAT_NONLINEAR] != 0, correlated, wo, wi)
    return _BLACK


@target.device
def family_pdf(kind, mat_i, mat_f, mat, params, front_face, wo, wi):
    """The density `family_sample` gives wi, the delta parts excluded."""
    correlated = mat_i[mat, MAT_CORRELATED] != 0
    if CONDUCTORS and kind == CONDUCTOR:
        return conductor_pdf(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], _row3(mat_f, mat, MAT_ETA),
                             _row3(mat_f, mat, MAT_K), _BLACK, correlated, wo, wi)
    if ROUGH_DIELECTRICS and kind == ROUGH_DIELECTRIC:
        return rough_dielectric_pdf(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], _eta(mat_f, mat, front_face), _BLACK,
                                    correlated, wo, wi)
    if PRINCIPLED and kind == PRINCIPLED_KIND:
        return principled_pdf(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], params[SLOT_METALLIC],
                              params[SLOT_TRANSMISSION], params[SLOT_CLEARCOAT], params[SLOT_CLEARCOAT_ALPHA],
                              params[SLOT_SPECULAR], _row3(mat_f, mat, MAT_SPECULAR_COLOR), _eta(mat_f, mat, front_face),
                              mat_i[mat, MAT_THIN_WALLED] != 0, _BLACK, correlated, wo, wi)
    if PLASTICS and kind == PLASTIC:
        return plastic_pdf(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], mat_f[mat, MAT_IOR], _BLACK,
                           mat_i[mat, MAT_NONLINEAR] != 0, correlated, wo, wi)
    return 0.0


@target.device
def family_has_density(kind, params):
    """Whether the family of `kind` with these parameters has a non-delta part."""
    if CONDUCTORS and kind == CONDUCTOR:
        return not conductor_is_smooth(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V])
    if ROUGH_DIELECTRICS and kind == ROUGH_DIELECTRIC:
        # By its widths only: at ior 1 the rough lobe is a delta too, and light sampling finds
        # nothing there (eval 0), which costs shadow rays but no bias.
        return not rough_dielectric_is_smooth(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V])
    if PRINCIPLED and kind == PRINCIPLED_KIND:
        return principled_has_density(params[SLOT_ALPHA_U], params[SLOT_ALPHA_V], params[SLOT_METALLIC],
                                      params[SLOT_TRANSMISSION], params[SLOT_CLEARCOAT], params[SLOT_CLEARCOAT_ALPHA])
    if PLASTICS and kind == PLASTIC:
        # The base under the coat always has a density, whatever the coat (a smooth coat's mirror
        # is mixed with it); a black base gives eval 0, which costs shadow rays but no bias.
        return True
    return False
