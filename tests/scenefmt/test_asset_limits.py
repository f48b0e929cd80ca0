"""The files a scene names (meshes, images) are bounded before they are read, read once however
they are named, and every failure of their readers is a clear error, never a traceback.

Files are made small, or sparse (os.truncate): a header may promise gigabytes that are not there.
Tests that start a process run `python -m rt` as a user does, some under an address-space limit
(RLIMIT_AS, what `ulimit -v` and `prlimit --as` set), which the memory budget respects.
"""

import io
import os
import resource
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

from scenefmt import bounds, meshfile, meshgen
from scenefmt.diagnostics import SceneError
from scenefmt.meshfile import MeshProblem, read_mesh, read_obj
from scenefmt.validation import loads

MATERIAL = "materials: {m: {type: lambertian, albedo: [0.5, 0.5, 0.5]}}\n"


def mesh_scene(*files: str) -> str:
    return MATERIAL + "shapes:\n" + "".join(
        f"  - {{type: mesh, file: '{f}', material: m, transform: [{{translate: [{3 * i}, 0, 0]}}]}}\n" for i, f in enumerate(files))


def texture_scene(*files: str) -> str:
    return MATERIAL + "shapes:\n" + "".join(
        f"  - {{type: sphere, center: [{3 * i}, 0, 0], radius: 1, material: {{type: lambertian, albedo: {{type: image, file: '{f}'}}}}}}\n"
        for i, f in enumerate(files))


def messages(tmp_path, text: str) -> list[str]:
    with pytest.raises(SceneError) as info:
        loads(text, file=str(tmp_path / "scene.yaml"), base_dir=tmp_path)
    return [d.message for d in info.value.diagnostics]


def rt(tmp_path, *args, address_space=None, patch=None):
    """`python -m rt ARGS` in tmp_path, optionally under an address-space limit (bytes), or with
    Python `patch` run first (to make an allocation fail as it would on a machine short of memory)."""
    if patch is None:
        command = [sys.executable, "-m", "rt", *args]
    else:
        command = [sys.executable, "-c", f"{patch}\nimport sys\nfrom rt.__main__ import run\nsys.argv = ['rt'] + sys.argv[1:]\nrun()",
                   *args]

    def limit():
        if address_space is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))

    started = time.perf_counter()
    result = subprocess.run(command, cwd=tmp_path, capture_output=True, text=True, preexec_fn=limit, timeout=120)
    result.seconds = time.perf_counter() - started
    assert "Traceback" not in result.stderr, result.stderr
    return result


def sparse(path, header: bytes, size: int):
    """A file of `size` bytes that starts with `header`, the rest a hole that takes no disk."""
    path.write_bytes(header)
    os.truncate(path, size)
    return path


# --- OBJ ----------------------------------------------------------------------------------------


def test_a_face_of_too_many_corners_is_refused_at_its_line_before_its_numbers_are_read(tmp_path):
    # The file: one face of 40 million corners (80 MB) took 3.5 GB and 87 s before a
    # traceback. Here 1,000,001 corners (2 MB), one above the limit.
    (tmp_path / "fan.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf " + b"1 " * 1_000_001 + b"\n")
    (message,) = messages(tmp_path, mesh_scene("fan.obj"))
    assert message == "mesh file 'fan.obj' line 4: a face has 1,000,001 corners, more than the 1,000,000 allowed"


