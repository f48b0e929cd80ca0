"""The material table: type codes, the two row layouts, and each material model's rows."""

import numpy as np

from scenefmt.materials import emits

from ..columns import Column, Layout

# Type codes. The books' materials first; the microfacet families from CONDUCTOR on, so that one
# comparison tells the kernels whether a row has parameters to read.
LAMBERTIAN = 0
METAL = 1
DIELECTRIC = 2
DIFFUSE_LIGHT = 3
ISOTROPIC = 4
CONDUCTOR = 5
ROUGH_DIELECTRIC = 6
THIN_DIELECTRIC = 7
PLASTIC = 8
PRINCIPLED = 9
CODES = {"lambertian": LAMBERTIAN, "metal": METAL, "dielectric": DIELECTRIC, "diffuse_light": DIFFUSE_LIGHT,
         "isotropic": ISOTROPIC, "conductor": CONDUCTOR, "rough_dielectric": ROUGH_DIELECTRIC,
         "thin_dielectric": THIN_DIELECTRIC, "plastic": PLASTIC, "principled": PRINCIPLED}

# A material row's scalar parameters, each a constant or read from a texture at the hit
# (`dispatch.material_at`). What each slot means depends on the kind:
PARAMETER_SLOTS = 8
SLOT_ALPHA_U, SLOT_ALPHA_V = 0, 1  # GGX widths along the frame's s and t (every microfacet kind)
SLOT_METALLIC, SLOT_TRANSMISSION, SLOT_CLEARCOAT, SLOT_CLEARCOAT_ALPHA, SLOT_SPECULAR = 2, 3, 4, 5, 6  # principled
CHANNELS = {"r": 0, "g": 1, "b": 2}
# The model fields whose texture is a row's colour (column `texture`), by kind: at most one each.
COLOUR_KEYS = ("albedo", "emit", "tint", "base_color")

MATERIAL_I = Layout("mat_i", "int32", [
    Column("kind", 1, "type code: LAMBERTIAN, METAL, DIELECTRIC, DIFFUSE_LIGHT, ISOTROPIC, CONDUCTOR, ROUGH_DIELECTRIC, "
                      "THIN_DIELECTRIC, PLASTIC or PRINCIPLED"),
    Column("texture", 1, "texture row of the colour: albedo, emission of a light, tint, base colour; a solid white one "
                         "for a dielectric"),
    Column("reads_uv", 1, "1 if any texture of the material reads surface (u, v): the kernels compute (u, v) only then"),
    Column("param_texture", PARAMETER_SLOTS, "per parameter slot: the texture row it is read from, -1 for a constant"),
    Column("param_channel", PARAMETER_SLOTS, "per parameter slot: the channel of that texture (0 r, 1 g, 2 b)"),
    Column("param_squared", PARAMETER_SLOTS, "per parameter slot: 1 if the texture holds a roughness whose square is "
                                             "the GGX width"),
    Column("normal_map", 1, "texture row of a tangent-space normal map, -1 for none"),
    Column("bump_map", 1, "texture row of a height field, -1 for none"),
    Column("emission", 1, "principled: texture row of the emitted colour, -1 for none (also for a black one)"),
    Column("correlated", 1, "microfacet kinds: 1 for the height-correlated Smith term, 0 for the separable one"),
    Column("nonlinear", 1, "plastic: 1 to account for the colour shift of internal bounces"),
    Column("thin_walled", 1, "principled: 1 for a thin sheet's transmission, 0 for refraction into a solid"),
    Column("one_sided", 1, "diffuse light: 1 if it emits only from the front, along the shape's outward normal "
                           "(`sides: front`), 0 for both faces (the books')"),
])
MATERIAL_F = Layout("mat_f", "float64", [
    Column("fuzz", 1, "metal: radius of the sphere the mirror direction is moved within (0 = a perfect mirror)"),
    Column("ior", 1, "dielectric kinds, plastic and principled: index of refraction, inside over outside"),
    Column("param", PARAMETER_SLOTS, "per parameter slot: its value, or the scale of its texture's channel"),
    Column("eta", 3, "conductor: real part of the index of refraction per channel"),
    Column("k", 3, "conductor: imaginary part of the index of refraction per channel"),
    Column("specular_color", 3, "principled: colour of the dielectric specular reflection"),
    Column("normal_scale", 1, "scale of a normal map's x and y"),
    Column("bump_height", 1, "world units of height per unit of a bump map"),
    Column("emission_strength", 1, "principled: factor of the emitted colour"),
    Column("g", 1, "isotropic (a medium's phase function): Henyey-Greenstein's asymmetry, 0 for the isotropic phase"),
])
MAT_KIND, MAT_TEXTURE, MAT_READS_UV = MATERIAL_I.offsets("kind", "texture", "reads_uv")
MAT_PARAM_TEXTURE, MAT_PARAM_CHANNEL, MAT_PARAM_SQUARED = MATERIAL_I.offsets("param_texture", "param_channel", "param_squared")
MAT_NORMAL_MAP, MAT_BUMP_MAP, MAT_EMISSION, MAT_CORRELATED, MAT_NONLINEAR, MAT_THIN_WALLED = MATERIAL_I.offsets(
    "normal_map", "bump_map", "emission", "correlated", "nonlinear", "thin_walled")
