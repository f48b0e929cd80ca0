"""Reading Wavefront material libraries (.mtl) and choosing our nearest material for each entry.

An OBJ file names its library with `mtllib` and picks an entry per face with `usemtl`. The
format is the Phong-era description of Alias|Wavefront (diffuse `Kd`, specular `Ks` with exponent
`Ns`, transparency `d`/`Tr`, index `Ni`, an `illum` model number, image maps), extended by
exporters with `Ke` (emission) and the PBR keys `Pr`, `Pm`, `Pc`, `Pcr`. The reader has two steps:

- `read_mtl(path)` / `parse_mtl(data)`: the library's entries, their values and map names, and a
  warning for every statement that has no equivalent here (one per keyword per file, with the
  first line and how many more), all bounded: the file's size, the number of entries, the length
  of a name; a NUL byte, a malformed number or a count out of range is an `MtlProblem` naming the
  line. Nothing read is shown in a message but through `quote_key` / `quote_text`.
- `material_of(entry, map_file)`: the pydantic material for one entry, by the rules of the table
  in docs/meshes.md ("Materials from a .mtl file"), and the warnings of that choice (what was
  dropped, with its line). Maps become image textures; `map_file` says which file each is
  (resolving it is the caller's job: named_files' rule, relative to the library's folder).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Callable, Optional

from .diagnostics import key_shown, quote_key
from .files import FileProblem, LineProblem, read_regular_file

# Bounds on a library: a real one is kilobytes with tens of entries.
MAX_MTL_BYTES = 8 << 20
MAX_MTL_MATERIALS = 65_536
MAX_NAME_CHARS = 1024
# Bounds on an OBJ's use of libraries: each library is a file to find and read, each material a
# mesh of its own (a tree, a node); real assets name one library and up to some hundreds.
MAX_LIBRARIES = 64
MAX_OBJ_MATERIALS = 10_000
# The material of faces whose `usemtl` names no entry of the library (or that come before any):
# the light grey most OBJ viewers draw them in.
DEFAULT_ALBEDO = (0.8, 0.8, 0.8)
# The index of refraction when a transparent entry gives none above 1 (Ni 1 is the usual
# exporters' "not set"); the coat of a plastic likewise.
DEFAULT_IOR = 1.5

# Keywords read, and what each number means (for messages).
_COLOURS = {"Kd", "Ks", "Ka", "Ke", "Tf"}
_NUMBERS = {"Ns", "Ni", "d", "Tr", "Pr", "Pm", "Pc", "Pcr", "illum", "sharpness", "Ps", "aniso", "anisor"}
_MAPS = {"map_Kd", "map_Ks", "map_Ka", "map_Ns", "map_d", "map_Ke", "map_bump", "bump", "norm", "disp", "decal", "refl",
         "map_Pr", "map_Pm", "map_Ps", "map_refl", "map_Tr", "map_Disp", "map_Norm"}
# What has no equivalent in our materials: dropped with a warning naming the keyword.
_DROPPED = {
    "Ka": "ambient colour: a path tracer has no ambient term",
    "map_Ka": "ambient colour map",
    "Tf": "transmission filter colour",
    "sharpness": "reflection-map sharpness",
    "map_Ks": "specular colour map",
    "map_Ns": "specular exponent map",
    "map_d": "opacity map (cut-outs)",
    "map_Tr": "opacity map (cut-outs)",
    "map_Ke": "emission map",
    "disp": "displacement map",
    "map_Disp": "displacement map",
    "decal": "decal map",
    "refl": "reflection map",
    "map_refl": "reflection map",
    "map_Pr": "roughness map",
    "map_Pm": "metallic map",
    "map_Ps": "sheen map",
    "Ps": "sheen",
    "aniso": "anisotropy",
    "anisor": "anisotropy rotation",
}
# Keys a material of each kind leaves unread without a warning: exporters write them for every
# entry (Blender: Ns, Ni and illum always), and they ask for nothing that kind could show.
_QUIET = {
    "lambertian": ("Ns", "Ni", "illum", "Ks"),
    "metal": ("Ni", "Kd"),
    "diffuse_light": ("Ns", "Ni", "illum", "Ks"),
    "dielectric": ("Ns", "Ks", "Ka"),
    "plastic": (),
    "principled": ("illum",),
}
# Options a map statement may carry, and how many values each takes (`-o`, `-s`, `-t`: 1 to 3).
_MAP_OPTIONS = {"-blendu": 1, "-blendv": 1, "-boost": 1, "-mm": 2, "-o": 3, "-s": 3, "-t": 3, "-texres": 1,
                "-clamp": 1, "-bm": 1, "-imfchan": 1, "-type": 1, "-cc": 1}


class MtlProblem(LineProblem):
    """A material library cannot be used; `line` is the 1-based line where one is known."""


@dataclass
class MapRef:
    """An image map: the file as the library names it, its line, and its options (name -> values)."""

    file: str
    line: int
    options: dict = field(default_factory=dict)


@dataclass
class MtlEntry:
    """One `newmtl` entry: its values (keyword -> (numbers, line)) and maps (keyword -> MapRef)."""

    name: str
    line: int
    values: dict = field(default_factory=dict)
    maps: dict = field(default_factory=dict)

    def number(self, key: str) -> Optional[float]:
        return self.values[key][0][0] if key in self.values else None

    def colour(self, key: str) -> Optional[tuple]:
        return self.values[key][0] if key in self.values else None

    def line_of(self, key: str) -> int:
        got = self.values.get(key) or self.maps.get(key)
        return got[1] if isinstance(got, tuple) else got.line


@dataclass
class MtlLibrary:
    """The entries of a library by name (the first of a repeated name), and its file-level
    warnings as (line, message)."""

    materials: dict
    warnings: list


def read_mtl(path) -> MtlLibrary:
    """The library in the file at `path` (a regular file of at most MAX_MTL_BYTES); raises MtlProblem."""
    try:
        data = read_regular_file(path, MAX_MTL_BYTES)
    except FileProblem as exc:
        raise MtlProblem(str(exc)) from None
    return parse_mtl(data)


def _name(raw: bytes) -> str:
    """A `newmtl` name, decoded as the OBJ reader decodes a `usemtl` one (meshfile._MaterialStatements)."""
    return raw.strip().decode("utf-8", "replace")


def _shown(word: str) -> str:
    return f"'{word}'" if key_shown(word) else f"a word of {len(word)} characters (not shown)"


def parse_mtl(data: bytes) -> MtlLibrary:
    """The entries of library text `data`, checked line by line (see the module's docstring)."""
    nul = data.find(b"\0")
    if nul >= 0:
        raise MtlProblem(f"not a material library text file: byte {nul + 1:,} is a NUL byte")
    materials: dict = {}
    dropped: dict = {}  # keyword -> [first line, count]: one warning per keyword per file
    warnings: list = []
    current: Optional[MtlEntry] = None
    for number, raw in enumerate(data.split(b"\n"), 1):
        words = raw.split(b"#", 1)[0].split()
        if not words:
            continue
        key = words[0].decode("ascii", "replace")
        if key == "newmtl":
            name = _name(raw.split(b"#", 1)[0].strip()[len(b"newmtl"):])
            if not name:
                raise MtlProblem("newmtl needs a name", number)
            if len(name) > MAX_NAME_CHARS:
                raise MtlProblem(f"a material name of {len(name):,} characters, more than the {MAX_NAME_CHARS:,} allowed", number)
            if name in materials:
                warnings.append((number, f"material {quote_key(name)} is defined again (first on line "
                                         f"{materials[name].line}); the first definition is used"))
                current = MtlEntry(name, number)  # read, to check it, and left out
                continue
            if len(materials) >= MAX_MTL_MATERIALS:
                raise MtlProblem(f"more than the {MAX_MTL_MATERIALS:,} materials allowed", number)
            current = materials[name] = MtlEntry(name, number)
            continue
        if key in _COLOURS or key in _NUMBERS or key in _MAPS or key in _DROPPED:
            if current is None:
                _count(dropped, f"{key} before any newmtl", number)
                continue
            if key in _MAPS:
                current.maps[key] = _map(words[1:], key, number)
            else:
                values = _values(words[1:], key, number)
                if values is None:  # a spectral or CIE XYZ colour
                    _count(dropped, f"{key} as a spectral or xyz colour", number)
                    continue
                current.values[key] = (values, number)
            if key in _DROPPED:
                _count(dropped, f"{key} ({_DROPPED[key]})", number)
            continue
        _count(dropped, f"unknown statement {_shown(key)}", number)
    for what, (first, count) in dropped.items():
        more = f" (and {count - 1:,} more line{'s' if count > 2 else ''})" if count > 1 else ""
        warnings.append((first, f"{what} has no equivalent and is dropped{more}"))
    warnings.sort(key=lambda w: w[0])
    return MtlLibrary(materials, warnings)


def _count(dropped: dict, what: str, line: int) -> None:
    if what in dropped:
        dropped[what][1] += 1
    else:
        dropped[what] = [line, 1]


def _float(word: bytes, key: str, line: int) -> float:
    try:
        value = float(word)
    except ValueError:
        raise MtlProblem(f"{key} expects numbers: {_shown(word.decode('utf-8', 'replace'))} is not one", line) from None
    if not math.isfinite(value):
        raise MtlProblem(f"{key} has a NaN or infinite value", line)
    return value


def _values(words: list, key: str, line: int) -> Optional[tuple]:
    """The numbers of a colour (1 number: a grey; 3: r g b) or a single value; None for a
    spectral or xyz colour."""
    if key in _COLOURS:
        if words and words[0] in (b"spectral", b"xyz"):
            return None
        if len(words) not in (1, 3):
            raise MtlProblem(f"{key} needs 1 or 3 numbers, found {len(words)}", line)
        values = tuple(_float(w, key, line) for w in words)
        if min(values) < 0:
            raise MtlProblem(f"{key} must not be negative, found {min(values):g}", line)
        return values * 3 if len(values) == 1 else values
    if key == "d" and words and words[0] == b"-halo":
        words = words[1:]  # the halo form: read as the plain opacity, and said below
    if len(words) != 1:
        raise MtlProblem(f"{key} needs 1 number, found {len(words)}", line)
    value = _float(words[0], key, line)
    if key == "illum" and (value != int(value) or not 0 <= value <= 10):
        raise MtlProblem(f"illum must be a whole number from 0 to 10, found {value:g}", line)
    if value < 0:
        raise MtlProblem(f"{key} must not be negative, found {value:g}", line)
    return (value,)


def _map(words: list, key: str, line: int) -> MapRef:
    """A map statement's options and file name (the rest of the line: names may hold spaces)."""
    options: dict = {}
    k = 0
    while k < len(words) and words[k].startswith(b"-"):
        option = words[k].decode("ascii", "replace")
        if option not in _MAP_OPTIONS:
            shown = f"'{option}'" if re.fullmatch(r"-[A-Za-z_]{1,16}", option) else _shown(option)
            raise MtlProblem(f"{key}: unknown option {shown}", line)
        most = _MAP_OPTIONS[option]
        k += 1
        values = []
        while k < len(words) and len(values) < most:
            try:
                value = float(words[k])
                if not math.isfinite(value):
                    raise MtlProblem(f"{key}: option {option} has a NaN or infinite value", line)
                values.append(value)
            except ValueError:
                if option in ("-blendu", "-blendv", "-clamp", "-imfchan", "-type", "-cc"):
                    values.append(words[k].decode("ascii", "replace"))  # on/off, a channel, a word
                else:
                    break
            k += 1
        if not values:
            raise MtlProblem(f"{key}: option {option} needs a value", line)
        options[option] = values
    name = b" ".join(words[k:]).decode("utf-8", "replace").replace("\\", "/")  # exporters on Windows write \
    if not name:
        raise MtlProblem(f"{key} names no file", line)
    if len(name) > 4096:
        raise MtlProblem(f"{key}: a file name of {len(name):,} characters, more than the 4,096 allowed", line)
    return MapRef(name, line, options)


# --- choosing our material ----------------------------------------------------------------------


def alpha_of_exponent(ns: float) -> float:
    """The microfacet width alpha of a Phong exponent Ns: sqrt(2 / (Ns + 2)), the Beckmann width of
    the same highlight (Walter et al. 2007, section 5.2), used as the GGX width; in [0.001, 1]."""
    return min(1.0, max(1e-3, math.sqrt(2.0 / (ns + 2.0))))


def kind_of_entry(entry: MtlEntry) -> str:
    """Which of our materials an entry becomes: the rules of docs/meshes.md, in their order."""
    illum = entry.number("illum")
    d = _opacity(entry)
    ke = entry.colour("Ke")
    if any(k in entry.values for k in ("Pr", "Pm", "Pc", "Pcr")):
        return "principled"
    if (d is not None and d < 1.0) or illum in (4, 6, 7, 9):
        return "dielectric"
    if ke is not None and max(ke) > 0:
        kd = entry.colour("Kd")
        dark = "map_Kd" not in entry.maps and (kd is None or max(kd) <= 0)
        return "diffuse_light" if dark else "principled"
    if illum in (3, 5, 8):
        return "metal"
    ks = entry.colour("Ks")
    if ks is not None and max(ks) > 0 and illum not in (0, 1):
        return "plastic"
    return "lambertian"


def _opacity(entry: MtlEntry) -> Optional[float]:
    """d, or 1 - Tr, whichever the entry wrote last; None if neither."""
    d, tr = entry.values.get("d"), entry.values.get("Tr")
    if d is not None and (tr is None or d[1] >= tr[1]):
        return d[0][0]
    if tr is not None:
        return 1.0 - tr[0][0]
    return None


def material_of(entry: MtlEntry, map_file: Callable[[str, MapRef], Optional[str]]):
    """(our material model, [(line, warning)]) for one entry. `map_file(key, ref)` gives the file
    an image texture of map `key` reads (None: it could not be used, and the caller said why)."""
    from . import materials as m
    from .textures import ImageTexture

    warnings: list = []
    kind = kind_of_entry(entry)
    used: set = set()

    def colour(key: str, default: tuple, cap: Optional[float] = None) -> tuple:
        value = entry.colour(key)
        if value is None:
            return default
        used.add(key)
        if cap is not None and max(value) > cap:
            warnings.append((entry.line_of(key), f"{key} {max(value):g} is above {cap:g}, the most a surface reflects: "
                                                 f"clamped to {cap:g}"))
            value = tuple(min(v, cap) for v in value)
        return value

    def image(key: str, colorspace: str) -> Optional[object]:
        ref = entry.maps.get(key)
        if ref is None:
            return None
        used.add(key)
        dropped = sorted(o for o in ref.options if o != "-bm")
        if dropped:
            warnings.append((ref.line, f"{key}: option{'s' if len(dropped) > 1 else ''} {', '.join(dropped)} "
                                       "ha{} no equivalent and {} dropped".format("ve" if len(dropped) > 1 else "s",
                                                                                  "are" if len(dropped) > 1 else "is")))
        file = map_file(key, ref)
        return None if file is None else ImageTexture(file=file, colorspace=colorspace)

    def reflectance() -> object:
        texture = image("map_Kd", "srgb")
        if texture is not None:
            used.add("Kd")  # the format multiplies Kd by the map; the image stands alone here (docs/meshes.md)
            return texture
        return colour("Kd", DEFAULT_ALBEDO, 1.0)

    def ior() -> float:
        ni = entry.number("Ni")
        if ni is not None:
            used.add("Ni")
        return ni if ni is not None and ni > 1.0 else DEFAULT_IOR

    def surface_maps() -> dict:
        out = {}
        normal = image("norm", "linear") or image("map_Norm", "linear")
        bump_key = "map_bump" if "map_bump" in entry.maps else ("bump" if "bump" in entry.maps else None)
        if normal is not None:
            out["normal_map"] = normal
            if bump_key:
                used.add(bump_key)
                warnings.append((entry.maps[bump_key].line, f"{bump_key} is dropped: the entry has a normal map (norm), "
                                                            "and a surface takes one or the other"))
        elif bump_key:
            ref = entry.maps[bump_key]
            if "-bm" not in ref.options or not isinstance(ref.options["-bm"][0], float):
                used.add(bump_key)
                warnings.append((ref.line, f"{bump_key} without -bm gives no height for the map's values: dropped "
                                           "(add -bm with the height in scene units of a value of 1)"))
            else:
                bump = image(bump_key, "linear")
                if bump is not None:
                    out["bump_map"] = bump
                    out["bump_height"] = ref.options["-bm"][0]
        return out

    ns = entry.number("Ns")
    if kind == "principled":
        pr = entry.number("Pr")
        model = m.Principled(
            base_color=reflectance(),
            metallic=min(1.0, entry.number("Pm") or 0.0),
            roughness=min(1.0, pr if pr is not None else (math.sqrt(alpha_of_exponent(ns)) if ns is not None else 0.5)),
            ior=ior(),
            transmission=1.0 - _opacity(entry) if _opacity(entry) is not None and _opacity(entry) < 1.0 else 0.0,
            clearcoat=min(1.0, entry.number("Pc") or 0.0),
            clearcoat_roughness=min(1.0, entry.number("Pcr") or 0.0),
            emission=colour("Ke", (0.0, 0.0, 0.0)),
            **surface_maps(),
        )
        used.update(k for k in ("Pr", "Pm", "Pc", "Pcr", "d", "Tr", "Ns") if k in entry.values)
    elif kind == "dielectric":
        d = _opacity(entry)
        if d is not None and 0.0 < d < 1.0 and entry.number("illum") not in (4, 6, 7, 9):
            key = "d" if "d" in entry.values else "Tr"
            warnings.append((entry.line_of(key), f"partial opacity ({key} {entry.number(key):g}) has no equivalent: "
                                                 "the surface is clear glass"))
        if entry.number("Ni") is None or entry.number("Ni") <= 1.0:
            warnings.append((entry.line, f"a transparent material without Ni above 1 gets ior {DEFAULT_IOR:g}"))
        model = m.Dielectric(ior=ior(), **surface_maps())
        used.update(k for k in ("d", "Tr", "illum") if k in entry.values)
    elif kind == "diffuse_light":
        model = m.DiffuseLight(emit=colour("Ke", (0.0, 0.0, 0.0)))
    elif kind == "metal":
        ks = entry.colour("Ks")
        key = "Ks" if ks is not None and max(ks) > 0 else "Kd"
        model = m.Metal(albedo=colour(key, DEFAULT_ALBEDO, 1.0), fuzz=alpha_of_exponent(ns) if ns is not None else 0.0,
                        **surface_maps())
        used.update(k for k in ("Ns", "illum") if k in entry.values)
    elif kind == "plastic":
        model = m.Plastic(albedo=reflectance(), ior=ior(), alpha=alpha_of_exponent(ns if ns is not None else 0.0),
                          **surface_maps())
        used.update(k for k in ("Ks", "Ns", "illum") if k in entry.values)
    else:
        model = m.Lambertian(albedo=reflectance(), **surface_maps())
        used.update(k for k in ("illum",) if k in entry.values)
    # What this choice leaves unread, beyond what the file-level warnings already named.
    for key in sorted(set(entry.values) | set(entry.maps)):
        if key in used or key in _DROPPED or key in _QUIET.get(kind, ()):
            continue
        if key in entry.values and max(entry.values[key][0]) <= 0:  # a zero (Ks 0 0 0, Ke 0 0 0) asks for nothing
            continue
        if key == "d" and entry.number("d") >= 1.0:  # opaque, as every surface here is
            continue
        warnings.append((entry.line_of(key), f"{key} is not used by the {kind} material this entry becomes"))
    warnings.sort(key=lambda w: w[0])
    return model, warnings


_SHOWN_FILE = re.compile(r"[A-Za-z0-9_ .+\-/]{1,200}")


def quote_file(name: str) -> str:
    """A file name read from an OBJ or a library as a message may show it: quoted when it looks
    like a path of plain words (`textures/wood.png`), else by its length."""
    return f"'{name}'" if _SHOWN_FILE.fullmatch(name) else f"(a name of {len(name)} characters, not shown)"


def hide_name(message: str, name: str) -> str:
    """`message` (a named_files sentence, which quotes the name as written) with `name` shown only
    as quote_file shows it."""
    shown = quote_file(name)
    for form in (repr(name), f"'{name}'"):
        message = message.replace(form, shown)
    if shown.startswith("'"):
        return message
    # Where it was looked for holds the name too, resolved: left out with it.
    return message.split(" (looked for ", 1)[0].replace(name, "(the name)")