def test_triangles_that_repeat_a_corner_are_dropped_as_the_fans_are_cut(monkeypatch):
    monkeypatch.setattr(meshfile, "_CHUNK_TRIANGLES", 4)  # many chunks, each cut and filtered alone
    text = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 1 1 1 1 1 1 1 1\nf 1 2 2 3 4\nf 4 3 2\n"
    mesh = meshfile.check_mesh(read_obj(text))
    # The fans: (1 2 3) (1 3 4); seven of (1 1 1); (1 2 2) (1 2 3) (1 3 4); (4 3 2).
    assert mesh.faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3], [3, 2, 1]]
    assert mesh.degenerate == 8 and mesh.polygons == 4
    # A face of nothing but one repeated corner says so, not "no faces".
    with pytest.raises(MeshProblem, match="every one of the mesh's 7 triangles has zero area"):
        meshfile.check_mesh(read_obj(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 2 2 2 2 2 2 2 2 2\n"))
    # An index out of range is still reported as such, at its triangle.
    with pytest.raises(MeshProblem, match="refers to vertex 9 of 3"):
        meshfile.from_arrays([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[8, 8, 8]])


def test_the_triangles_of_the_fans_are_checked_against_the_memory_budget_before_they_are_made(tmp_path, monkeypatch):
    monkeypatch.setattr(bounds, "physical_memory", lambda: 64 << 20)  # a budget of 48 MiB
    face = b"f " + b"1 2 3 " * 170 + b"\n"  # 510 corners: 508 triangles
    (tmp_path / "many.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + face * 1000)  # 2 MB: reading it fits
    (message,) = messages(tmp_path, mesh_scene("many.obj"))
    assert message.startswith("mesh file 'many.obj': cutting its 1,000 faces into 508,000 triangles needs about 48.4 MiB, "
                              "more than the 48.0 MiB allowed on this machine (75% of its 64.0 MiB of memory)")


def test_an_obj_larger_than_the_budget_allows_is_refused_from_its_size(tmp_path, monkeypatch):
    monkeypatch.setattr(bounds, "physical_memory", lambda: 1 << 30)
    sparse(tmp_path / "big.obj", b"v 0 0 0\n", 100_000_000)  # 100 MB, read at 12 bytes a byte
    (message,) = messages(tmp_path, mesh_scene("big.obj"))
    assert message == ("mesh file 'big.obj': reading this 100,000,000-byte OBJ file needs about 1.1 GiB, more than the "
                       "768.0 MiB allowed on this machine (75% of its 1.0 GiB of memory)")


def test_an_obj_holding_nul_bytes_is_refused_at_its_first_chunk_without_echoing_it(tmp_path):
    sparse(tmp_path / "holes.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 20_000_000)
    (tmp_path / "binary.obj").write_bytes(b"v 0 0 0\n\0SECRET\0\n")
    found = messages(tmp_path, mesh_scene("holes.obj", "binary.obj"))
    assert found == ["mesh file 'holes.obj': not an OBJ text file: byte 33 is a NUL byte (a binary or sparse file)",
                     "mesh file 'binary.obj': not an OBJ text file: byte 9 is a NUL byte (a binary or sparse file)"]


@pytest.mark.slow
def test_a_4_gb_sparse_obj_is_refused_at_once_under_an_address_space_limit(tmp_path):
    (tmp_path / "s.yaml").write_text(mesh_scene("huge.obj"))
    sparse(tmp_path / "huge.obj", b"v 0 0 0\n", 4_000_000_000)
    result = rt(tmp_path, "validate", "s.yaml", address_space=2_000_000_000)
    assert result.returncode == 1
    assert "mesh file 'huge.obj': reading this 4,000,000,000-byte OBJ file needs about 44.7 GiB, more than the" in result.stderr
    assert "this process may still allocate (its address-space limit, ulimit -v)" in result.stderr
    assert result.seconds < 30  # before: 12 s reading it, then a MemoryError traceback


def test_an_obj_material_library_is_named_in_a_warning(tmp_path):
    (tmp_path / "lib.obj").write_bytes(b"# made by hand\nmtllib lib.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n")
    (tmp_path / "slow.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nmtllib a.mtl\nf 1 2 3 \\\n\n")  # the line-by-line reader
    loaded = loads(mesh_scene("lib.obj", "slow.obj"), file=str(tmp_path / "scene.yaml"), base_dir=tmp_path)
    found = [(d.severity, d.path, d.message) for d in loaded.warnings]
    assert found == [
        ("warning", ("shapes", 0, "file"), "mesh file 'lib.obj' names a material library (mtllib, line 2): the OBJ's materials "
         "are not read; the shape's material: is used for every face"),
        ("warning", ("shapes", 1, "file"), "mesh file 'slow.obj' names a material library (mtllib, line 4): the OBJ's materials "
         "are not read; the shape's material: is used for every face"),
    ]


# --- PLY ----------------------------------------------------------------------------------------

PLY_BINARY = (b"ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
              b"element face %d\nproperty list uchar int vertex_indices\nend_header\n")


def test_a_sparse_ply_whose_header_promises_too_much_for_the_budget_is_refused_before_plyfile_reads(tmp_path, monkeypatch):
    import plyfile

    monkeypatch.setattr(bounds, "physical_memory", lambda: 4 << 30)
    monkeypatch.setattr(plyfile.PlyData, "read", lambda *a, **k: pytest.fail("plyfile was asked to read"))
    header = PLY_BINARY % (300_000_000, 1)
    sparse(tmp_path / "big.ply", header, len(header) + 300_000_000 * 12 + 13)  # 3.6 GB of holes: the size fits
    (message,) = messages(tmp_path, mesh_scene("big.ply"))
    assert message == ("mesh file 'big.ply': reading the elements its header declares needs about 10.1 GiB, more than the "
                       "3.0 GiB allowed on this machine (75% of its 4.0 GiB of memory)")


@pytest.mark.slow
def test_a_sparse_ply_is_refused_under_an_address_space_limit(tmp_path):
    # Before: plyfile allocated its 3.35 GiB of records, and a MemoryError traceback.
    header = PLY_BINARY % (300_000_000, 1)
    sparse(tmp_path / "big.ply", header, len(header) + 300_000_000 * 12 + 13)
    (tmp_path / "s.yaml").write_text(mesh_scene("big.ply"))
    result = rt(tmp_path, "validate", "s.yaml", address_space=2_000_000_000)
    assert result.returncode == 1
    assert "mesh file 'big.ply': reading the elements its header declares needs about 10.1 GiB" in result.stderr


@pytest.mark.parametrize("count", [b"-5", b"99999999999", b"256"])
def test_an_ascii_ply_face_length_out_of_range_is_a_clear_error(tmp_path, count):
    (tmp_path / "bad.ply").write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\n"
        b"property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n" + count + b" 0 1 2\n")
    (message,) = messages(tmp_path, mesh_scene("bad.ply"))
    assert message == "mesh file 'bad.ply': the PLY file does not parse: a count or value is out of range for its type"


def malformed_plys() -> dict[str, bytes]:
    v, f = meshgen.icosphere(1)
    header = PLY_BINARY % (12, 20)
    body = np.asarray(v, "<f4").tobytes() + b"".join(b"\x03" + np.asarray(t, "<i4").tobytes() for t in f)
    return {
        "truncated": header + body[:-7],
        "list_too_long": header + body[:12 * 12] + b"\x09" + body[12 * 12 + 1:],
        "bad_type": header.replace(b"property float x", b"property quad x") + body,
        "ascii_words": b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                       b"element face 1\nproperty list uchar int vertex_indices\nend_header\nSECRET 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "ascii_short": b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                       b"element face 2\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
        "list_x": b"ply\nformat ascii 1.0\nelement vertex 3\nproperty list uchar float x\nproperty float y\nproperty float z\n"
                  b"element face 1\nproperty list uchar int vertex_indices\nend_header\n1 0 0 0\n1 1 0 0\n1 0 1 0\n3 0 1 2\n",
    }


@pytest.mark.parametrize("name", sorted(malformed_plys()))
def test_every_failure_of_the_ply_reader_is_a_mesh_problem_that_quotes_nothing_of_the_file(tmp_path, name):
    (tmp_path / "bad.ply").write_bytes(malformed_plys()[name])
    with pytest.raises(MeshProblem) as info:
        read_mesh(tmp_path / "bad.ply")
    assert "SECRET" not in str(info.value)
    (message,) = messages(tmp_path, mesh_scene("bad.ply"))
    assert message.startswith("mesh file 'bad.ply': ")


@pytest.mark.slow
def test_an_ascii_ply_with_a_negative_face_length_is_an_error_in_rt_validate(tmp_path):
    # Before: OverflowError from plyfile, as a traceback.
    (tmp_path / "bad.ply").write_bytes(
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\n"
        b"property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n-5 0 1 2\n")
    (tmp_path / "s.yaml").write_text(mesh_scene("bad.ply"))
    result = rt(tmp_path, "validate", "s.yaml")
    assert result.returncode == 1
    assert "mesh file 'bad.ply': the PLY file does not parse: a count or value is out of range for its type" in result.stderr


# --- one read per file ----------------------------------------------------------------------------


def spellings(tmp_path, name: str) -> list[str]:
    """Eight names of tmp_path/name: relative, dotted, through a folder and back, absolute, a symlink."""
    (tmp_path / "sub").mkdir(exist_ok=True)
    link = tmp_path / f"link-{name}"
    link.symlink_to(tmp_path / name)
    return [name, f"./{name}", f"sub/../{name}", str(tmp_path / name), link.name, f".//{name}", f"sub/./../{name}",
            f"./sub/../{name}"]


def test_a_mesh_named_by_eight_shapes_and_spellings_is_read_once(tmp_path, monkeypatch):
    meshgen.write_obj(tmp_path / "ico.obj", *meshgen.icosphere(4))
    calls = []
    real = meshfile.read_obj
    monkeypatch.setattr(meshfile, "read_obj", lambda *a, **k: calls.append(1) or real(*a, **k))
    loaded = loads(mesh_scene(*spellings(tmp_path, "ico.obj")), file=str(tmp_path / "scene.yaml"), base_dir=tmp_path)
    assert len(calls) == 1
    meshes = {id(member.mesh) for member in loaded.graph.root.members}
    assert len(loaded.graph.root.members) == 8 and len(meshes) == 1
    assert loaded.graph.memory.primitives == 8 * 320 * bounds.MESH_TRIANGLE_BYTES  # each shape still counts its triangles


def test_a_changed_file_is_a_different_file(tmp_path):
    from scenefmt.assets import AssetCache

    path = tmp_path / "a.obj"
    path.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    cache = AssetCache()
    first = cache.get("mesh", path, lambda: read_mesh(path))
    assert cache.get("mesh", tmp_path / "." / "a.obj", lambda: pytest.fail("read again")) is first
    path.write_bytes(b"v 0 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\n")
    os.utime(path, ns=(1, 1))  # another modification time, whatever the clock's resolution
    assert cache.get("mesh", path, lambda: read_mesh(path)).vertices[1, 0] == 2.0
    assert cache.reads == 2


def test_a_texture_named_by_eight_spellings_is_read_and_decoded_once(tmp_path, monkeypatch):
    from PIL import Image

    from renderer import textures
    from scenefmt import graph as graph_module

    Image.fromarray((np.arange(64 * 32 * 3) % 251).astype(np.uint8).reshape(32, 64, 3)).save(tmp_path / "a.png")
    headers, decodes = [], []
    real_header, real_decode = graph_module.image_header, textures.load_image_texels
    monkeypatch.setattr(graph_module, "image_header", lambda p: headers.append(p) or real_header(p))
    monkeypatch.setattr(textures, "load_image_texels", lambda p, c="srgb": decodes.append(p) or real_decode(p, c))
    loaded = loads(texture_scene(*spellings(tmp_path, "a.png")), file=str(tmp_path / "scene.yaml"), base_dir=tmp_path)
    assert len(headers) == 1
    nodes = [n for n in loaded.graph.textures if n.kind == "image"]
    assert len(nodes) == 8
    tables = textures.TextureTables()
    rows = [tables.add(node) for node in nodes]
    assert len(decodes) == 1
    arrays = tables.arrays()
    assert arrays["texels"].shape == (64 * 32, 3)  # one copy of the texels, which every row points at
    assert {tuple(arrays["tex_f"][r, 3:6]) for r in rows} == {(0.0, 64.0, 32.0)}
    # The same file read as linear values is another texture: decoded once more.
    node = nodes[0]
    linear = type(node)(node.model.model_copy(update={"colorspace": "linear"}), None, ("x",), image_path=node.image_path)
    tables.add(linear)
    assert len(decodes) == 2


def test_a_float_texture_named_twice_is_decoded_once_to_find_its_peak(tmp_path, monkeypatch):
    from renderer.film import write_pfm
    from scenefmt import hdr_files

    write_pfm(tmp_path / "sky.pfm", np.full((4, 8, 3), 0.25))
    calls = []
    real = hdr_files._pfm_rgb
    monkeypatch.setattr(hdr_files, "_pfm_rgb", lambda *a: calls.append(1) or real(*a))
    loaded = loads(texture_scene("sky.pfm", "./sky.pfm"), file=str(tmp_path / "scene.yaml"), base_dir=tmp_path)
    assert len(calls) == 1
    assert [n.image_peak for n in loaded.graph.textures if n.kind == "image"] == [0.25, 0.25]


# --- images ----------------------------------------------------------------------------------------


def big_exr_header(path, width: int, height: int):
    """A valid one-channel EXR of 16 x 16 pixels whose header says width x height: its header reads
    as the issue's 847 KB file's did (16384 x 8192), without 2.5 s spent compressing zeros."""
    import OpenEXR

    out = io.BytesIO()
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"Y": np.zeros((16, 16), np.float16)}).write(out)
    raw = bytearray(out.getvalue())
    at = raw.find(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    raw[at:at + 16] = struct.pack("<4i", 0, 0, width - 1, height - 1)
    path.write_bytes(bytes(raw))
    return path


def test_an_exr_too_large_for_the_budget_is_refused_from_its_header_before_decoding(tmp_path, monkeypatch):
    pytest.importorskip("OpenEXR")
    from scenefmt import hdr_files

    monkeypatch.setattr(bounds, "physical_memory", lambda: 4 << 30)
    monkeypatch.setattr(hdr_files, "_exr_rgb_channels", lambda *a: pytest.fail("decoded"))
    big_exr_header(tmp_path / "big.exr", 16384, 8192)
    (message,) = messages(tmp_path, texture_scene("big.exr"))
    assert message == ("image file 'big.exr' is 16384 x 8192 pixels: rendering with it needs about 6.0 GiB, more than the "
                       "3.0 GiB allowed on this machine (75% of its 4.0 GiB of memory)")


@pytest.mark.slow
def test_a_16384_by_8192_exr_is_refused_by_rt_validate_without_decoding_it(tmp_path):
    pytest.importorskip("OpenEXR")
    import OpenEXR

    # The case, a real file: compressed zeros of 16384 x 8192 (287 KB). Before: decoded
    # whole to find its peak (2.6 GB, 5 to 88 s), then refused by the memory estimate.
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"Y": np.zeros((8192, 16384), np.float16)}).write(str(tmp_path / "big.exr"))
    (tmp_path / "s.yaml").write_text(texture_scene("big.exr"))
    result = rt(tmp_path, "validate", "s.yaml", address_space=3_000_000_000)
    assert result.returncode == 1
    assert "image file 'big.exr' is 16384 x 8192 pixels: rendering with it needs about 6.0 GiB, more than" in result.stderr
    assert result.seconds < 20


