"""The material table: type codes, the two row layouts, and each material model's rows."""

from ..columns import Column, Layout

# Type codes.
LAMBERTIAN = 0
METAL = 1
DIELECTRIC = 2
DIFFUSE_LIGHT = 3
ISOTROPIC = 4
CODES = {"lambertian": LAMBERTIAN, "metal": METAL, "dielectric": DIELECTRIC, "diffuse_light": DIFFUSE_LIGHT,
         "isotropic": ISOTROPIC}

MATERIAL_I = Layout("mat_i", "int32", [
    Column("kind", 1, "type code: LAMBERTIAN, METAL, DIELECTRIC, DIFFUSE_LIGHT or ISOTROPIC"),
    Column("texture", 1, "texture row of the albedo (emission for a light); a solid white one for a dielectric"),
    Column("reads_uv", 1, "1 if that texture reads surface (u, v): the kernels compute (u, v) only then"),
    Column("normal_map", 1, "texture row of a tangent-space normal map; -1 for none"),
    Column("bump_map", 1, "texture row of a bump map's height (its first channel); -1 for none"),
])
MATERIAL_F = Layout("mat_f", "float64", [
    Column("fuzz", 1, "metal: radius of the sphere the mirror direction is moved within (0 = a perfect mirror)"),
    Column("ior", 1, "dielectric: index of refraction, inside over outside"),
    Column("normal_scale", 1, "the normal map's scale of X and Y (glTF's normalTexture.scale)"),
    Column("bump_height", 1, "world units of height per unit of the bump map's first channel"),
])
MAT_KIND, MAT_TEXTURE, MAT_READS_UV = MATERIAL_I.offsets("kind", "texture", "reads_uv")
MAT_FUZZ, MAT_IOR = MATERIAL_F.offsets("fuzz", "ior")
MAT_NORMAL_MAP, MAT_BUMP_MAP = MATERIAL_I.offsets("normal_map", "bump_map")
MAT_NORMAL_SCALE, MAT_BUMP_HEIGHT = MATERIAL_F.offsets("normal_scale", "bump_height")


def material_rows(model, texture: int) -> tuple[list, list]:
    """The (MATERIAL_I, MATERIAL_F) rows of a material model whose texture is row `texture`
    (`reads_uv` is filled in once every texture is known, see compile.py)."""
    ints = MATERIAL_I.row(kind=CODES[model.type], texture=texture, normal_map=-1, bump_map=-1)
    floats = MATERIAL_F.row(fuzz=getattr(model, "fuzz", 0.0), ior=getattr(model, "ior", 1.0))
    return ints, floats


def phase_function(texture: int) -> tuple[list, list]:
    """The rows of the isotropic material that scatters inside a medium of albedo `texture`."""
    return MATERIAL_I.row(kind=ISOTROPIC, texture=texture, normal_map=-1, bump_map=-1), MATERIAL_F.row(fuzz=0.0, ior=1.0)
