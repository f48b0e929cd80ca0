"""The hand-written introduction of the format reference; everything after it comes from the models."""

INTRODUCTION = """\
# Scene file format reference

<!-- Generated from the models in scenefmt/ by `python -m scenefmt.docgen`; do not edit by hand. -->

A scene file describes everything `rt` needs to render one image: the camera, the image size
and sampling, the shutter interval, the background, and the shapes with their materials,
textures and participating media. It is written in YAML or JSON; both syntaxes load to the
same models, so anything below can be written either way (the examples are YAML).

```yaml
# yaml-language-server: $schema=../schemas/scene.schema.json
version: 1
camera: {look_from: [0, 0, 9], look_at: [0, 0, 0], vfov: 80}
materials:
  red: {type: lambertian, albedo: [1.0, 0.2, 0.2]}
shapes:
  - {type: sphere, center: [0, 0, 0], radius: 1, material: red}
```

- **Version.** Every file should start with `version: 1`, the version of the format this
  release reads. Keys not listed below are errors, so a misspelt key never goes unnoticed.
- **Named definitions.** Textures, materials, media and groups of shapes are defined once,
  by name, under `textures:`, `materials:`, `media:` and `groups:`, and referred to by that
  name wherever they are used. Wherever a name is accepted, an inline definition is accepted
  too (`material: {type: metal, fuzz: 0.1}` instead of `material: brass`). A name starts with
  a letter or `_`, continues with letters, digits, `_`, `.` or `-`, and is at most
  {name_max} characters long.
- **Colours** are linear RGB triples `[r, g, b]` with components >= 0; reflectances
  (albedos) normally stay within 0..1, while emitters may exceed 1 (`emit: [15, 15, 15]`).
- **Angles** are in degrees.
- **Transforms.** A shape's (or an instance's) `transform:` is an ordered list of steps,
  applied first to last: `[{rotate: {axis: y, degrees: 15}}, {translate: [265, 0, 295]}]`
  rotates, then moves.
- **Editor support.** A first line `# yaml-language-server: $schema=...` pointing at the
  JSON Schema (`schemas/scene.schema.json`; the path is relative to the scene file) gives
  completion, hover help and live checking in editors that use the YAML language server;
  `rt schema` prints the schema.
- **Checking.** `rt validate scene.yaml` checks a file without rendering it and reports every
  problem with its line and column.

In the tables below, *Default* is the value a key takes when it is left out; **required** keys
have none. A `type` key selects the kind of a definition and must be given (except on a group).
"""
