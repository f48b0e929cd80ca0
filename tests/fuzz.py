"""A mutation fuzzer over the book scenes, saved render states, hostile paths, includes, `--set`,
standard input, mesh and image files, and `rt render`'s outputs.

    python tests/fuzz.py --cases 10000 --seed 1             # validation, a tenth of accepted scenes rendered
    python tests/fuzz.py --cases 2000 --render-share 1       # render every accepted scene (4x4, 1-2 spp)
    python tests/fuzz.py --cases 500 --no-render --show 5    # validation only; print 5 rejections
    python tests/fuzz.py --cases 500 --surfaces set,stdin    # only these kinds of case
    python tests/fuzz.py --seed 1 --case 190 --keep /tmp/c   # replay case 190, its files left in /tmp/c

Each case is one of:

- a book scene from `scenes/`, mutated 1 to 4 times: keys deleted, duplicated or renamed (typos,
  control characters), values replaced by extreme and degenerate numbers (0, -0, subnormals,
  1e-300, 1e300, inf, NaN, 2^64, a 500-digit integer) or by values of another type, references
  broken, hostile transforms added (huge, tiny, singular, 256 steps), image paths made hostile
  (`/dev/zero`, a FIFO, a directory, a symlink loop, a NUL byte, 5000 characters), instances
  nested to explode, colours pushed beyond any radiance; or its text truncated, spliced with
  random bytes, control characters or alias bombs. It is loaded in-process with
  `scenefmt.validation.loads`; an accepted scene may be rendered tiny (4x4 pixels, 1 or 2
  samples, depth 2 to 4) with `renderer.compile.compile_scene` and `renderer.render.render`.
- a saved render state, corrupted (truncated, bytes flipped, arrays of other shapes or types,
  NaN, negative or huge sample counts, wrong metadata, a compressed bomb), loaded with
  `renderer.state.load_state`.
- a hostile scene path (device, FIFO, directory, symlink loop, NUL byte, name too long).
- includes: a book scene whose `include:` names mutated parts, another whole scene, a file that is
  not a scene holding a secret marker (a shadow line, an .env, a key), binary bytes, itself, a
  cycle, chains 3 to 40 deep, 257 or 1000 files, a string or a number instead of a list, paths
  leaving the folder, symlinks (to the secret, /dev/zero, a loop, a FIFO, a folder), hostile
  names, sparse files beyond the size bound; loaded with `scenefmt.validation.load_source`.
- `--set`: key paths from the scene, misspelt, with huge indices, 100 to 10,000 parts, control
  characters, empty parts; values that are recursive aliases (`&r [*r]`), alias bombs, huge
  numbers, 100,000 levels of brackets, tags, syntax errors, 300,000-item lists; 1 to 1001 of
  them, applied by `load_source(path, overrides)` as `rt validate --set` does.
- standard input: scene bytes (mutated, empty, binary, UTF-16, truncated, a few bytes at a time,
  endless) read by `load_source("-")`, and a closed standard input (`sys.stdin` None, as with
  `<&-`; a closed stream; a read that fails).
- meshes: OBJ and PLY (ASCII, both binary orders) files generated small and mutated (negative,
  huge and mismatched counts; faces of up to a million corners; indices out of range, negative,
  huge; NaN and infinite vertices; truncated; flipped bytes; sparse files of 4 MiB to 4 GiB;
  `mtllib` paths; the secret file as a mesh; wrong suffixes), named by a `mesh` shape.
- images: PNG (8 and 16 bits, grey, palette, alpha), PFM and EXR (half and float; RGB, RGBA, Y,
  Z only) files generated small and mutated (truncated; a header claiming 30000 x 30000 to 2^32
  pixels; NaN, infinite and negative texels; flipped and random bytes; wrong suffixes; sparse
  files beyond the size bound; a folder), used as an image texture, as the background, or both;
  an accepted image's texels are then decoded with `renderer.textures.load_image_texels`.
- outputs: `rt render` options (--output, --hdr, --noise-map, --save-state, --resume) that name
  the scene's inputs (its texture, environment map, include, mesh, the scene itself) directly,
  through `./` and `sub/..`, a symbolic link or a hard link, run through `rt.render_job.prepare`
  and then `render_prepared` (a share of them) or `rt.outputs.write_outputs` with a made-up film.

Every case runs under a time limit (a hang is a case that exceeds it). The counts printed:
cases, accepted, rejected with a position (file:line:col), rejected without one, tracebacks
(any exception other than the documented refusal), non-finite pixels or noise figures (or
texels), hangs, diagnostics that print a raw control character, diagnostics that show the
secret marker (echoed file contents), and inputs whose bytes a render's outputs changed; then
the slowest and the largest (peak Python memory, traced) rejections and each distinct failure
(its exception and innermost frame) with a reproduction. The exit status is 1 if any of these
failures was seen. `run(...)` does the same from Python (tests/test_fuzz.py).

Case k draws from its own random stream, so `--case k` replays it alone and `--keep DIR` leaves
its files in DIR. `main` caps the process's address space (`--memory-limit`, 3 GiB), so a case
that asks for too much ends in a MemoryError (a traceback) instead of taking the machine.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import io
import json
import math
import os
import random
import re
import shutil
import signal
import sys
import tempfile
import time
import traceback
import tracemalloc
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import yaml  # noqa: E402

from scenefmt.diagnostics import SceneError  # noqa: E402
from scenefmt.loading import parse_file  # noqa: E402
from scenefmt.validation import loads  # noqa: E402

SCENES = ROOT / "scenes"
_RAW_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")

EXTREME_NUMBERS = [
    0, -0.0, 5e-324, 1e-320, 1e-300, 1e-60, 1e-51, 1e-50, 1e-12, 1e12, 1e13, 1e50, 1e51, 1e60, 1e300, 1.7e308,
    -1e300, -1, -1e-300, float("inf"), float("-inf"), float("nan"), 2**31, 2**63 - 1, 2**63, 2**64, 10**500,
    -(10**40), 0.5, 1, 3, 32768, 32769, 1_000_000, 1_000_001, 10_000, 10_001, 1.0000001,
]
SWAPPED_VALUES = ["text", "", [], {}, True, False, None, [1, 2], [[1, 2, 3]], {"type": "sphere"}, "\x1b[31mred", [0, 0, 0]]
NAMES = ["", "x", "\x1b[2J", "a\u202eb", "ground", "light", "g0", "type", "<<", "1abc", "a" * 70, "nul\x00l", "mat.1"]


class Hang(Exception):
    """A case ran past its time limit."""


def _alarm(signum, frame):
    raise Hang()


@dataclass
class Counts:
    cases: int = 0
    accepted: int = 0
    rejected_with_position: int = 0
    rejected_without_position: int = 0
    tracebacks: int = 0
    non_finite: int = 0
    hangs: int = 0
    raw_control: int = 0
    rendered: int = 0
    too_big_to_render: int = 0  # accepted, but more placements than a tiny render should flatten
    states: int = 0
    states_accepted: int = 0
    paths: int = 0
    echoed: int = 0  # a diagnostic that shows the contents of a file the scene named (the SECRET marker)
    overwritten: int = 0  # an input file whose bytes a render's outputs changed
    decode_refused: int = 0  # accepted by validation, its image then refused when decoded (the documented ValueError)
    outputs: int = 0
    surfaces: dict = field(default_factory=dict)  # cases per surface
    surface: str = ""  # the surface of the case running
    fuzzer_errors: list = field(default_factory=list)  # cases the fuzzer failed to build (its own bugs, not rt's)
    slow_traced: int = 0  # cases past the limit under memory tracing, run again untraced (a hang only if still too slow)
    native_output: int = 0  # cases where a C library wrote to the terminal itself (not a failure; counted)
    native_examples: dict = field(default_factory=dict)
    slowest: list = field(default_factory=list)  # (seconds, label, first message)
    largest: list = field(default_factory=list)  # (peak bytes, label, first message)
    failures: list = field(default_factory=list)  # (label, what, detail)
    shown: list = field(default_factory=list)

    @property
    def bad(self) -> int:
        return self.tracebacks + self.non_finite + self.hangs + self.raw_control + self.echoed + self.overwritten

    def note_rejection(self, seconds: float, peak: int, label: str, message: str) -> None:
        self.slowest = sorted(self.slowest + [(seconds, label, message)], reverse=True)[:5]
        self.largest = sorted(self.largest + [(peak, label, message)], reverse=True)[:5]

    def report(self) -> str:
        lines = [
            f"cases: {self.cases}",
            f"accepted: {self.accepted} (rendered: {self.rendered}; too big to render tiny: {self.too_big_to_render})",
            f"rejected with a position: {self.rejected_with_position}",
            f"rejected without a position: {self.rejected_without_position}",
            f"tracebacks: {self.tracebacks}",
            f"non-finite pixels or noise: {self.non_finite}",
            f"hangs: {self.hangs} (and {self.slow_traced} past the limit only under memory tracing, within it untraced)",
            f"raw control characters in messages: {self.raw_control}",
            f"echoed file contents: {self.echoed}",
            f"inputs overwritten: {self.overwritten}",
            f"(of the cases: {self.states} saved states, {self.states_accepted} of them accepted; {self.paths} hostile paths;"
            f" {self.decode_refused} accepted images refused when decoded)",
            "cases per surface: " + ", ".join(f"{k} {v}" for k, v in sorted(self.surfaces.items())),
            f"cases where a C library wrote to standard error itself: {self.native_output}",
        ]
        lines += [f"  {label}: {first}" for label, first in list(self.native_examples.values())[:5]]
        lines.append("slowest rejections:")
        lines += [f"  {s * 1000:8.1f} ms  {label}: {msg[:150]}" for s, label, msg in self.slowest]
        lines.append("largest rejections (peak traced Python memory):")
        lines += [f"  {peak / 2**20:8.1f} MiB  {label}: {msg[:150]}" for peak, label, msg in self.largest]
        for error in self.fuzzer_errors[:5]:
            lines.append(f"FUZZER ERROR (not counted against rt) in {error}")
        distinct = self.distinct()
        if distinct:
            lines.append(f"distinct failures: {len(distinct)} (of {len(self.failures)})")
        for (what, where), (count, label, detail) in list(distinct.items())[:40]:
            lines.append(f"FAILURE {what} at {where}, {count} case{'s' if count != 1 else ''}; first in {label}:\n{detail}")
        return "\n".join(lines)

    def distinct(self) -> dict:
        """The failures grouped by what and where: {(what, where): (count, first label, first detail)}."""
        groups: dict = {}
        for label, what, detail, surface in self.failures:
            key = (what, _where(what, surface, detail))
            count, first, shown = groups.get(key, (0, label, detail))
            groups[key] = (count + 1, first, shown)
        return groups


def _where(what: str, surface: str, detail: str) -> str:
    """Where a failure happened: for a traceback, its exception and the project's innermost frame;
    otherwise the surface."""
    if what.startswith("traceback"):
        frames = re.findall(r'File "([^"]+)", line (\d+), in (\S+)', detail)
        ours = [f for f in frames if f[0].startswith(str(ROOT)) and "/tests/" not in f[0]]
        frame = ours[-1] if ours else frames[-1] if frames else ("?", "?", "?")
        error = next((line.split(":")[0] for line in reversed(detail.splitlines()) if re.match(r"^[A-Za-z_.]+(Error|Exception|Exit|Interrupt)\b", line)), "?")
        return f"{error} in {os.path.relpath(frame[0], ROOT)}:{frame[1]} ({frame[2]})"
    return f"the {surface} surface"


# ----------------------------------------------------------------------------------------------
# Scene mutations, on plain data


def _containers(data, path=()):
    """Every dict and list in `data`, with its key path."""
    yield path, data
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        if isinstance(value, (dict, list)):
            yield from _containers(value, path + (key,))


def _leaves(data, path=()):
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        if isinstance(value, (dict, list)):
            yield from _leaves(value, path + (key,))
        else:
            yield data, key, value


def _shapes(data) -> list:
    shapes = [s for s in data.get("shapes", []) if isinstance(s, dict)] if isinstance(data.get("shapes"), list) else []
    groups = data.get("groups")
    if isinstance(groups, dict):
        for g in groups.values():
            if isinstance(g, dict) and isinstance(g.get("shapes"), list):
                shapes += [s for s in g["shapes"] if isinstance(s, dict)]
    return shapes


def hostile_transform(rng: random.Random) -> list:
    kind = rng.randrange(8)
    if kind == 0:
        return [{"scale": rng.choice([1e-40, 1e-30, 1e-20])} for _ in range(rng.randint(2, 4))]
    if kind == 1:
        return [{"scale": rng.choice([1e20, 1e30, 1e40])} for _ in range(rng.randint(2, 4))]
    if kind == 2:
        return [{"matrix": [[rng.choice([0, 1, 1e50, 1e-50, -1e45]) for _ in range(4)] for _ in range(3)]}]
    if kind == 3:
        return [{"rotate": {"axis": "y", "degrees": 1.0}}] * 256
    if kind == 4:
        return [{"rotate": {"axis": [rng.choice([0, 1e-50, 1e50]) for _ in range(3)], "degrees": rng.choice([1e50, 90, -1e-50])}}]
    if kind == 5:
        return [{"scale": [1e-7, 1, 1]}, {"rotate": {"axis": "z", "degrees": 45}}, {"scale": [1e-7, 1, 1]}]
    if kind == 6:
        return [{"translate": [rng.choice([1e50, -1e50, 1e-50]) for _ in range(3)]}, {"scale": 1e15}]
    return [{"matrix": [[1, 2, 3, 0], [2, 4, 6, 0], [0, 0, 1, 0]]}]


def mutate(data, rng: random.Random, hostile_dir: Path) -> str:
    """Change `data` in place one way; the name of the mutation."""
    containers = list(_containers(data))
    kind = rng.randrange(16)
    if kind >= 13:  # a change that may well keep the scene valid: a number moved, a transform added
        leaves = [(p, k, v) for p, k, v in _leaves(data) if isinstance(v, (int, float)) and not isinstance(v, bool)]
        if kind < 15 and leaves:
            parent, key, value = rng.choice(leaves)
            parent[key] = type(value)(value * rng.choice([-1, 0, 0.5, 2, 10, 0.1])) if isinstance(value, float) else value
        elif _shapes(data):
            rng.choice(_shapes(data))["transform"] = [rng.choice([{"scale": rng.uniform(0.1, 3)}, {"rotate": {"axis": [1, 1, 0], "degrees": rng.uniform(-360, 360)}},
                                                                  {"translate": [rng.uniform(-5, 5), 0, 1]}, {"matrix": [[1, 0.5, 0, 0], [0, 1, 0, 1], [0, 0, 1, 0]]}])
                                                      for _ in range(rng.randint(1, 3))]
        return "tweak"
    if kind == 0:  # delete a key or an item
        dicts = [c for _, c in containers if isinstance(c, dict) and c] + [c for _, c in containers if isinstance(c, list) and c]
        if dicts:
            c = rng.choice(dicts)
            if isinstance(c, dict):
                del c[rng.choice(list(c))]
            else:
                del c[rng.randrange(len(c))]
        return "delete"
    if kind == 1:  # rename a key
        dicts = [c for _, c in containers if isinstance(c, dict) and c]
        if dicts:
            c = rng.choice(dicts)
            key = rng.choice(list(c))
            new = rng.choice(NAMES + [key[:-1], key + "s", key.upper(), key[::-1]])
            c[new] = c.pop(key)
        return "rename"
    if kind == 2 or kind == 3:  # an extreme number
        leaves = list(_leaves(data))
        if leaves:
            parent, key, _ = rng.choice(leaves)
            parent[key] = rng.choice(EXTREME_NUMBERS)
        return "number"
    if kind == 4:  # a value of another type
        leaves = list(_leaves(data))
        if leaves:
            parent, key, _ = rng.choice(leaves)
            parent[key] = copy.deepcopy(rng.choice(SWAPPED_VALUES))
        return "type"
    if kind == 5:  # a broken reference
        refs = [(p, k) for p, k, v in _leaves(data) if isinstance(v, str) and k in ("material", "albedo", "emit", "interior", "group", "even", "odd")]
        if refs:
            p, k = rng.choice(refs)
            p[k] = rng.choice(NAMES + ["missing", "earthmap", "pertext"])
        return "reference"
    if kind == 6:  # a hostile transform
        shapes = _shapes(data)
        if shapes:
            rng.choice(shapes)["transform"] = hostile_transform(rng)
        return "transform"
    if kind == 7:  # a hostile image path
        paths = ["/dev/zero", "/dev/null", str(hostile_dir / "fifo"), str(hostile_dir / "loop"), str(hostile_dir),
                 "a\x00b.png", "x" * 5000 + ".png", "../" * 40 + "etc/passwd", str(hostile_dir / "huge.png"), "earthmap.png"]
        textures = data.setdefault("textures", {}) if isinstance(data, dict) else {}
        if isinstance(textures, dict):
            textures["hostile"] = {"type": "image", "file": rng.choice(paths)}
            mats = data.get("materials")
            if isinstance(mats, dict) and mats:
                name = rng.choice(list(mats))
                if isinstance(mats[name], dict) and "albedo" in mats[name] or rng.random() < 0.5:
                    mats[name] = {"type": "lambertian", "albedo": "hostile"}
        return "path"
    if kind == 8:  # instances nested to explode
        levels, fan = rng.randint(2, 9), rng.randint(2, 12)
        groups = data.setdefault("groups", {})
        if isinstance(groups, dict):
            groups["f0"] = {"shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"type": "lambertian"}}]}
            for i in range(1, levels + 1):
                groups[f"f{i}"] = {"shapes": [{"type": "instance", "group": f"f{i - 1}", "transform": [{"translate": [k, 0, 0]}]} for k in range(fan)]}
            if isinstance(data.get("shapes"), list):
                data["shapes"].append({"type": "instance", "group": f"f{levels}"})
        return "explosion"
    if kind == 9:  # image settings
        image = data.setdefault("image", {})
        if isinstance(image, dict):
            key = rng.choice(["width", "height", "aspect_ratio", "samples_per_pixel", "max_depth", "seed"])
            image[key] = rng.choice(EXTREME_NUMBERS + ["1:0", "16:9", "0:0", "1e400:1", "1:" + "0" * 400 + "1"])
            if key == "height":
                image.pop("aspect_ratio", None)
        return "image"
    if kind == 10:  # colours
        leaves = [(p, k) for p, k, v in _leaves(data) if isinstance(p, list) and len(p) == 3 and isinstance(v, (int, float))]
        if leaves:
            p, k = rng.choice(leaves)
            p[k] = rng.choice([1e12, 1e13, 1e300, 1.0000001, 2, 1e6, -0.0])
        return "colour"
    if kind == 11:  # deep nesting
        leaves = list(_leaves(data))
        if leaves:
            parent, key, value = rng.choice(leaves)
            for _ in range(rng.choice([10, 63, 65, 200])):
                value = [value]
            parent[key] = value
        return "nesting"
    # a duplicated section, under another spelling
    if isinstance(data, dict) and data:
        key = rng.choice(list(data))
        data[key + rng.choice(["", "_", "\x07"])] = copy.deepcopy(data[key])
    return "duplicate"


def text_mutation(text: str, syntax: str, rng: random.Random) -> tuple[str, str]:
    kind = rng.randrange(6)
    if kind == 0 and text:
        return text[: rng.randrange(len(text))], "truncate"
    if kind == 1 and text:
        i = rng.randrange(len(text))
        return text[:i] + rng.choice(["\x00", "\x1b[2J", "\ufeff", "\u202e", "\t", "{", "]", ":", "'", '"', "\\", "&a", "*a", "!!python/object:os.system"]) + text[i:], "splice"
    if kind == 2 and syntax == "yaml":
        lines = text.splitlines()
        if lines:
            i = rng.randrange(len(lines))
            lines.insert(i, lines[i])  # a duplicated key, most often
        return "\n".join(lines), "duplicate-line"
    if kind == 3 and syntax == "yaml":
        levels = rng.randint(5, 40)
        bomb = "a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "\n".join(
            f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}]" for i in range(1, levels))
        return bomb + "\n" + text, "alias-bomb"
    if kind == 4 and syntax == "yaml":
        chain = "b0: &b0 [1]\n" + "\n".join(f"b{i}: &b{i} [[[[[[[[[[*b{i - 1}]]]]]]]]]]" for i in range(1, rng.randint(5, 200)))
        return chain + "\n" + text, "alias-depth"
    if text:
        i = rng.randrange(len(text))
        return text[:i] + "".join(chr(rng.randrange(0, 0x3000)) for _ in range(rng.randint(1, 8))) + text[i:], "random-chars"
    return text, "none"


def dump(data, syntax: str) -> str:
    if syntax == "json":
        return json.dumps(data, indent=1, allow_nan=True)
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=4096)


# ----------------------------------------------------------------------------------------------
# Saved states


def state_case(rng: random.Random, work: Path):
    import numpy as np

    from renderer.film import Film
    from renderer.state import STATE_VERSION, RenderKey, save_state

    key = RenderKey("ab" * 32, 4, 4, 3, 1)
    film = Film(np.full((4, 4, 3), 0.5), np.full((4, 4, 3), 0.3), 2)
    path = work / "state.npz"
    save_state(path, film, key)
    raw = path.read_bytes()
    kind = rng.randrange(8)
    if kind == 7:
        pass  # the control: a state as saved
    elif kind == 0:
        raw = raw[: rng.randrange(len(raw))]
    elif kind == 1:
        raw = bytearray(raw)
        for _ in range(rng.randint(1, 20)):
            raw[rng.randrange(len(raw))] = rng.randrange(256)
        raw = bytes(raw)
    else:
        arrays = {"total": film.total, "total_sq": film.total_sq,
                  "meta": np.array(json.dumps({"version": STATE_VERSION, **key.__dict__, "samples": 2}))}
        name = rng.choice(["total", "total_sq", "meta"])
        if kind == 2:
            arrays[name] = rng.choice([np.zeros((4, 5, 3)), np.zeros(48), np.zeros((4, 4, 3), np.float32), np.zeros((4, 4, 3), np.int8),
                                       np.full((4, 4, 3), np.nan), np.full((4, 4, 3), -1.0), np.full((4, 4, 3), 1e308), np.array(5), np.zeros((0,))])
        elif kind == 3:
            meta = {"version": STATE_VERSION, **key.__dict__, "samples": 2}
            meta[rng.choice(list(meta))] = rng.choice([-1, 0, 10**18, 2**64, "x", None, True, 1.5, [1]])
            arrays["meta"] = np.array(json.dumps(meta))
        elif kind == 4:
            arrays["meta"] = np.array(rng.choice(["[]", "{", "5", "null", json.dumps({"version": STATE_VERSION}), json.dumps({"version": 1}), "\x1b[2J"]))
        elif kind == 5:
            arrays["total"] = np.zeros((2000, 2000, 3))  # a compressed bomb
        else:
            arrays["extra"] = np.zeros(3)
        buffer = io.BytesIO()
        (np.savez_compressed if kind == 5 or rng.random() < 0.5 else np.savez)(buffer, **arrays)
        raw = buffer.getvalue()
    path.write_bytes(raw)
    return path, key


# ----------------------------------------------------------------------------------------------
# The surfaces beyond the scene text: includes, --set, standard input, meshes, images, outputs.
#
# Each builds its files in a folder of its own (removed after the case) and calls the function
# the command line calls. A file's real size stays small: the huge ones are sparse.

SECRET = "zq-SECRET-5b1e"  # written only into files a scene names; never the user's own arguments
SMALL_SCENES = ("weekend_diffuse.yaml", "weekend_metal.yaml", "weekend_glass.yaml", "earth.yaml", "perlin_spheres.yaml",
                "simple_light.yaml", "cornell_box.yaml", "quads.json", "sky_spheres.yaml", "checkered_spheres.yaml",
                "weekend_sky.yaml", "cornell_smoke.yaml")
BOOK_FILES = ("earthmap.png", "sky.pfm", "torus_knot.ply")
MATERIAL = {"type": "lambertian", "albedo": [0.6, 0.5, 0.4]}


def small_scene(shapes: list, background=None, materials=None) -> dict:
    """A scene that validates: a camera, a tiny image and the shapes given."""
    return {
        "camera": {"look_from": [0, 0, 5], "look_at": [0, 0, 0], "vfov": 40},
        "image": {"width": 8, "aspect_ratio": 1, "samples_per_pixel": 2, "max_depth": 4},
        "background": background if background is not None else [0.7, 0.8, 1.0],
        "materials": materials if materials is not None else {"m": copy.deepcopy(MATERIAL)},
        "shapes": shapes,
    }


def secret_text(rng: random.Random) -> str:
    """A file that is not a scene, holding the marker: what `include: [/etc/shadow]` would read."""
    return rng.choice([
        f"root:$6${SECRET}$Qz1:19000:0:99999:7:::\ndaemon:*:19000:0:99999:7:::\n",
        f"API_KEY={SECRET}\nDEBUG=1\n",
        f"password: {SECRET}\n",
        f"- {SECRET}\n- other\n",
        f"[client]\npassword = {SECRET}\n",
        f"key: [{SECRET}\n",  # a YAML syntax error on the secret's line
        f'{{"token": "{SECRET}", "x": [1, 2,\n',  # broken JSON
        f"{SECRET}\n",
        f"# {SECRET}\nv 0 0 0\n{SECRET} 1 2 3\n",
        f"-----BEGIN PRIVATE KEY-----\n{SECRET}\n-----END PRIVATE KEY-----\n",
    ])


def random_bytes(rng: random.Random, n: int) -> bytes:
    return bytes(rng.randrange(256) for _ in range(n))


def sparse_file(path: Path, size: int, head: bytes = b"") -> None:
    """A file of `size` bytes that takes almost no disk: `head`, then a hole."""
    with open(path, "wb") as fh:
        fh.write(head)
    os.truncate(path, size)


def link_book_files(folder: Path) -> None:
    for name in BOOK_FILES:
        if not os.path.lexists(folder / name):
            os.symlink(SCENES / name, folder / name)


def _writes(files: dict) -> str:
    """The files of a case, shown short, for a failure's reproduction."""
    out = []
    for name, content in files.items():
        shown = content if isinstance(content, str) else repr(content)
        out.append(f"--- {name}\n{shown[:400]}")
    return "\n".join(out)