MAT_ONE_SIDED = MATERIAL_I.offset("one_sided")
MAT_FUZZ, MAT_IOR, MAT_PARAM, MAT_ETA, MAT_K = MATERIAL_F.offsets("fuzz", "ior", "param", "eta", "k")
MAT_SPECULAR_COLOR, MAT_NORMAL_SCALE, MAT_BUMP_HEIGHT, MAT_EMISSION_STRENGTH = MATERIAL_F.offsets(
    "specular_color", "normal_scale", "bump_height", "emission_strength")
MAT_G = MATERIAL_F.offset("g")

# The model field read into each parameter slot, per kind (roughness slots come from widths()).
PRINCIPLED_SLOTS = {SLOT_METALLIC: "metallic", SLOT_TRANSMISSION: "transmission", SLOT_CLEARCOAT: "clearcoat",
                    SLOT_SPECULAR: "specular"}


def _slot(value, squared: bool, texture_rows: dict, key: str):
    """(constant or scale, texture row, channel, squared) of one parameter slot whose model value is
    `value`: a number (squared here when it is a roughness), or a ScalarTexture read from
    texture_rows[key]."""
    if isinstance(value, (int, float)):
        return (float(value) ** 2 if squared else float(value)), -1, 0, 0
    return float(value.scale), texture_rows[key], CHANNELS[value.channel], int(squared)


def parameter_slots(model, texture_rows: dict) -> list:
    """The parameter slots of a material model, as `_slot` tuples (unused slots: constant 0)."""
    slots = [(0.0, -1, 0, 0)] * PARAMETER_SLOTS
    kind = model.type
    if kind in ("conductor", "rough_dielectric", "plastic"):
        (u, u_sq), (v, v_sq) = model.widths()
        u_key = "alpha" if model.alpha is not None else "roughness"
        v_key = ("alpha_v" if model.alpha_v is not None else "roughness_v"
                 if model.roughness_v is not None else u_key)
        slots[SLOT_ALPHA_U] = _slot(u, u_sq, texture_rows, u_key)
        slots[SLOT_ALPHA_V] = _slot(v, v_sq, texture_rows, v_key)
    elif kind == "principled":
        slots[SLOT_ALPHA_U] = slots[SLOT_ALPHA_V] = _slot(model.roughness, True, texture_rows, "roughness")
        slots[SLOT_CLEARCOAT_ALPHA] = _slot(model.clearcoat_roughness, True, texture_rows, "clearcoat_roughness")
        for at, key in PRINCIPLED_SLOTS.items():
            slots[at] = _slot(getattr(model, key), False, texture_rows, key)
    return slots


