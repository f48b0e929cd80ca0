"""A mutation fuzzer over the book scenes, saved render states and hostile paths.

    python tests/fuzz.py --cases 10000 --seed 1             # validation, a tenth of accepted scenes rendered
    python tests/fuzz.py --cases 2000 --render-share 1       # render every accepted scene (4x4, 1-2 spp)
    python tests/fuzz.py --cases 500 --no-render --show 5    # validation only; print 5 rejections

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

Every case runs under a time limit (a hang is a case that exceeds it). The counts printed:
cases, accepted, rejected with a position (file:line:col), rejected without one, tracebacks
(any exception other than the documented refusal), non-finite pixels or noise figures, hangs,
and diagnostics that print a raw control character; then the slowest and the largest (peak
Python memory, traced) rejections. The exit status is 1 if any traceback, non-finite pixel,
hang or raw control character was seen. `run(...)` does the same from Python (tests/test_fuzz.py).
"""

from __future__ import annotations

import argparse
import copy
import io
import json
import math
import os
import random
import re
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
    slowest: list = field(default_factory=list)  # (seconds, label, first message)
    largest: list = field(default_factory=list)  # (peak bytes, label, first message)
    failures: list = field(default_factory=list)  # (label, what, detail)
    shown: list = field(default_factory=list)

    @property
    def bad(self) -> int:
        return self.tracebacks + self.non_finite + self.hangs + self.raw_control

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
            f"hangs: {self.hangs}",
            f"raw control characters in messages: {self.raw_control}",
            f"(of the cases: {self.states} saved states, {self.states_accepted} of them accepted; {self.paths} hostile paths)",
            "slowest rejections:",
        ]
        lines += [f"  {s * 1000:8.1f} ms  {label}: {msg[:150]}" for s, label, msg in self.slowest]
        lines.append("largest rejections (peak traced Python memory):")
        lines += [f"  {peak / 2**20:8.1f} MiB  {label}: {msg[:150]}" for peak, label, msg in self.largest]
        for label, what, detail in self.failures[:20]:
            lines.append(f"FAILURE {what} in {label}:\n{detail}")
        return "\n".join(lines)


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


def run(cases: int, seed: int, render_share: float = 0.1, time_limit: float = 10.0, render_time_limit: float = 120.0,
        measure_memory: bool = True, show: int = 0, progress: bool = False) -> Counts:
    rng = random.Random(seed)
    counts = Counts()
    sources = sorted(p for p in SCENES.iterdir() if p.suffix in (".yaml", ".json"))
    documents = {p: parse_file(p).data for p in sources}
    previous = signal.signal(signal.SIGALRM, _alarm)
    with tempfile.TemporaryDirectory(prefix="rt-fuzz-") as tmp:
        work = Path(tmp)
        hostile = prepare_hostile_dir(work)
        started = time.perf_counter()
        try:
            for case in range(cases):
                counts.cases += 1
                roll = rng.random()
                if roll < 0.06:
                    _state(counts, rng, work, case, time_limit)
                elif roll < 0.08:
                    _path(counts, rng, hostile, case, time_limit, measure_memory)
                else:
                    _scene(counts, rng, sources, documents, hostile, case, time_limit, render_time_limit,
                           render_share, measure_memory, show)
                if progress and (case + 1) % 500 == 0:
                    print(f"  {case + 1} cases, {time.perf_counter() - started:.0f} s, {counts.bad} bad", file=sys.stderr, flush=True)
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
    return counts


def _timed(limit: float):
    signal.setitimer(signal.ITIMER_REAL, limit)


def _untimed():
    signal.setitimer(signal.ITIMER_REAL, 0)


def _failure(counts: Counts, label: str, what: str, detail: str) -> None:
    counts.failures.append((label, what, detail))


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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--render-share", type=float, default=0.1, help="share of accepted scenes rendered tiny (0 to 1)")
    parser.add_argument("--no-render", action="store_true", help="validation only (no Numba)")
    parser.add_argument("--time-limit", type=float, default=10.0, help="seconds a validation or state case may take")
    parser.add_argument("--no-memory", action="store_true", help="do not trace peak memory (faster)")
    parser.add_argument("--show", type=int, default=0, help="print this many rejections")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    counts = run(args.cases, args.seed, 0.0 if args.no_render else args.render_share, args.time_limit,
                 measure_memory=not args.no_memory, show=args.show, progress=True)
    for item in counts.shown:
        print(item)
    print(counts.report())
    print(f"time: {time.perf_counter() - started:.1f} s")
    return 1 if counts.bad else 0


if __name__ == "__main__":
    sys.exit(main())