# --- includes ---------------------------------------------------------------------------------

INCLUDE_KINDS = ("part", "scene", "secret", "binary", "self", "cycle", "chain", "not-a-list", "outside", "symlink",
                 "name", "big", "many", "shared", "empty", "other-file")


def include_case(rng: random.Random, folder: Path, documents: dict) -> tuple[Path, list, dict]:
    """A main scene including hostile files; (its path, the kinds used, the files written)."""
    files: dict = {}

    def write(name: str, content) -> str:
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, str):
            path.write_text(content, encoding="utf-8")
        else:
            path.write_bytes(content)
        files[name] = content
        return name

    def part(name: str, extra=None) -> str:
        data = copy.deepcopy(documents[SCENES / rng.choice(SMALL_SCENES)])
        data = {k: v for k, v in data.items() if k in ("textures", "materials", "media", "groups", "shapes")}
        for _ in range(rng.choice([0, 0, 1, 2])):
            mutate(data, rng, folder)
        if extra:
            data.update(extra)
        syntax = "json" if name.endswith(".json") else "yaml"
        return write(name, dump(data, syntax))

    main_syntax = rng.choice(["yaml", "yaml", "json"])
    main = f"main.{main_syntax}"
    kinds = rng.sample(INCLUDE_KINDS, rng.choice([1, 1, 2, 3]))
    if "secret" not in kinds and rng.random() < 0.25:  # what an attacker tries first: include: [/etc/shadow]
        kinds.append("secret")
    entries: list = []
    include_value = None
    for kind in kinds:
        if kind == "part":
            entries.append(part(rng.choice(["part.yaml", "part.json", "sub/part.yaml", "part.yml", "part"])))
        elif kind == "scene":
            data = copy.deepcopy(documents[SCENES / rng.choice(SMALL_SCENES)])
            entries.append(write("other.yaml", dump(data, "yaml")))
        elif kind == "secret":
            entries.append(write(rng.choice(["secret.txt", "secret.yaml", "shadow", ".env", "secret.json", "id_rsa"]), secret_text(rng)))
        elif kind == "binary":
            head = rng.choice([b"", b"\x89PNG\r\n\x1a\n", b"\xff\xfe", b"\xef\xbb\xbf", b"PK\x03\x04", b"\x00" * 8])
            entries.append(write(rng.choice(["blob.bin", "blob.yaml"]), head + random_bytes(rng, rng.randint(0, 300))))
        elif kind == "self":
            entries.append(rng.choice([main, "./" + main, "sub/../" + main]))
        elif kind == "cycle":
            write("a.yaml", dump({"include": ["b.yaml"], "materials": {"ca": MATERIAL}}, "yaml"))
            write("b.yaml", dump({"include": [rng.choice(["a.yaml", "../" + folder.name + "/a.yaml", main])]}, "yaml"))
            entries.append("a.yaml")
        elif kind == "chain":
            depth = rng.choice([3, 15, 16, 17, 40])
            for i in range(depth):
                write(f"c{i}.yaml", dump({"include": [f"c{i + 1}.yaml"]} if i + 1 < depth else {"materials": {"deep": MATERIAL}}, "yaml"))
            entries.append("c0.yaml")
        elif kind == "not-a-list":
            part("part.yaml")
            include_value = rng.choice(["part.yaml", 5, {"a": "part.yaml"}, [5, None, "", ["part.yaml"]], True, None, [],
                                        ["part.yaml"] * 300, "x" * 5000, {"include": "secret.txt"}])
        elif kind == "outside":
            outside = folder.parent / "outside-secret.txt"
            if not outside.exists():
                outside.write_text(secret_text(rng), encoding="utf-8")
            entries.append(rng.choice(["../outside-secret.txt", str(outside), "../" * 40 + str(outside).lstrip("/"),
                                       "~/outside-secret.txt", "../missing.yaml", "/nonexistent/x.yaml"]))
        elif kind == "symlink":
            target = rng.choice(["secret", "zero", "loop", "dangling", "folder", "fifo", "outside"])
            name = f"link-{target}.yaml"
            if target == "secret":
                write("secret.txt", secret_text(rng))
                os.symlink("secret.txt", folder / name)
            elif target == "zero":
                os.symlink("/dev/zero", folder / name)
            elif target == "loop":
                os.symlink(name, folder / name)
            elif target == "dangling":
                os.symlink("nowhere.yaml", folder / name)
            elif target == "folder":
                (folder / "dir").mkdir(exist_ok=True)
                os.symlink("dir", folder / name)
            elif target == "fifo":
                os.mkfifo(folder / "fifo")
                os.symlink("fifo", folder / name)
            else:
                outside = folder.parent / "outside-secret.txt"
                if not outside.exists():
                    outside.write_text(secret_text(rng), encoding="utf-8")
                os.symlink(outside, folder / name)
            entries.append(name)
        elif kind == "name":
            entries.append(rng.choice(["", "a\x00b.yaml", "x" * 5000 + ".yaml", "\x1b[2Jx.yaml", ".", "..", "/", "sub/", "\u202egnp.yaml",
                                       "x" * 300 + ".yaml", "-", "part.yaml\n"]))
        elif kind == "big":
            size = rng.choice([128 * 1024 * 1024 + 1, 3 << 30, 4 << 20])
            sparse_file(folder / "big.yaml", size, b"materials:\n  big: {type: lambertian}\n# ")
            files["big.yaml"] = f"(sparse, {size:,} bytes: a materials line then NUL bytes)"
            entries.append("big.yaml")
        elif kind == "many":
            count = rng.choice([255, 257, 1000])
            for i in range(min(count, 300)):
                write(f"m{i}.yaml", f"materials: {{m{i}: {{type: lambertian}}}}\n")
            files.update({"m*.yaml": f"{count} tiny files"})
            entries += [f"m{i % 300}.yaml" for i in range(count)]  # past 300, the same files again
        elif kind == "shared":
            write("lib.yaml", dump({"materials": {"shared": MATERIAL}}, "yaml"))
            part("p1.yaml", {"include": ["lib.yaml"]})
            part("p2.yaml", {"include": ["lib.yaml"]})
            entries += ["p1.yaml", "p2.yaml"]
        elif kind == "empty":
            entries.append(write("empty.yaml", rng.choice(["", "---\n", "null\n", "[]\n", "{}\n", "---\n---\n", "\ufeff", "~"])))
        else:  # a file of another kind a scene names: an image, a mesh, a saved state
            entries.append(rng.choice(["earthmap.png", "sky.pfm", "torus_knot.ply"]))
    data = copy.deepcopy(documents[SCENES / rng.choice(SMALL_SCENES)])
    if rng.random() < 0.2:
        mutate(data, rng, folder)
    if isinstance(data, dict):
        data = {"include": include_value if include_value is not None else entries, **data}
    link_book_files(folder)
    text = dump(data, main_syntax)
    if rng.random() < 0.1:
        text, name = text_mutation(text, main_syntax, rng)
        kinds.append(name)
    write(main, text)
    return folder / main, kinds, files