def material_rows(model, texture: int, texture_rows: dict | None = None) -> tuple[list, list]:
    """The (MATERIAL_I, MATERIAL_F) rows of a material model whose colour texture is row `texture`
    and whose other textures (maps, textured parameters, emission) are rows texture_rows[field]
    (`reads_uv` is filled in once every texture is known, see compile.py)."""
    texture_rows = texture_rows or {}
    slots = parameter_slots(model, texture_rows)
    ints = MATERIAL_I.row(
        kind=CODES[model.type], texture=texture,
        param_texture=[s[1] for s in slots], param_channel=[s[2] for s in slots], param_squared=[s[3] for s in slots],
        normal_map=texture_rows.get("normal_map", -1), bump_map=texture_rows.get("bump_map", -1),
        # -1 unless the material sends light: `dispatch.emits` reads this column.
        emission=texture_rows.get("emission", -1) if model.type == "principled" and emits(model) else -1,
        correlated=int(getattr(model, "shadowing", "correlated") == "correlated"),
        nonlinear=int(getattr(model, "nonlinear", False)), thin_walled=int(getattr(model, "thin_walled", False)),
        one_sided=int(getattr(model, "sides", "both") == "front"),
    )
    eta, k = model.index() if model.type == "conductor" else ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    floats = MATERIAL_F.row(
        fuzz=getattr(model, "fuzz", 0.0), ior=getattr(model, "ior", 1.0), param=[s[0] for s in slots], eta=eta, k=k,
        specular_color=getattr(model, "specular_color", (0.0, 0.0, 0.0)), normal_scale=getattr(model, "normal_scale", 1.0),
        bump_height=getattr(model, "bump_height", 1.0), emission_strength=getattr(model, "emission_strength", 0.0),
    )
    return ints, floats


def texture_rows_of(ints) -> list[int]:
    """Every texture row a material row reads (for whether it needs (u, v))."""
    rows = [ints[MAT_TEXTURE], ints[MAT_NORMAL_MAP], ints[MAT_BUMP_MAP], ints[MAT_EMISSION]]
    rows += list(ints[MAT_PARAM_TEXTURE:MAT_PARAM_TEXTURE + PARAMETER_SLOTS])
    return [int(r) for r in rows if r >= 0]


def phase_function(texture: int, g: float = 0.0) -> tuple[list, list]:
    """The rows of the material that scatters inside a medium of albedo `texture`: isotropic for
    g = 0, Henyey-Greenstein's of asymmetry g otherwise (materials/phase.py)."""
    return (MATERIAL_I.row(kind=ISOTROPIC, texture=texture, param_texture=[-1] * PARAMETER_SLOTS, normal_map=-1,
                           bump_map=-1, emission=-1),
            MATERIAL_F.row(fuzz=0.0, ior=1.0, g=g))


# Below this width (a metal's fuzz, a microfacet lobe's alpha) a surface shows a small bright light
# as a small bright highlight or carries it on as a caustic: only a path that happens to leave in
# just the right direction finds it (the rare-path prior of renderer/rare_paths.py).
SHARP_WIDTH = 0.1


def sharp_rows(mat_i: np.ndarray, mat_f: np.ndarray) -> np.ndarray:
    """Which material rows reflect or transmit sharply: glass of every kind, near-mirror metals and
    microfacet lobes narrower than SHARP_WIDTH (a textured width counts as sharp: it may be).
    Plastic's coat reflects a few per cent and is left out."""
    kind = mat_i[:, MAT_KIND]
    alpha = np.where(mat_i[:, MAT_PARAM_TEXTURE + SLOT_ALPHA_U] >= 0, 0.0, mat_f[:, MAT_PARAM + SLOT_ALPHA_U])
    return ((kind == DIELECTRIC) | (kind == THIN_DIELECTRIC) | ((kind == METAL) & (mat_f[:, MAT_FUZZ] < SHARP_WIDTH))
            | (((kind == CONDUCTOR) | (kind == ROUGH_DIELECTRIC) | (kind == PRINCIPLED)) & (alpha < SHARP_WIDTH)))


def emission_rows(mat_i: np.ndarray, mat_f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(texture row, factor) of what each material row emits, as the kernels' `emission_source`
    reads it (meaningful for the rows that emit)."""
    principled = (mat_i[:, MAT_KIND] == PRINCIPLED) & (mat_i[:, MAT_EMISSION] >= 0)
    rows = np.where(principled, mat_i[:, MAT_EMISSION], mat_i[:, MAT_TEXTURE])
    return rows, np.where(principled, mat_f[:, MAT_EMISSION_STRENGTH], 1.0)


def one_sided_rows(mat_i: np.ndarray) -> np.ndarray:
    """Which material rows emit from their front face only (`sides: front`): a light made of
    such a row sends nothing behind it, so a light tree may bound its emission by a cone of
    half-angle pi / 2 about its normal instead of the whole sphere, and its flux is pi A L,
    half a two-sided light's."""
    return mat_i[:, MAT_ONE_SIDED] != 0