def test_the_peak_of_a_float_image_is_decoded_within_the_budget(tmp_path, monkeypatch):
    from renderer.film import write_pfm
    from scenefmt.hdr_files import HdrProblem, hdr_header, hdr_peak

    write_pfm(tmp_path / "sky.pfm", np.full((64, 64, 3), 2.0))
    header = hdr_header(tmp_path / "sky.pfm")
    assert (header.width, header.height, header.channels) == (64, 64, 3)
    assert hdr_peak(tmp_path / "sky.pfm", 64 * 64) == 2.0
    with pytest.raises(HdrProblem, match=r"is 64 x 64 pixels of 3 channels: decoding it needs about 0\.1 MiB, more than"):
        hdr_peak(tmp_path / "sky.pfm", 64 * 64, memory=1000)


def malformed_exrs() -> dict[str, bytes]:
    import OpenEXR

    out = io.BytesIO()
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {"RGB": np.ones((64, 64, 3), np.float32)}).write(out)
    raw = out.getvalue()
    smashed = bytearray(raw)
    smashed[400:440] = b"\xff" * 40
    return {"cut_near_end": raw[:-10], "cut_in_half": raw[:len(raw) // 2], "chunk_smashed": bytes(smashed),
            "header_only": raw[:300], "magic_only": raw[:4]}


@pytest.mark.parametrize("name", ["cut_near_end", "cut_in_half", "chunk_smashed", "header_only", "magic_only"])
def test_every_failure_of_the_exr_reader_is_a_clear_error(tmp_path, name):
    pytest.importorskip("OpenEXR")
    from renderer.textures import load_image_texels

    (tmp_path / "bad.exr").write_bytes(malformed_exrs()[name])
    (message,) = messages(tmp_path, texture_scene("bad.exr"))
    assert message.startswith("image file 'bad.exr' is not a readable OpenEXR image (")
    with pytest.raises(ValueError, match="is not a readable OpenEXR image"):
        load_image_texels(tmp_path / "bad.exr")


@pytest.mark.slow
def test_a_truncated_exr_is_an_error_in_rt_validate(tmp_path):
    pytest.importorskip("OpenEXR")
    # Before: ValueError("Invalid part index '0': file has 0 parts.") from the bindings, a traceback.
    (tmp_path / "bad.exr").write_bytes(malformed_exrs()["cut_near_end"])
    (tmp_path / "s.yaml").write_text(texture_scene("bad.exr"))
    result = rt(tmp_path, "validate", "s.yaml")
    assert result.returncode == 1
    assert "image file 'bad.exr' is not a readable OpenEXR image (" in result.stderr


def png_header(width: int, height: int) -> bytes:
    """A PNG's signature and header, then a few bytes of pixel data: Pillow reads its size."""
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) + \
        chunk(b"IDAT", zlib.compress(b"\0" * 1000))