# --- --set ------------------------------------------------------------------------------------

def _typo(word: str, rng: random.Random) -> str:
    if not word:
        return "x"
    i = rng.randrange(len(word))
    kind = rng.randrange(4)
    if kind == 0:
        return word[:i] + word[i + 1:]
    if kind == 1 and i + 1 < len(word):
        return word[:i] + word[i + 1] + word[i] + word[i + 2:]
    if kind == 2:
        return word[:i] + rng.choice("abcdefghijklmnopqrstuvwxyz_") + word[i:]
    return word.upper()


def set_key(data, rng: random.Random) -> tuple[str, str]:
    """A key path for --set, taken from the scene and mutated; (key, the mutation's name)."""
    from scenefmt.diagnostics import format_path

    paths = []
    for path, _ in _containers(data):
        if path:
            paths.append(path)
    for parent, key, _ in _leaves(data):
        paths.append(next(p for p, c in _containers(data) if c is parent) + (key,))
    path = rng.choice(paths) if paths else ("image", "width")
    key = format_path(path)
    kind = rng.randrange(12)
    if kind == 0:
        return key, "key"
    if kind == 1:
        parts = key.split(".")
        j = rng.randrange(len(parts))
        parts[j] = _typo(parts[j], rng)
        return ".".join(parts), "typo"
    if kind == 2:
        return re.sub(r"\[\d+\]", lambda m: f"[{rng.choice([999999999, 4294967296, 10**20, 2**63, 10**400])}]", key, count=1) \
            if "[" in key else f"shapes[{rng.choice([999999999, 10**20, -1])}]", "huge-index"
    if kind == 3:
        n = rng.choice([100, 1000, 10_000])
        return rng.choice([".".join(["a"] * n), "image." + ".".join(["x"] * n), "[0]" * n, "shapes" + "[0]" * n,
                           ".".join(f"k{i}" for i in range(n)), "materials." + ".".join(["glass"] * n)]), f"{n}-parts"
    if kind == 4:
        i = rng.randrange(len(key) + 1)
        return key[:i] + rng.choice(["\x00", "\x1b[2J", "\n", "\u202e", "\t", "\x7f", "\r"]) + key[i:], "control"
    if kind == 5:
        return rng.choice(["", ".", "..", "image..width", ".image", "image.", "[0]", "shapes[]", "shapes[0]]", "shapes[-1]",
                           "shapes[0x1]", "[", "]", "image.width.", " ", "image . width"]), "empty-part"
    if kind == 6:
        return rng.choice(["include", "include[0]", "version", "description", "camera.look_from[7]", "image.width.value",
                           "shapes[0].material.type", "materials.new.type", "groups.g.shapes[0]"]), "special"
    if kind == 7:
        return key + "." + _typo("width", rng), "deeper"
    if kind == 8:
        return "x" * rng.choice([300, 5000, 100_000]), "long"
    if kind == 9:
        return key.replace(".", rng.choice(["/", "->", ":", "]["])), "separator"
    if kind == 10:
        return "image." + _typo(rng.choice(["width", "height", "samples_per_pixel", "max_depth", "aspect_ratio", "seed"]), rng), "misspelt"
    return "é" + key, "unicode"


