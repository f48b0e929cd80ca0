"""Materials: their table, their flattening, and what each answers the path tracer.

Every material answers the same questions, in the spirit of pbrt's BxDF interface, and the
integrator (`tracing/integrator.trace`) asks only these and names no material:

- `material_at`: its colour at a hit (the albedo, or a light's radiance: `color_at`) and its
  parameters there (roughness, metalness, ...: up to eight slots, constants or read from
  textures), evaluated once and handed to the functions below;
- `emits` / `emitted_at`: whether it emits, and the radiance it sends back along the ray (for
  most kinds `emitted`, their colour); `one_sided`: whether only its front face emits;
- `scatters`: whether it also scatters (a path goes on from an emitter only if it does);
- `sample_bsdf`: a scattered direction, the throughput weight f . cos / pdf, the density per
  solid angle, and whether the lobe is a delta (no density: never light-sampled);
- `eval_bsdf`: f . cos for a given pair of directions, as colour times number;
- `pdf_bsdf`: the density `sample_bsdf` gives a direction, for multiple importance sampling;
- `has_density`: whether the material has a non-delta part at all, which light sampling serves
  whichever lobe `sample_bsdf` chose;
- `reads_uv`: whether the hit's (u, v) is needed at all;
- `has_shading_map` / `shading_frame` / `same_side`: whether a normal or bump map bends its
  shading normal, the bent normal and tangent (shading_normal.py), and whether a direction
  lies on the same side of the surface as of the bent normal's plane (else it carries nothing).

Each dispatches by kind to the material's own functions below. Lambertian and isotropic have a
density, so light sampling and MIS serve them; metal and dielectric are deltas; a diffuse
light emits and absorbs. Adding a material means a model in `scenefmt/materials.py`, a type
code, its parameters in `MATERIAL_F`, a case in `material_rows` and a case in each of the functions
above that it answers differently from "black, delta".

The direction of each material is a function of its random inputs (`lambertian_direction`,
`metal_direction`, `dielectric_direction`), so tests can check each on chosen inputs;
`sample_bsdf` draws those inputs.
"""

from .books import (ISOTROPIC_DENSITY, dielectric_direction, lambertian_direction, lambertian_value,
                    metal_direction, random_unit_vector, reflect)
from .dispatch import (MICROFACETS, emission_source, NO_PARAMETERS, is_anisotropic, NO_TANGENT, color_at, emits, emitted, emitted_at, emitting_rows, eval_bsdf, has_density, is_zero,
                       material_at, one_sided, pdf_bsdf, reads_uv, sample_bsdf, scatters)
from .fresnel import fresnel_dielectric
from .shading_normal import has_shading_map, same_side, shading_frame
from .table import (CONDUCTOR, PLASTIC, PRINCIPLED, ROUGH_DIELECTRIC, THIN_DIELECTRIC, CODES, DIELECTRIC, DIFFUSE_LIGHT, ISOTROPIC, LAMBERTIAN, MAT_FUZZ, MAT_IOR,
                    MAT_KIND, MAT_READS_UV, MAT_TEXTURE, MATERIAL_F, MATERIAL_I, METAL, material_rows, one_sided_rows, phase_function)

__all__ = [
    "NO_PARAMETERS", "NO_TANGENT", "material_at", "has_density", "CONDUCTOR", "PLASTIC", "PRINCIPLED", "ROUGH_DIELECTRIC",
    "THIN_DIELECTRIC", "CODES", "DIELECTRIC", "DIFFUSE_LIGHT", "ISOTROPIC", "ISOTROPIC_DENSITY", "LAMBERTIAN", "MAT_FUZZ", "MAT_IOR", "MAT_KIND",
    "MAT_READS_UV", "MAT_TEXTURE", "MATERIAL_F", "MATERIAL_I", "METAL", "color_at", "dielectric_direction", "emits", "emitted",
    "emitted_at", "emitting_rows", "eval_bsdf", "fresnel_dielectric", "is_zero", "lambertian_direction", "lambertian_value", "material_rows",
    "metal_direction", "pdf_bsdf", "phase_function", "random_unit_vector", "reads_uv", "reflect", "sample_bsdf", "scatters",
    "has_shading_map", "same_side", "shading_frame", "MICROFACETS", "is_anisotropic", "emission_source", "one_sided", "one_sided_rows",
]