def test_a_png_is_checked_against_the_budget_before_it_is_decoded(tmp_path, monkeypatch):
    from renderer.textures import load_image_texels

    monkeypatch.setattr(bounds, "physical_memory", lambda: 4 << 30)
    (tmp_path / "huge.png").write_bytes(png_header(13000, 13000))  # 169 megapixels
    with pytest.raises(ValueError, match=r"huge\.png: is 13000 x 13000 pixels: decoding it needs about 5\.5 GiB, more than the "
                       r"3\.0 GiB allowed on this machine"):
        load_image_texels(tmp_path / "huge.png")


def test_a_damaged_png_is_a_clear_error_when_decoded(tmp_path):
    from PIL import Image

    from renderer.textures import load_image_texels

    out = io.BytesIO()
    Image.fromarray(np.full((64, 64, 3), 7, np.uint8)).save(out, "PNG")
    raw = out.getvalue()
    at = raw.find(b"IDAT")
    (tmp_path / "crc.png").write_bytes(raw[:at + 4] + b"\xff" * 20 + raw[at + 24:])
    (tmp_path / "cut.png").write_bytes(raw[: len(raw) // 2])
    for name in ("crc.png", "cut.png"):
        with pytest.raises(ValueError, match=f"{name}: cannot read it as an image"):
            load_image_texels(tmp_path / name)


def test_an_image_beyond_pillows_decompression_bomb_limit_says_so(tmp_path):
    (tmp_path / "bomb.png").write_bytes(png_header(16000, 16000))  # 256 megapixels: Pillow refuses to open it
    (message,) = messages(tmp_path, texture_scene("bomb.png"))
    assert message.startswith("image file 'bomb.png' has more pixels than Pillow decodes (")


# --- memory that runs out after the estimate allowed the work ---------------------------------------

OUT_OF_MEMORY = "raise MemoryError('Unable to allocate 3.50 GiB for an array with shape (470000000,) and data type float64')"


def test_a_mesh_read_that_runs_out_of_memory_is_an_error_at_its_file(tmp_path, monkeypatch):
    def short_of_memory(*args, **kw):
        exec(OUT_OF_MEMORY)

    (tmp_path / "a.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    monkeypatch.setattr(meshfile, "check_mesh", short_of_memory)
    (message,) = messages(tmp_path, mesh_scene("a.obj"))
    assert message == "mesh file 'a.obj': not enough memory to read it (about 384 bytes needed)"


def test_flattening_that_runs_out_of_memory_is_a_value_error_with_the_estimate(tmp_path, monkeypatch):
    import renderer.compile
    from renderer.session import flatten_loaded as flatten

    def short_of_memory(graph):
        exec(OUT_OF_MEMORY)

    monkeypatch.setattr(renderer.compile, "compile_scene", short_of_memory)
    loaded = loads(MATERIAL + "shapes: [{type: sphere, center: [0, 0, 0], radius: 1, material: m}]\n")
    with pytest.raises(ValueError, match=r"^not enough memory to flatten the scene \(about [0-9.]+ MiB needed\)$"):
        flatten(loaded)


@pytest.mark.slow
def test_memory_running_out_reaches_the_user_as_one_line(tmp_path):
    (tmp_path / "a.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "s.yaml").write_text(mesh_scene("a.obj"))
    patch = f"import scenefmt.meshfile as m\ndef boom(*a, **k):\n    {OUT_OF_MEMORY}\nm.check_mesh = boom"
    result = rt(tmp_path, "validate", "s.yaml", patch=patch)
    assert result.returncode == 1
    assert "mesh file 'a.obj': not enough memory to read it (about 384 bytes needed)" in result.stderr
    # Flattening (rt render): the allocation that fails is the renderer's.
    patch = f"import renderer.compile as c\ndef boom(*a, **k):\n    {OUT_OF_MEMORY}\nc.compile_scene = boom"
    result = rt(tmp_path, "render", "s.yaml", "-o", "out.png", patch=patch)
    assert result.returncode == 1
    assert result.stderr.strip().splitlines()[-1].startswith("error: s.yaml: not enough memory to flatten the scene (about ")
    assert not (tmp_path / "out.png").exists()
    # Loading the scene itself.
    patch = f"import scenefmt.validation as v\ndef boom(*a, **k):\n    {OUT_OF_MEMORY}\nv.load_source = boom"
    result = rt(tmp_path, "validate", "s.yaml", patch=patch)
    assert result.returncode == 1
    assert result.stderr.strip() == "error: s.yaml: not enough memory to load the scene (3.50 GiB more needed for one array)"


@pytest.mark.slow
def test_the_memory_budget_respects_an_address_space_limit():
    code = ("import resource; resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))\n"
            "from scenefmt import bounds\nprint(bounds.memory_limit() < 1 << 30, bounds.memory_limit_text())")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert result.stdout.startswith("True the "), result.stderr
    assert "this process may still allocate (its address-space limit, ulimit -v)" in result.stdout