def set_value(rng: random.Random) -> tuple[str, str]:
    kind = rng.randrange(12)
    if kind == 0:
        return str(rng.choice(EXTREME_NUMBERS)), "number"
    if kind == 1:
        return rng.choice(["&r [*r]", "&r {a: *r}", "*r", "&a [1, *a]", "[&a 1, *a, *b]", "&r [[*r]]"]), "recursive-alias"
    if kind == 2:
        levels = rng.randint(3, 12)
        return "[" + ", ".join(f"&a{i} [" + ", ".join([f"*a{i - 1}" if i else "1"] * 10) + "]" for i in range(levels)) + "]", "alias-bomb"
    if kind == 3:
        n = rng.choice([63, 65, 1000, 100_000])
        return "[" * n + "1" + "]" * n, f"nesting-{n}"
    if kind == 4:
        return rng.choice(["1e999", "-1e999", "1" + "0" * 5000, ".nan", ".inf", "0x" + "f" * 40, "1_000", "0o777", "+.5e-400"]), "huge-number"
    if kind == 5:
        return rng.choice(["!!python/object/apply:os.system ['true']", "!!binary aGVsbG8=", "!!set {a, b}", "!!timestamp 2001-01-01",
                           "!!str", "!<tag:x> 1", "%YAML 1.1\n--- 1"]), "tag"
    if kind == 6:
        return rng.choice(["", "---", "--- 1\n--- 2", "...", "'unterminated", '"\\xZZ"', "a: b: c", "{", "[1, 2", "- a\nb: c", "? x"]), "syntax"
    if kind == 7:
        return rng.choice(["\x1b[2J", "a\x00b", "\u202emalicious", "\t", "\r\n1"]), "control"
    if kind == 8:
        return rng.choice(["[1, 0, 0]", "{type: metal, fuzz: 0.1}", "{type: image, file: /dev/zero}", "{type: image, file: ../../../etc/hostname}",
                           "[]", "{}", "~", "true", "400", "0.5", "16:9", "[1e300, 1e300, 1e300]"]), "plain"
    if kind == 9:
        return "x" * rng.choice([1000, 100_000, 2_000_000]), "long"
    if kind == 10:
        return "{" + ", ".join(f"k{i}: {i}" for i in range(rng.choice([10, 10_000]))) + "}", "wide-map"
    return "[" + ", ".join(["1"] * rng.choice([3, 10_000, 300_000])) + "]", "long-list"


def set_arguments(data, rng: random.Random) -> tuple[list, list]:
    count = rng.choice([1, 1, 1, 2, 3, 5, 1001])
    args, names = [], []
    for i in range(count):
        if i >= 3 and count > 5:
            args.append(f"image.width={i}")
            continue
        key, kname = set_key(data, rng)
        value, vname = set_value(rng)
        sep = rng.choice(["=", "=", "=", "==", " = ", ""])
        args.append(key + sep + value)
        names.append(f"{kname}={vname}" + ("" if sep == "=" else f" sep {sep!r}"))
    if count > 5:
        names.append(f"{count} arguments")
    return args, names


# --- standard input ---------------------------------------------------------------------------

