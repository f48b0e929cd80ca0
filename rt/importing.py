"""`rt import`: a glTF model written out as a scene file, its meshes and its images.

Files are written so that a failure leaves nothing half-done: the meshes and images go into a new
temporary folder beside the scene, the scene text is built and checked by our models before
anything is moved, then the folder takes its place and the scene file is written last (through a
temporary name and a rename). Nothing is written outside the scene file's folder, and neither the
model nor a file it names is ever replaced.
"""

from __future__ import annotations

import os
import re
import secrets
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

from scenefmt.diagnostics import quote_text
from scenefmt.gltf_read import GltfProblem


@dataclass
class ImportResult:
    scene: Path
    assets: Path
    meshes: int
    triangles: int
    images: int
    warnings: list


def _prefix_of(stem: str) -> str:
    """A name prefix from the scene file's stem ('' when the stem makes no name)."""
    text = re.sub(r"[^A-Za-z0-9_\-]", "_", stem)[:24]
    return f"{text}_" if text and re.match(r"^[A-Za-z_]", text) else ""


def import_gltf(model, out, *, part: bool = False, prefix: str | None = None, width: int = 640, samples: int = 64,
                lumens_per_watt: float = 683.0, force: bool = False) -> ImportResult:
    """Write the scene of glTF file `model` to `out` (YAML) and its meshes and images to
    `<out stem>_assets/` beside it; raises GltfProblem with one sentence on any failure, having
    written nothing."""
    from scenefmt.gltf_read import load
    from scenefmt.gltf_scene import ImportOptions, plan_import

    model, out = Path(model), Path(out)
    if out.suffix.lower() not in (".yaml", ".yml"):
        raise GltfProblem("the scene is written as YAML: give -o a name ending in .yaml")
    folder = out.parent if str(out.parent) else Path(".")
    if not folder.is_dir():
        raise GltfProblem(f"the folder of {quote_text(str(out)[:200])} does not exist")
    if not (lumens_per_watt > 0 and lumens_per_watt < 1e12):
        raise GltfProblem("--lumens-per-watt must be a positive number")
    stem = out.stem
    assets_name = f"{stem}_assets"
    assets = folder / assets_name
    try:
        model_real = model.resolve(strict=True)
    except (OSError, RuntimeError):
        raise GltfProblem(f"the model {quote_text(str(model)[:200])} cannot be found") from None
    out_real = out.resolve()
    if out_real == model_real:
        raise GltfProblem("the scene would overwrite the model itself: choose another -o")
    if model_real.is_relative_to(assets.resolve()):
        raise GltfProblem(f"the model lies inside {quote_text(assets_name)}, the folder the import writes: move it or choose another -o")
    if not force and (out.exists() or out.is_symlink()):
        raise GltfProblem(f"{quote_text(str(out)[:200])} exists: give --force to replace it")
    if not force and (assets.exists() or assets.is_symlink()):
        raise GltfProblem(f"the folder {quote_text(assets_name)} exists: give --force to replace it")
    if force and assets.is_symlink():
        raise GltfProblem(f"{quote_text(assets_name)} is a symbolic link: remove it first")

    doc = load(model)
    options = ImportOptions(prefix=_prefix_of(stem) if prefix is None else prefix, assets=assets_name, part=part,
                            width=width, samples=samples, lumens_per_watt=lumens_per_watt, source_name=quote_text(model.name))
    plan = plan_import(doc, options)
    for path in [Path(p) for p in plan.images] + [Path(m.path) for m in plan.meshes]:
        if (folder / path).resolve() in _model_files(doc, model_real):
            raise GltfProblem("the import would overwrite a file the model names: choose another -o")
    text = plan.header + _scene_text(plan.data)

    tmp = Path(tempfile.mkdtemp(prefix=f".{assets_name}.", dir=folder))
    try:
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o777 & ~umask)  # mkdtemp's folder is private; the assets are as shareable as the scene
        from scenefmt.ply_writing import write_ply

        for mesh in plan.meshes:
            with open(tmp / Path(mesh.path).name, "xb") as fh:
                write_ply(fh, mesh.positions, mesh.faces, mesh.normals, mesh.uvs)
        for path, data in plan.images.items():
            with open(tmp / Path(path).name, "xb") as fh:
                fh.write(data)
        old = None
        if assets.exists():
            old = folder / f".{assets_name}.old-{secrets.token_hex(4)}"
            os.replace(assets, old)
        os.replace(tmp, assets)
        try:
            _write_text_atomic(out, text)
        except BaseException:
            shutil.rmtree(assets, ignore_errors=True)
            if old is not None:
                os.replace(old, assets)
            raise
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except OSError as exc:
        raise GltfProblem(f"cannot write the import: {exc.strerror or type(exc).__name__}") from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return ImportResult(out, assets, len(plan.meshes), plan.triangles, len(plan.images), plan.warnings)


def _model_files(doc, model_real: Path) -> set:
    """The model and every file its buffers and images name (resolved): none may be written over."""
    files = {model_real}
    for item in list(doc.gltf.buffers or []) + list(doc.gltf.images or []):
        uri = getattr(item, "uri", None)
        if isinstance(uri, str) and not uri[:5].lower() == "data:":
            from urllib.parse import unquote

            try:
                files.add((doc.folder / unquote(uri)).resolve())
            except (OSError, RuntimeError, ValueError):
                pass
    return files


def _scene_text(data: dict) -> str:
    """The scene's YAML, after our models have checked it (a failure here is rt's bug, said plainly)."""
    from pydantic import ValidationError

    from scenefmt.scene import Scene
    from scenefmt.writing import dumps

    try:
        scene = Scene.model_validate(data)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise GltfProblem(f"the imported scene does not pass rt's checks at {where}: {first['msg']}") from None
    return dumps(scene)


def _write_text_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        with open(tmp, "x", encoding="utf-8") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
