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
  problem with its line and column. Warnings (printed by `rt render` too) do not stop a render:
  a definition nothing uses, and a scene with no `shapes` key, such as an empty file (write
  `shapes: []` for a scene that is only its background).
- **Includes.** `include: [materials.yaml, parts/room.yaml]` merges the named definitions
  (`textures`, `materials`, `media`, `groups`) and the `shapes` of other files into the scene;
  names are relative to the including file's folder. An included file holds only those sections
  (and `include`, `version`, `description`); the camera, image, shutter and background belong to
  the main file. A name defined in two files is an error that gives both places; a file that
  includes itself, directly or through others, is an error; a file included by two others (a
  shared library of materials) is read once. An error inside an included file is reported at
  its own line and column, with the place that included it:
  `parts/room.yaml:4:60: error: shapes[1].material: undefined material 'glas'; did you mean
  'glass'? (included from scene.yaml:2:28)`. Includes nest at most 16 deep, at most 256 files
  and 128 MiB in all; `include: materials.yaml` is one file.
- **Relative file names.** Every file a scene names (includes, image textures, environment
  maps, meshes) follows one rule: a relative name is relative to the folder of the file that
  writes it, so `parts/robot.yaml` names its mesh `arm.obj` for `parts/arm.obj`, as it names its
  textures and includes; an absolute name stands. A name given by `--set` is relative to the main
  file's folder. Before this rule a mesh inside an included file was looked for in the main
  scene's folder; such a scene now names it relative to the included file.
- **Files a scene may read.** Every file a scene names (includes, image textures, environment
  maps, meshes, and those given by `--set`) must lie inside the main scene file's folder, after
  symbolic links are resolved (for standard input, the current folder); anything else is
  refused before it is opened, at its key path, with the same sentence for every kind of file.
  `--allow-path DIR` (repeatable, on `rt render`, `rt validate` and `rt watch`) and
  `allow_paths=[...]` (`rt.render`, `rt.load`, `rt.validate`) add folders. A file named where
  a scene is expected that is not one gets one error that quotes nothing of it.
- **Changing a value from the command line.** `rt render` and `rt validate` take
  `--set KEY.PATH=VALUE` (repeatable): `--set image.samples_per_pixel=64 --set
  materials.glass.ior=1.33 --set 'shapes[2].center=[0, 1, 0]'`. `VALUE` is read as YAML and
  checked like a value in the file; an error names the argument, with the column within it:
  `--set image.width=100.5:1:13: error: image.width: expected a valid integer, found 100.5`.
  Only the path's last key may be new (`--set 'materials.glass={type: dielectric, ior: 1.5}'`
  adds a material); every key before it must be in the scene, or be a key of the format the file
  left out (`camera.vfov=30` without a `camera:`), so a misspelt name is refused with a
  did-you-mean (`materials: no key 'whit' here ...; did you mean 'white'?`) instead of creating
  an entry. A list item must exist. A path has at most 64 parts and 4096 characters, an argument
  at most 1 MiB. `include` cannot be set.
- **Standard input.** `rt render -` and `rt validate -` read the scene from standard input
  (YAML or JSON, detected from the first character, or given by `--format yaml|json`); its
  includes, images and meshes are relative to the current folder. Started with standard input
  closed (`rt validate - <&-`), both say `error: standard input is closed` and exit 2.

**What the JSON Schema checks, and what only `rt validate` can.** The schema in `schemas/`
(for editors) holds every rule JSON Schema can express: types, ranges, whole numbers, required
keys, unknown keys, a `type` that selects one member of each union (so an editor names the
wrong key, not "not valid under any of the given schemas"), a sphere, moving sphere or box
needing a `material` or an `interior`, `aperture` against a positive `defocus_angle`, `height`
against `aspect_ratio`, no zero vector as a disk's normal, a rotation axis or `up`, no zero
scale factor. `rt validate` also checks:

{beyond}

In the tables below, *Default* is the value a key takes when it is left out; **required** keys
have none. A `type` key selects the kind of a definition and must be given (except on a group).
"""