class _Endless(io.RawIOBase):
    """A pipe that never ends (`rt render - < /dev/zero`), or one that fails on read."""

    def __init__(self, fill: bytes = b"\0", error: Exception | None = None, chunk: int = 1 << 20):
        self.fill, self.error, self.chunk = fill, error, chunk

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        if self.error is not None:
            raise self.error
        n = min(len(buffer), self.chunk)
        buffer[:n] = (self.fill * (n // len(self.fill) + 1))[:n]
        return n


class _Trickle(io.RawIOBase):
    """A pipe that hands over its bytes a few at a time."""

    def __init__(self, data: bytes, step: int):
        self.data, self.step, self.at = data, step, 0

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        n = min(len(buffer), self.step, len(self.data) - self.at)
        buffer[:n] = self.data[self.at:self.at + n]
        self.at += n
        return n


def stdin_case(rng: random.Random, documents: dict):
    """(what sys.stdin becomes, a description, the bytes or None)."""
    source = SCENES / rng.choice(SMALL_SCENES)
    data = copy.deepcopy(documents[source])
    syntax = "json" if source.suffix == ".json" else "yaml"
    if rng.random() < 0.5:
        for _ in range(rng.randint(1, 2)):
            mutate(data, rng, SCENES)
        syntax = rng.choice(["yaml", "json"])
    text = dump(data, syntax)
    kind = rng.randrange(12)
    if kind <= 3:
        raw, name = text.encode(), f"{source.name} as {syntax}"
    elif kind == 4:
        raw, name = b"", "empty"
    elif kind == 5:
        raw, name = random_bytes(rng, rng.randint(1, 500)), "binary"
    elif kind == 6:
        raw, name = rng.choice([text.encode("utf-16"), b"\xef\xbb\xbf" + text.encode(), text.encode("latin-1", "replace") + b"\xe9\xff"]), "encoding"
    elif kind == 7:
        return None, "closed (sys.stdin is None, as with <&-)", None
    elif kind == 8:
        stream = io.TextIOWrapper(io.BufferedReader(_Endless()))
        stream.close()
        return stream, "closed stream", None
    elif kind == 9:
        import errno

        error = OSError(rng.choice([errno.EBADF, errno.EIO, errno.EISDIR, errno.EAGAIN]), "failed")
        return io.TextIOWrapper(io.BufferedReader(_Endless(error=error))), f"read fails ({error.errno})", None
    elif kind == 10:
        if rng.random() < 0.2:
            return io.TextIOWrapper(io.BufferedReader(_Endless(rng.choice([b"\0", b"a: 1\n", b"[", b"- "])))), "endless", None
        raw, name = text.encode(), "trickle"
        return io.TextIOWrapper(io.BufferedReader(_Trickle(raw, rng.choice([1, 7, 4096])))), f"{source.name} a few bytes at a time", raw
    else:
        raw, name = dump(data, syntax)[: rng.randrange(len(text) + 1)].encode(), "truncated"
    return io.TextIOWrapper(io.BytesIO(raw)), name, raw


# --- meshes -----------------------------------------------------------------------------------

def _mesh_arrays(rng: random.Random):
    """A small closed or open mesh: vertices, faces, uvs and normals."""
    n = rng.randint(2, 5)
    vertices = [[x / n, y / n, rng.uniform(-0.1, 0.1)] for y in range(n + 1) for x in range(n + 1)]
    faces = []
    for y in range(n):
        for x in range(n):
            a = y * (n + 1) + x
            faces.append([a, a + 1, a + n + 2, a + n + 1] if rng.random() < 0.5 else [a, a + 1, a + n + 2])
    uvs = [[v[0], v[1]] for v in vertices]
    normals = [[0.0, 0.0, 1.0] for _ in vertices]
    return vertices, faces, uvs, normals


def obj_text(vertices, faces, uvs, normals, rng: random.Random) -> str:
    style = rng.randrange(4)
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in vertices]
    if style >= 1:
        lines += [f"vt {u!r} {v!r}" for u, v in uvs]
    if style >= 2:
        lines += [f"vn {a!r} {b!r} {c!r}" for a, b, c in normals]
    for face in faces:
        if style == 0:
            corners = [str(i + 1) for i in face]
        elif style == 1:
            corners = [f"{i + 1}/{i + 1}" for i in face]
        elif style == 2:
            corners = [f"{i + 1}/{i + 1}/{i + 1}" for i in face]
        else:
            corners = [f"{i - len(vertices)}//{i - len(vertices)}" for i in face]
        lines.append("f " + " ".join(corners))
    return "\n".join(lines) + "\n"


def ply_bytes(vertices, faces, fmt: str, rng: random.Random, vertex_count=None, face_count=None, count_type="uchar",
              index_type="int", extra_header="") -> bytes:
    import struct

    header = ["ply", f"format {fmt} 1.0", f"element vertex {len(vertices) if vertex_count is None else vertex_count}",
              "property float x", "property float y", "property float z",
              f"element face {len(faces) if face_count is None else face_count}",
              f"property list {count_type} {index_type} vertex_indices"]
    if extra_header:
        header.append(extra_header)
    head = ("\n".join(header) + "\nend_header\n").encode()
    if fmt == "ascii":
        body = "".join(f"{x!r} {y!r} {z!r}\n" for x, y, z in vertices) + "".join(f"{len(f)} " + " ".join(map(str, f)) + "\n" for f in faces)
        return head + body.encode()
    end = "<" if fmt == "binary_little_endian" else ">"
    codes = {"uchar": "B", "char": "b", "ushort": "H", "short": "h", "int": "i", "uint": "I", "float": "f", "double": "d",
             "int32": "i", "uint8": "B"}
    body = b"".join(struct.pack(end + "fff", *v) for v in vertices)
    for face in faces:
        try:
            body += struct.pack(end + codes.get(count_type, "B"), len(face)) + struct.pack(end + codes.get(index_type, "i") * len(face), *face)
        except struct.error:
            body += b"\xff" * (1 + 4 * len(face))
    return head + body


MESH_KINDS = ("valid", "count-negative", "count-huge", "count-mismatch", "corners-huge", "index-range", "index-negative",
              "nan-vertex", "truncated", "sparse", "mtl", "bytes", "secret", "statement", "suffix", "list-type", "header")


def mesh_case(rng: random.Random, folder: Path) -> tuple[str, str, dict]:
    """A mesh file in `folder`; (its name, the mutation, the files written)."""
    vertices, faces, uvs, normals = _mesh_arrays(rng)
    form = rng.choice(["obj", "obj", "ascii", "binary_little_endian", "binary_big_endian"])
    suffix = ".obj" if form == "obj" else ".ply"
    kind = rng.choice(MESH_KINDS)
    content: bytes
    if form == "obj":
        text = obj_text(vertices, faces, uvs, normals, rng)
        if kind == "count-negative":
            text += rng.choice(["f -1 -2 -99999\n", "f 0 1 2\n", "f -0 1 2\n", f"f {-len(vertices) - 1} 1 2\n"])
        elif kind == "count-huge":
            text += rng.choice(["f 1 2 99999999999999999999\n", "f 1 2 9223372036854775808\n", "f 1 2 4294967297\n", "vt 1e999 0\n"])
        elif kind == "count-mismatch":
            text += rng.choice(["f 1/1 2 3\n", "f 1//1 2/2 3/3/3\n", "f 1/99 2/99 3/99\n", "f 1//99 2//99 3//99\n", "f 1 2\n", "f\n"])
        elif kind == "corners-huge":
            n = rng.choice([1000, 100_000, 1_000_000])
            text += "f " + " ".join(str(rng.randint(1, len(vertices))) for _ in range(min(n, 1000)))
            text += (" 1 2 3" * ((n - 1000) // 3)) + "\n" if n > 1000 else "\n"
        elif kind == "index-range":
            text += f"f 1 2 {len(vertices) + rng.choice([1, 1000])}\n"
        elif kind == "index-negative":
            text += rng.choice(["f -1 -2 -3\n", f"f 1 2 -{len(vertices) + 5}\n", "f 1/-1 2/-2 3/-3\n"])
        elif kind == "nan-vertex":
            text = text.replace("v ", rng.choice(["v nan ", "v inf ", "v -inf ", "v 1e999 ", "v NaN ", "v 1e308 1e308 "]), 1)
        elif kind == "truncated":
            text = text[: rng.randrange(len(text))]
        elif kind == "mtl":
            text = rng.choice(["mtllib ../../../../etc/hostname\n", "mtllib secret.txt\n", "mtllib /dev/zero\nusemtl x\n",
                               "mtllib a\x00b.mtl\n", "usemtl " + "x" * 10000 + "\n"]) + text
            (folder / "secret.txt").write_text(secret_text(rng))
        elif kind == "statement":
            text += rng.choice(["vx 1 2 3\n", "f 1 2 3 \\\n 4\n", "\\\n", "v 1 2\n", "vt\n", "vn 1 x 2\n", "f a b c\n",
                                "f 1/2/3/4 2 3\n", "\x00\n", "é 1 2 3\n", "f 1.5 2 3\n", "v 1 2 3 4 5 6 7\n", "\r\n\r\n", "#" * 100000 + "\n"])
        elif kind == "secret":
            text = secret_text(rng) + text
        content = text.encode("utf-8", "surrogatepass")
    else:
        ptype = rng.choice(["int", "uint", "uchar", "short"])
        ctype = rng.choice(["uchar", "uchar", "int", "ushort", "char"])
        args = {}
        if kind == "count-negative":
            args = rng.choice([{"vertex_count": -5}, {"face_count": -5}, {"face_count": "-1"}])
        elif kind == "count-huge":
            args = rng.choice([{"vertex_count": 99999999999}, {"face_count": 99999999999}, {"vertex_count": 10**30},
                               {"face_count": 2**63}, {"face_count": 2**64 + 3}])
        elif kind == "count-mismatch":
            args = rng.choice([{"vertex_count": len(vertices) + 3}, {"face_count": len(faces) + 1}, {"vertex_count": 1}, {"face_count": 0},
                               {"vertex_count": 0}])
        elif kind == "list-type":
            args = rng.choice([{"count_type": "float"}, {"index_type": "float"}, {"index_type": "double"}, {"count_type": "bogus"},
                               {"count_type": "int", "index_type": "char"}])
        elif kind == "header":
            args = rng.choice([{"extra_header": "element extra 3"}, {"extra_header": "property float nope"}, {"extra_header": "format ascii 2.0"},
                               {"extra_header": "comment " + "x" * 5000}, {"extra_header": "obj_info \x1b[2J"}, {"extra_header": "property list uchar int vertex_indices"}])
        if kind == "corners-huge":
            n = rng.choice([255, 1000, 100_000])
            faces = faces + [[rng.randrange(len(vertices)) for _ in range(n)]]
            if form != "ascii":
                ctype = "int" if n > 255 else "uchar"
        elif kind == "index-range":
            faces = faces + [[0, 1, len(vertices) + rng.choice([0, 1, 2**20])]]
        elif kind == "index-negative":
            faces = faces + [[0, 1, -1]]
            ptype = "int"
        elif kind == "nan-vertex":
            vertices = [list(v) for v in vertices]
            vertices[rng.randrange(len(vertices))][rng.randrange(3)] = rng.choice([float("nan"), float("inf"), -float("inf"), 3.4e38])
        ctype, ptype = args.pop("count_type", ctype), args.pop("index_type", ptype)
        content = ply_bytes(vertices, faces, form, rng, count_type=ctype, index_type=ptype, **args)
        if kind == "truncated":
            content = content[: rng.randrange(len(content))]
        elif kind == "secret":
            content = b"ply\nformat ascii 1.0\n" + secret_text(rng).encode() + b"end_header\n"
        elif kind == "statement":
            content = content.replace(b"end_header", rng.choice([b"end_headr", b"end_header extra", b"end_header\r"]), 1)
    if kind == "bytes":
        flipped = bytearray(content)
        for _ in range(rng.randint(1, 20)):
            flipped[rng.randrange(len(flipped))] = rng.randrange(256)
        content = bytes(flipped)
    name = "mesh" + suffix
    if kind == "suffix":
        name = rng.choice(["mesh.OBJ", "mesh.stl", "mesh", "mesh.ply" if suffix == ".obj" else "mesh.obj", "mesh.obj.png"])
    path = folder / name
    if kind == "sparse":
        size = rng.choice([(4 << 30) + 1, 16 << 20, 4 << 20])  # a bigger read costs over 12 times its size
        sparse_file(path, size, content)
        return name, f"{form} sparse to {size:,} bytes", {name: f"(sparse: {len(content)} bytes of a valid {form} mesh, then NUL bytes to {size:,})"}
    path.write_bytes(content)
    return name, f"{form} {kind}", {name: content[:600]}


# --- images -----------------------------------------------------------------------------------

def _png_chunk(kind: bytes, data: bytes, good_crc: bool = True) -> bytes:
    import struct
    import zlib

    crc = zlib.crc32(kind + data) if good_crc else 0
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", crc)


def png_bytes(rng: random.Random, width: int, height: int) -> bytes:
    import numpy as np
    from PIL import Image

    mode = rng.choice(["RGB", "RGB", "RGBA", "L", "LA", "P", "I;16", "1", "I", "F"])
    pixels = np.random.default_rng(rng.randrange(2**32)).integers(0, 256, (height, width, 3), dtype=np.uint8)
    image = Image.fromarray(pixels, "RGB")
    if mode == "I;16":  # 16 bits a sample
        image = Image.fromarray(np.ascontiguousarray(pixels[..., 0].astype(np.uint16) * 257))
    elif mode in ("I", "F"):  # 32-bit integer or float samples: a TIFF under the PNG's name
        image = image.convert(mode)
    elif mode != "RGB":
        image = image.convert(mode)
    buffer = io.BytesIO()
    image.save(buffer, format="TIFF" if mode in ("I", "F") else "PNG")
    return buffer.getvalue()


def pfm_bytes(rng: random.Random, width: int, height: int, values) -> bytes:
    import numpy as np

    grey = rng.random() < 0.1
    data = np.asarray(values, np.float32)[..., :1 if grey else 3]
    little = rng.random() < 0.7
    head = f"{'Pf' if grey else 'PF'}\n{width} {height}\n{-1.0 if little else 1.0}\n".encode()
    return head + data[::-1].astype("<f4" if little else ">f4").tobytes()


def exr_file_bytes(rng: random.Random, values) -> bytes:
    import numpy as np
    import OpenEXR

    pixels = np.ascontiguousarray(values, dtype=rng.choice([np.float32, np.float32, np.float16]))
    which = rng.choice(["RGB", "RGB", "RGBA", "Y", "Z", "RG"])
    if which == "RGBA":
        channels = {"RGBA": np.concatenate([pixels, np.ones_like(pixels[..., :1])], axis=2)}
    elif which == "Y":
        channels = {"Y": np.ascontiguousarray(pixels[..., 0])}
    elif which == "Z":
        channels = {"Z": np.ascontiguousarray(pixels[..., 0])}
    elif which == "RG":
        channels = {"R": np.ascontiguousarray(pixels[..., 0]), "G": np.ascontiguousarray(pixels[..., 1])}
    else:
        channels = {"RGB": pixels}
    header = {"compression": rng.choice([OpenEXR.ZIP_COMPRESSION, OpenEXR.NO_COMPRESSION, OpenEXR.PIZ_COMPRESSION]),
              "type": OpenEXR.scanlineimage}
    out = io.BytesIO()
    OpenEXR.File(header, channels).write(out)
    return out.getvalue()


def _lie_about_size(raw: bytes, form: str, rng: random.Random) -> bytes:
    """The same file, its header claiming another size."""
    import struct

    width, height = rng.choice([(30000, 30000), (65535, 65535), (2**31 - 1, 1), (1, 2**31 - 1), (0, 5), (16385, 16384),
                                (100000, 100000), (2**32 - 1, 2**32 - 1)])
    if form == "png" and raw.startswith(b"\x89PNG") and raw[12:16] == b"IHDR":
        ihdr = struct.pack(">II", width % 2**32, height % 2**32) + raw[24:29]
        return raw[:8] + _png_chunk(b"IHDR", ihdr, rng.random() < 0.8) + raw[33:]
    if form == "pfm":
        end = raw.index(b"\n", raw.index(b"\n") + 1)
        return raw[:3] + f"{width} {height}".encode() + raw[end:]
    at = raw.find(b"dataWindow\0box2i\0")
    if at >= 0:
        start = at + len(b"dataWindow\0box2i\0") + 4
        box = rng.choice([(0, 0, width - 1, height - 1), (0, 0, -5, -5), (2**31 - 1, 0, -(2**31), 3), (-(2**31), -(2**31), 2**31 - 1, 2**31 - 1)])
        box = tuple(max(-(2**31), min(2**31 - 1, b)) for b in box)
        return raw[:start] + struct.pack("<iiii", *box) + raw[start + 16:]
    return raw


IMAGE_KINDS = ("valid", "truncated", "size-lie", "special-values", "bytes", "random", "empty", "suffix", "secret", "sparse", "folder")


def image_case(rng: random.Random, folder: Path) -> tuple[str, str, dict]:
    """An image file in `folder`; (its name, what was done to it, the files written)."""
    import numpy as np

    form = rng.choice(["png", "png", "pfm", "exr"])
    width, height = rng.randint(1, 8), rng.randint(1, 8)
    values = np.random.default_rng(rng.randrange(2**32)).uniform(0, 2, (height, width, 3))
    kind = rng.choice(IMAGE_KINDS)
    if kind == "special-values" and form != "png":
        values[rng.randrange(height), rng.randrange(width), rng.randrange(3)] = rng.choice(
            [float("nan"), float("inf"), -float("inf"), -1.0, -0.0, 3.4e38, 1e-45, 65504.0, 1e5])
    raw = png_bytes(rng, width, height) if form == "png" else pfm_bytes(rng, width, height, values) if form == "pfm" else exr_file_bytes(rng, values)
    if kind == "truncated":
        raw = raw[: rng.randrange(len(raw))]
    elif kind == "size-lie":
        raw = _lie_about_size(raw, form, rng)
    elif kind == "bytes":
        flipped = bytearray(raw)
        for _ in range(rng.randint(1, 12)):
            flipped[rng.randrange(len(flipped))] = rng.randrange(256)
        raw = bytes(flipped)
    elif kind == "random":
        raw = rng.choice([b"", b"\x89PNG\r\n\x1a\n", b"PF\n", b"v/1\x01", b"\x76\x2f\x31\x01\x02\0\0\0"]) + random_bytes(rng, rng.randint(0, 400))
    elif kind == "empty":
        raw = rng.choice([b"", b"PF\n1 1\n-1\n", b"PF\n-1 1\n-1\n", b"PF\n1 1\nnan\n" + b"\0" * 12, b"PF 1 1 0 " + b"\0" * 12,
                          b"PF\n1 1\n-1e999\n" + b"\0" * 12])
    elif kind == "secret":
        raw = secret_text(rng).encode()
    name = "image." + form
    if kind == "suffix":
        name = "image." + rng.choice(["exr", "pfm", "png", "PFM", "jpg", "txt", "EXR"])
    path = folder / name
    if kind == "sparse":
        size = rng.choice([16384 * 16384 * 12 + (1 << 20) + 1, 300 << 20, 8 << 20])
        sparse_file(path, size, raw)
        return name, f"{form} sparse to {size:,} bytes", {name: f"(sparse: a {width}x{height} {form} then NUL bytes to {size:,})"}
    if kind == "folder":
        path.mkdir()
        return name, f"a folder named {name}", {}
    path.write_bytes(raw)
    return name, f"{form} {width}x{height} {kind}", {name: raw[:300]}


def image_scene(rng: random.Random, name: str) -> tuple[dict, list]:
    """A scene using the image as a texture, as the background, or both; (scene, the image roles)."""
    use = rng.choice(["texture", "background", "both"])
    materials = {"m": copy.deepcopy(MATERIAL)}
    roles = []
    if use in ("texture", "both"):
        texture = {"type": "image", "file": name, "colorspace": rng.choice(["srgb", "linear"])}
        kind = rng.choice(["lambertian", "metal", "diffuse_light"])
        materials["m"] = {"type": kind, "emit" if kind == "diffuse_light" else "albedo": texture}
        roles.append("texture")
    background = None
    if use in ("background", "both"):
        background = {"type": "image", "file": name, "rotate": rng.choice([0, 90, -360, 359.9]), "strength": rng.choice([1, 0, 1e6, 0.5])}
        roles.append("background")
    shapes = [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}]
    return small_scene(shapes, background, materials), roles


# --- outputs ----------------------------------------------------------------------------------

# The files the scene reads. (state.npz is not among them: --save-state may replace an earlier state,
# and --resume X --save-state X continues a render in place.)
OUTPUT_INPUTS = ("scene.yaml", "inc.yaml", "tex.png", "sky.pfm", "mesh.obj")


def output_case(rng: random.Random, folder: Path) -> tuple[dict, dict, str]:
    """Input files in `folder` and `rt render` options whose outputs may name them; (options, files, label)."""
    import numpy as np

    from renderer.film import Film, write_pfm
    from renderer.state import RenderKey, save_state

    png = png_bytes(random.Random(1), 4, 4)
    (folder / "tex.png").write_bytes(png)
    write_pfm(folder / "sky.pfm", np.full((4, 8, 3), 0.5))
    vertices, faces, uvs, normals = _mesh_arrays(random.Random(2))
    (folder / "mesh.obj").write_text(obj_text(vertices, faces, uvs, normals, random.Random(3)))
    (folder / "inc.yaml").write_text(dump({"materials": {"inc": MATERIAL}}, "yaml"))
    scene = small_scene(
        [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "t"},
         {"type": "mesh", "file": "mesh.obj", "material": "inc", "transform": [{"translate": [0, -2, 0]}]}],
        {"type": "image", "file": "sky.pfm"},
        {"t": {"type": "lambertian", "albedo": {"type": "image", "file": "tex.png"}}},
    )
    scene = {"include": ["inc.yaml"], **scene}
    (folder / "scene.yaml").write_text(dump(scene, "yaml"))
    save_state(folder / "state.npz", Film(np.full((8, 8, 3), 0.5), np.full((8, 8, 3), 0.3), 1), RenderKey("ab" * 32, 8, 8, 4, 0))
    os.symlink("tex.png", folder / "link.png")
    os.link(folder / "tex.png", folder / "hard.png")
    (folder / "sub").mkdir()

    def pick(*names):
        return rng.choice(list(names))

    inputs = ["tex.png", "./tex.png", "sub/../tex.png", str(folder / "tex.png"), "link.png", "hard.png"]
    options = {
        "output": pick(None, None, "out.png", *inputs, "scene.png", "TEX.png"),
        "hdr": pick(None, None, "out.exr", "out.pfm", "sky.pfm", "./sky.pfm", "out.png", "scene.yaml"),
        "noise_map": pick(None, None, "noise.png", *inputs, "out.png"),
        "save_state": pick(None, None, "saved.npz", "state.npz", "./state.npz"),
        "resume": pick(None, None, None, "state.npz"),
        "scene": pick("scene.yaml", "scene.yaml", "./scene.yaml", "-"),
    }
    if rng.random() < 0.2:  # the include or the mesh as an output, through a name with the right suffix
        for target, name in (("inc.yaml", "inc.png"), ("mesh.obj", "mesh.png"), ("scene.yaml", "scene.npz")):
            os.symlink(target, folder / name)
        options[pick("output", "noise_map")] = pick("inc.png", "mesh.png")
        if rng.random() < 0.5:
            options["save_state"] = "scene.npz"
    label = ", ".join(f"{k}={v}" for k, v in options.items() if v is not None)
    return options, {"scene.yaml": dump(scene, "yaml")}, label


# ----------------------------------------------------------------------------------------------


def prepare_hostile_dir(work: Path) -> Path:
    hostile = work / "hostile"
    hostile.mkdir(exist_ok=True)
    if not (hostile / "fifo").exists():
        os.mkfifo(hostile / "fifo")
    if not os.path.lexists(hostile / "loop"):
        os.symlink(hostile / "loop", hostile / "loop")
    if not os.path.lexists(hostile / "zero.yaml"):
        os.symlink("/dev/zero", hostile / "zero.yaml")
    # A PNG whose header promises 30000 x 30000 pixels.
    import struct
    import zlib

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    (hostile / "huge.png").write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 30000, 30000, 8, 2, 0, 0, 0))
                                       + chunk(b"IDAT", zlib.compress(b"\0" * 1000)))
    return hostile


RENDER_PLACEMENTS = 20_000


def render_tiny(loaded, rng: random.Random):
    """Render the scene at 4x4 pixels; (all pixels finite, noise figure not NaN)."""
    import dataclasses

    import numpy as np

    from renderer.compile import compile_scene
    from renderer.film import estimate_noise
    from renderer.render import render

    graph = loaded.graph
    image = graph.image.model_copy(update={"width": 4, "height": 4, "aspect_ratio": None})
    graph = dataclasses.replace(graph, image=image)
    flat = compile_scene(graph)
    result = render(graph, flat=flat, samples=rng.randint(1, 2), max_depth=rng.randint(2, 4))
    mean = result.film.mean()
    noise = estimate_noise(result.film).relative_rms if result.film.samples >= 2 else 0.0
    return bool(np.isfinite(mean).all()) and not math.isnan(noise)


# The default mix: what share of the cases each surface gets.
SURFACES = {"scenes": 0.40, "states": 0.05, "paths": 0.02, "includes": 0.11, "set": 0.11, "stdin": 0.07, "meshes": 0.10,
            "images": 0.10, "outputs": 0.04}
OLD_SURFACES = ("scenes", "states", "paths")


def pick_surface(rng: random.Random, surfaces) -> str:
    weights = [SURFACES[s] for s in surfaces]
    return rng.choices(list(surfaces), weights)[0]


def run(cases: int, seed: int, render_share: float = 0.1, time_limit: float = 10.0, render_time_limit: float = 120.0,
        measure_memory: bool = True, show: int = 0, progress: bool = False, surfaces=None, only=None, keep=None,
        log=None) -> Counts:
    """Fuzz `cases` cases of the `surfaces` named (all by default). Case k draws from its own
    random stream (seeded by `seed` and k), so `only=[k]` replays it alone; `keep` is a folder
    to build the cases' files in and leave there."""
    surfaces = tuple(surfaces) if surfaces else tuple(SURFACES)
    unknown = [s for s in surfaces if s not in SURFACES]
    if unknown:
        raise ValueError(f"unknown surfaces {unknown}; expected some of {', '.join(SURFACES)}")
    counts = Counts()
    sources = sorted(p for p in SCENES.iterdir() if p.suffix in (".yaml", ".json"))
    documents = {p: parse_file(p).data for p in sources}
    previous = signal.signal(signal.SIGALRM, _alarm)
    with contextlib.ExitStack() as stack:
        work = Path(keep) if keep else Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="rt-fuzz-")))
        work.mkdir(parents=True, exist_ok=True)
        hostile = prepare_hostile_dir(work)
        if render_share > 0:
            # The first render compiles (or loads) the kernels: not a case, so not under a case's limit.
            render_tiny(loads((SCENES / "weekend_diffuse.yaml").read_text(), base_dir=SCENES), random.Random(0))
        started = time.perf_counter()
        try:
            for case in (only if only is not None else range(cases)):
                rng = random.Random(seed * 1_000_003 + case)
                surface = pick_surface(rng, surfaces)
                counts.cases += 1
                counts.surfaces[surface] = counts.surfaces.get(surface, 0) + 1
                counts.surface = surface
                if log:
                    with open(log, "a") as fh:
                        fh.write(f"{case} {surface}\n")
                try:
                    _one(surface, counts, rng, work, hostile, sources, documents, case, time_limit, render_time_limit,
                         render_share, measure_memory, show)
                except Exception:  # a bug of the fuzzer's own (a case it could not build): said, and the run goes on
                    _untimed()
                    counts.fuzzer_errors.append(f"case {case} ({surface}): {traceback.format_exc()[-600:]}")
                finally:
                    if not keep:
                        shutil.rmtree(work / "cases" / f"c{case}", ignore_errors=True)
                if progress and (case + 1) % 500 == 0:
                    print(f"  {case + 1} cases, {time.perf_counter() - started:.0f} s, {counts.bad} bad", file=sys.stderr, flush=True)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
    return counts


def _one(surface, counts, rng, work, hostile, sources, documents, case, time_limit, render_time_limit, render_share, measure_memory, show):
    if surface == "states":
        _state(counts, rng, work, case, time_limit)
    elif surface == "paths":
        _path(counts, rng, hostile, case, time_limit, measure_memory)
    elif surface == "includes":
        _includes(counts, rng, work, case, documents, time_limit, measure_memory, show)
    elif surface == "set":
        _overrides(counts, rng, case, documents, time_limit, measure_memory, show)
    elif surface == "stdin":
        _stdin(counts, rng, work, case, documents, time_limit, measure_memory, show)
    elif surface == "meshes":
        _meshes(counts, rng, work, case, time_limit, render_time_limit, render_share, measure_memory, show)
    elif surface == "images":
        _images(counts, rng, work, case, time_limit, render_time_limit, render_share, measure_memory, show)
    elif surface == "outputs":
        # A render costs a process's worth of setup; a share of the cases only, the rest write a made-up film.
        _outputs_case(counts, rng, work, case, time_limit, render_time_limit, rng.random() < render_share, measure_memory, show)
    else:
        _scene(counts, rng, sources, documents, hostile, case, time_limit, render_time_limit, render_share, measure_memory, show)


def _timed(limit: float):
    signal.setitimer(signal.ITIMER_REAL, limit)


def _untimed():
    signal.setitimer(signal.ITIMER_REAL, 0)


def _failure(counts: Counts, label: str, what: str, detail: str) -> None:
    counts.failures.append((label, what, detail, counts.surface))


def _check_messages(counts: Counts, label: str, diagnostics) -> None:
    for d in diagnostics:
        if _RAW_CONTROL.search(str(d)):
            counts.raw_control += 1
            _failure(counts, label, "raw control character", repr(str(d))[:300])
            return


def _scene(counts, rng, sources, documents, hostile, case, time_limit, render_time_limit, render_share, measure_memory, show):
    source = rng.choice(sources)
    data = copy.deepcopy(documents[source])
    syntax = rng.choice(["yaml", "json"])
    names = [mutate(data, rng, hostile) for _ in range(rng.randint(1, 3))]
    text = dump(data, syntax)
    if rng.random() < 0.25:
        text, name = text_mutation(text, syntax, rng)
        names.append(name)
    label = f"case {case} ({source.name} as {syntax}: {', '.join(names)})"
    if measure_memory:
        tracemalloc.start()
    start = time.perf_counter()
    try:
        _timed(time_limit)
        try:
            loaded = loads(text, syntax, file=f"fuzz-{case}.{syntax}", base_dir=SCENES)
        finally:
            _untimed()
    except SceneError as exc:
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1] if measure_memory else 0
        diags = exc.diagnostics
        if diags and all(d.line >= 1 and d.column >= 1 for d in diags):
            counts.rejected_with_position += 1
        else:
            counts.rejected_without_position += 1
            _failure(counts, label, "rejection without a position", str(exc)[:300])
        _check_messages(counts, label, diags)
        counts.note_rejection(seconds, peak, label, str(diags[0]) if diags else "")
        if len(counts.shown) < show:
            counts.shown.append(f"{label}\n  {diags[0] if diags else ''}")
        return
    except Hang:
        counts.hangs += 1
        _failure(counts, label, "hang (validation)", text[:300])
        return
    except BaseException as exc:  # noqa: BLE001 - anything else is the bug this fuzzer looks for
        if isinstance(exc, KeyboardInterrupt):
            raise
        counts.tracebacks += 1
        _failure(counts, label, "traceback (validation)", traceback.format_exc()[-1500:])
        return
    finally:
        if measure_memory:
            tracemalloc.stop()
    counts.accepted += 1
    if rng.random() >= render_share:
        return
    from scenefmt.bounds import estimate_memory

    if estimate_memory(loaded.graph).placements > RENDER_PLACEMENTS:
        # Finite pixels do not depend on how many copies there are; flattening millions of them
        # in Python costs minutes (the scaling benchmark measures that).
        counts.too_big_to_render += 1
        return
    try:
        _timed(render_time_limit)
        try:
            finite = render_tiny(loaded, rng)
        finally:
            _untimed()
    except Hang:
        counts.hangs += 1
        _failure(counts, label, "hang (render)", text[:300])
        return
    except BaseException:  # noqa: BLE001
        counts.tracebacks += 1
        _failure(counts, label, "traceback (render)", traceback.format_exc()[-1500:])
        return
    counts.rendered += 1
    if not finite:
        counts.non_finite += 1
        _failure(counts, label, "non-finite pixels", text[:300])


def _state(counts, rng, work, case, time_limit):
    import numpy as np

    from renderer.state import StateError, load_state

    counts.states += 1
    label = f"case {case} (saved state)"
    path, key = state_case(rng, work)
    start = time.perf_counter()
    tracemalloc.start()
    try:
        _timed(time_limit)
        try:
            film = load_state(path, key)
        finally:
            _untimed()
    except StateError as exc:
        counts.rejected_with_position += 1  # the file, and what in it, are named
        counts.note_rejection(time.perf_counter() - start, tracemalloc.get_traced_memory()[1], label, str(exc))
        if _RAW_CONTROL.search(str(exc)):
            counts.raw_control += 1
            _failure(counts, label, "raw control character", repr(str(exc))[:300])
        return
    except Hang:
        counts.hangs += 1
        _failure(counts, label, "hang", "")
        return
    except BaseException:  # noqa: BLE001
        counts.tracebacks += 1
        _failure(counts, label, "traceback", traceback.format_exc()[-1500:])
        return
    finally:
        tracemalloc.stop()
    counts.accepted += 1
    counts.states_accepted += 1
    ok = (film.total.shape == film.total_sq.shape == (key.height, key.width, 3) and np.isfinite(film.total).all()
          and np.isfinite(film.total_sq).all() and film.samples >= 1)
    if not ok:
        counts.non_finite += 1
        _failure(counts, label, "an unusable state was accepted", "")


def _path(counts, rng, hostile, case, time_limit, measure_memory):
    from scenefmt.validation import load

    counts.paths += 1
    path = rng.choice(["/dev/zero", str(hostile / "zero.yaml"), str(hostile / "fifo"), str(hostile), str(hostile / "loop"),
                       str(hostile / "a\x00b.yaml"), str(hostile / ("x" * 300 + ".yaml")), str(hostile / "missing.yaml"),
                       "/proc/self/mem", "/dev/stdin"])
    label = f"case {case} (path {path[:60]!r})"
    start = time.perf_counter()
    try:
        _timed(time_limit)
        try:
            load(path)
        finally:
            _untimed()
    except SceneError as exc:
        counts.rejected_with_position += 1
        counts.note_rejection(time.perf_counter() - start, 0, label, str(exc.diagnostics[0]))
        _check_messages(counts, label, exc.diagnostics)
        return
    except Hang:
        counts.hangs += 1
        _failure(counts, label, "hang", "")
        return
    except BaseException:  # noqa: BLE001
        counts.tracebacks += 1
        _failure(counts, label, "traceback", traceback.format_exc()[-1500:])
        return
    counts.accepted += 1


# ----------------------------------------------------------------------------------------------
# Running the new surfaces


def _case_folder(work: Path, case: int) -> Path:
    folder = work / "cases" / f"c{case}"
    folder.mkdir(parents=True)
    return folder


def _check_text(counts: Counts, label: str, lines, detail: str = "") -> None:
    """Count a raw control character or the secret marker in what a user would read."""
    lines = [piece for line in lines for piece in re.split(r"[\r\n]", str(line))]
    for line in lines:
        if _RAW_CONTROL.search(line):
            counts.raw_control += 1
            _failure(counts, label, "raw control character", repr(line)[:300] + ("\n" + detail if detail else ""))
            break
    for line in lines:
        if SECRET in line:
            counts.echoed += 1
            _failure(counts, label, "echoed file contents", line[:300] + ("\n" + detail if detail else ""))
            break


@contextlib.contextmanager
def _native_stderr(sink: list):
    """Catch what native code (a C library) writes straight to file descriptor 2, past sys.stderr:
    a user sees it too. The text is appended to `sink`."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as tmp:
        os.dup2(tmp.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            tmp.seek(0)
            sink.append(tmp.read(4096).decode("utf-8", "replace"))


def _note_native(counts: Counts, label: str, sink: list) -> None:
    text = "".join(sink).strip()
    if text:
        counts.native_output += 1
        first = text.splitlines()[0]
        key = re.sub(r"\d+", "N", first)[:80]
        counts.native_examples.setdefault(key, (label, first[:200]))


def _trial(counts: Counts, label: str, action, time_limit: float, measure_memory: bool, detail: str = "",
           show: int = 0, what: str = "validation", again: bool = False):
    """Run `action()` under the time limit with its output captured. A `SceneError` or a `Stop` (the
    command refused, with a message) is a rejection; anything else a traceback.
    Returns (accepted, value). `again`: the action may be run twice (it reads files, changes nothing)."""
    from rt.render_job import Stop

    out = io.StringIO()
    native: list = []
    hung = False
    if measure_memory:
        tracemalloc.start()
    start = time.perf_counter()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out), _native_stderr(native):
            _timed(time_limit)
            try:
                value = action()
            finally:
                _untimed()
    except (SceneError, Stop) as exc:
        seconds = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1] if measure_memory else 0
        if isinstance(exc, SceneError):
            messages = [str(d) for d in exc.diagnostics]
            placed = bool(exc.diagnostics) and all(d.line >= 1 and d.column >= 1 for d in exc.diagnostics)
        else:
            messages = []  # the command printed its message
            placed = True  # and it names the file or option
        messages += out.getvalue().splitlines()
        if placed and any(m.strip() for m in messages):
            counts.rejected_with_position += 1
        else:
            counts.rejected_without_position += 1
            _failure(counts, label, "rejection without a position", ("\n".join(messages) or "(no message)")[:300] + "\n" + detail)
        _check_text(counts, label, messages, detail)
        first = next((m for m in messages if m.strip()), "")
        counts.note_rejection(seconds, peak, label, first)
        if len(counts.shown) < show:
            counts.shown.append(f"{label}\n  {first}")
        return False, None
    except Hang:
        hung = True  # handled below, once this frame's exception (and all it holds) is gone
    except BaseException as exc:  # noqa: BLE001 - anything else is the bug this fuzzer looks for
        if isinstance(exc, KeyboardInterrupt):
            raise
        counts.tracebacks += 1
        _failure(counts, label, f"traceback ({what})", traceback.format_exc()[-1500:] + "\n" + detail)
        return False, None
    finally:
        if tracemalloc.is_tracing():
            tracemalloc.stop()
        _note_native(counts, label, native)
    if hung:
        if measure_memory and again:
            # Tracing every allocation slows a parse of 300,000 values tenfold: time the case once
            # more untraced, and count a hang only if it still runs past the limit.
            counts.slow_traced += 1
            return _trial(counts, label, action, time_limit, False, detail, show, what, again=False)
        counts.hangs += 1
        _failure(counts, label, f"hang ({what})", detail)
        return False, None
    _check_text(counts, label, out.getvalue().splitlines() + [str(w) for w in getattr(value, "warnings", ())], detail)
    counts.accepted += 1
    return True, value


def _guarded(counts: Counts, label: str, limit: float, step, stage: str, detail: str) -> tuple[bool, object]:
    """(True, what `step` returns) within `limit` seconds. Otherwise (False, None), counted: a
    ValueError is the documented refusal of an image that does not decode (its text checked for
    echoes), a Hang or any other exception a failure of `stage` (render, decoding)."""
    try:
        _timed(limit)
        try:
            return True, step()
        finally:
            _untimed()
    except ValueError as exc:
        counts.decode_refused += 1
        _check_text(counts, label, [str(exc)], detail)
    except Hang:
        counts.hangs += 1
        _failure(counts, label, f"hang ({stage})", detail)
    except BaseException:  # noqa: BLE001
        counts.tracebacks += 1
        _failure(counts, label, f"traceback ({stage})", traceback.format_exc()[-1500:] + "\n" + detail)
    return False, None


def _render_accepted(counts: Counts, label: str, loaded, rng, render_time_limit: float, detail: str) -> None:
    """Render an accepted scene tiny; an image that does not decode is the documented ValueError."""
    ok, finite = _guarded(counts, label, render_time_limit, lambda: render_tiny(loaded, rng), "render", detail)
    if not ok:
        return
    counts.rendered += 1
    if not finite:
        counts.non_finite += 1
        _failure(counts, label, "non-finite pixels", detail)


def _includes(counts, rng, work, case, documents, time_limit, measure_memory, show):
    from scenefmt.validation import load_source

    folder = _case_folder(work, case)
    main, kinds, files = include_case(rng, folder, documents)
    label = f"case {case} (includes: {', '.join(kinds)})"
    detail = f"rt validate {main.name}  # in a folder holding:\n" + _writes(files)
    _trial(counts, label, lambda: load_source(str(main)), time_limit, measure_memory, detail, show, again=True)


def _overrides(counts, rng, case, documents, time_limit, measure_memory, show):
    from scenefmt.validation import load_source

    source = SCENES / rng.choice(SMALL_SCENES)
    args, names = set_arguments(documents[source], rng)
    label = f"case {case} (--set on {source.name}: {'; '.join(names)})"
    shown = " ".join("--set " + repr(a if len(a) < 120 else a[:60] + f"...({len(a):,} characters)..." + a[-30:]) for a in args[:6])
    detail = f"rt validate scenes/{source.name} {shown}" + (f" ... ({len(args)} --set in all)" if len(args) > 6 else "")
    _trial(counts, label, lambda: load_source(str(source), args), time_limit, measure_memory, detail, show, again=True)


def _stdin(counts, rng, work, case, documents, time_limit, measure_memory, show):
    from scenefmt.validation import load_source

    folder = _case_folder(work, case)
    link_book_files(folder)
    stream, name, raw = stdin_case(rng, documents)
    syntax = rng.choice([None, None, "yaml", "json"])
    label = f"case {case} (stdin: {name}" + (f", --format {syntax})" if syntax else ")")
    detail = f"rt validate -{' --format ' + syntax if syntax else ''} < " + (repr(raw[:300]) if raw is not None else name)
    saved, here = sys.stdin, os.getcwd()

    def action():
        sys.stdin = stream
        os.chdir(folder)
        try:
            return load_source("-", (), syntax)
        finally:
            sys.stdin = saved
            os.chdir(here)

    _trial(counts, label, action, time_limit, measure_memory, detail, show)


def _meshes(counts, rng, work, case, time_limit, render_time_limit, render_share, measure_memory, show):
    from scenefmt.validation import load_source

    folder = _case_folder(work, case)
    name, what, files = mesh_case(rng, folder)
    shape = {"type": "mesh", "file": name, "material": "m", "smooth": rng.random() < 0.3}
    if rng.random() < 0.2:
        shape["transform"] = hostile_transform(rng)
    scene = small_scene([shape, {"type": "sphere", "center": [0, 0, -3], "radius": 0.5, "material": "m"}])
    (folder / "scene.yaml").write_text(dump(scene, "yaml"))
    label = f"case {case} (mesh: {what})"
    detail = "rt validate scene.yaml  # a scene with {type: mesh, file: %s}; the folder holds:\n%s" % (name, _writes(files))
    ok, loaded = _trial(counts, label, lambda: load_source(str(folder / "scene.yaml")), time_limit, measure_memory, detail, show, again=True)
    if ok and rng.random() < render_share:
        _render_accepted(counts, label, loaded, rng, render_time_limit, detail)


def _images(counts, rng, work, case, time_limit, render_time_limit, render_share, measure_memory, show):
    import numpy as np

    from renderer.textures import load_image_texels
    from scenefmt.validation import load_source

    folder = _case_folder(work, case)
    name, what, files = image_case(rng, folder)
    scene, roles = image_scene(rng, name)
    (folder / "scene.yaml").write_text(dump(scene, "yaml"))
    label = f"case {case} (image as {' and '.join(roles)}: {what})"
    detail = f"rt render scene.yaml  # the image {name} as {' and '.join(roles)}; the folder holds:\n" + _writes(files)
    ok, loaded = _trial(counts, label, lambda: load_source(str(folder / "scene.yaml")), time_limit, measure_memory, detail, show, again=True)
    if not ok:
        return
    # Validation reads headers (and float images); the pixels are decoded when the scene is compiled.
    colorspace = scene["materials"]["m"].get("albedo", scene["materials"]["m"].get("emit", {})) if "texture" in roles else {}
    space = colorspace.get("colorspace", "srgb") if isinstance(colorspace, dict) else "srgb"
    ok, texels = _guarded(counts, label, time_limit, lambda: load_image_texels(folder / name, space), "decoding", detail)
    if not ok:
        return
    if not (np.isfinite(texels).all() and (texels >= 0).all()):
        counts.non_finite += 1
        _failure(counts, label, "non-finite or negative texels accepted", detail)
        return
    if rng.random() < render_share:
        _render_accepted(counts, label, loaded, rng, render_time_limit, detail)


def _digest(path: Path):
    try:
        return path.read_bytes()
    except OSError as exc:
        return f"unreadable: {exc}"


def _outputs_case(counts, rng, work, case, time_limit, render_time_limit, render, measure_memory, show):
    import numpy as np

    from renderer.film import Film
    from renderer.state import RenderKey
    from rt.outputs import write_outputs
    from rt.render_job import RenderOptions, fail, prepare, render_prepared

    counts.outputs += 1
    folder = _case_folder(work, case)
    options, files, what = output_case(rng, folder)
    before = {name: _digest(folder / name) for name in OUTPUT_INPUTS}
    opts = RenderOptions(scene=Path(options["scene"]), output=_opt_path(options["output"]), hdr=_opt_path(options["hdr"]),
                         noise_map=_opt_path(options["noise_map"]), save_state=_opt_path(options["save_state"]),
                         resume=_opt_path(options["resume"]), spp=1, width=4, max_depth=2)
    flags = " ".join(f"--{k.replace('_', '-')} {v}" for k, v in options.items() if v is not None and k != "scene")
    label = f"case {case} (outputs: {what})"
    detail = f"rt render {options['scene']} {flags} --spp 1 --width 4" + (" < scene.yaml" if options["scene"] == "-" else "") + \
        "  # in a folder holding scene.yaml (include: [inc.yaml]; tex.png, sky.pfm, mesh.obj), state.npz, link.png -> tex.png, hard.png (a hard link)"
    saved, here = sys.stdin, os.getcwd()

    def action():
        sys.stdin = io.TextIOWrapper(io.BytesIO((folder / "scene.yaml").read_bytes()))
        os.chdir(folder)
        try:
            scene = prepare(opts)
            if render:
                _timed(render_time_limit)
                render_prepared(opts, scene, time.perf_counter())
                return None
            # Without rendering: write what a render of this size would, through the same function.
            frame = scene.frame
            film = Film(np.full((frame.height, frame.width, 3), 0.25), np.full((frame.height, frame.width, 3), 0.1), 2)
            key = RenderKey(scene.fingerprint, frame.width, frame.height, frame.max_depth, frame.seed, frame.integrator) \
                if scene.fingerprint is not None else None
            write_outputs(opts, film, key, fail)
            return None
        finally:
            sys.stdin = saved
            os.chdir(here)

    _trial(counts, label, action, time_limit, measure_memory, detail, show, what="render" if render else "outputs")
    changed = [name for name in OUTPUT_INPUTS if _digest(folder / name) != before[name]]
    if changed:
        counts.overwritten += 1
        _failure(counts, label, "input overwritten", f"{', '.join(changed)} changed by: {detail}")


def _opt_path(value):
    return None if value is None else Path(value)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--render-share", type=float, default=0.1, help="share of accepted scenes rendered tiny (0 to 1)")
    parser.add_argument("--no-render", action="store_true", help="validation only (no Numba)")
    parser.add_argument("--time-limit", type=float, default=10.0, help="seconds a validation or state case may take")
    parser.add_argument("--no-memory", action="store_true", help="do not trace peak memory (faster)")
    parser.add_argument("--show", type=int, default=0, help="print this many rejections")
    parser.add_argument("--surfaces", default=",".join(SURFACES),
                        help=f"comma-separated surfaces to fuzz (default all: {','.join(SURFACES)})")
    parser.add_argument("--case", action="append", help="replay only this case number, or a range FIRST-LAST (repeatable)")
    parser.add_argument("--log", metavar="FILE", help="append each case's number and surface to FILE before it runs (to find a crash)")
    parser.add_argument("--keep", metavar="DIR", help="build the cases' files in DIR and leave them there")
    parser.add_argument("--memory-limit", type=float, default=3.0, metavar="GIB",
                        help="address-space limit of the process, so a case that asks for too much ends in MemoryError (0: none)")
    args = parser.parse_args(argv)
    if args.memory_limit > 0:
        import resource

        limit = int(args.memory_limit * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    started = time.perf_counter()
    surfaces = [s.strip() for s in args.surfaces.split(",") if s.strip()]
    only = None
    if args.case:
        only = [k for spec in args.case for k in (range(int(spec.split("-")[0]), int(spec.split("-")[1]) + 1) if "-" in spec else [int(spec)])]
    counts = run(args.cases, args.seed, 0.0 if args.no_render else args.render_share, args.time_limit,
                 measure_memory=not args.no_memory, show=args.show, progress=True, surfaces=surfaces, only=only,
                 keep=args.keep, log=args.log)
    for item in counts.shown:
        print(item)
    print(counts.report())
    print(f"time: {time.perf_counter() - started:.1f} s")
    return 1 if counts.bad else 0


if __name__ == "__main__":
    sys.exit(main())
