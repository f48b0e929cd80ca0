"""Render passes beside the image: their names, where they are written, and their arrays.

A pass is one more picture of the render, for compositing and for a denoiser:

- albedo, normal, depth: traced by camera rays of their own after the render, from the flat
  scene (renderer/tracing/aux_passes.py: OIDN's definitions of its auxiliary images), so asking
  for them changes no pixel of the image; AUX_SAMPLES rays a pixel;
- samples: each pixel's sample count (the film's counts);
- error: each pixel's standard error as the noise map estimates it (renderer/film.py
  `estimate_noise`), where it cannot be estimated (fewer than 2 samples) the largest float32.

Every pass is float32 and finite. `rt render --passes` writes them as extra layers of the --hdr
EXR (channels `albedo.R`, `normal.X`, `depth.Z`, `samples.Y`, `error.Y`; the image stays R, G, B)
or as files `NAME.<pass>.exr|.pfm` beside the image (`--passes-as`); `rt.render(passes=...)`
returns them in `Image.passes`.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterable, Optional, Union

if TYPE_CHECKING:
    import numpy as np

    from renderer.film import Film

# Every pass, in the order messages and files list them.
PASS_NAMES = ("albedo", "normal", "depth", "samples", "error")
# Those traced by the auxiliary kernel (renderer/tracing/aux_passes.AUX_PASSES).
TRACED = ("albedo", "normal", "depth")
# Each pass's channels in a multi-layer EXR, after the pass's name and a dot.
CHANNELS = {"albedo": ("R", "G", "B"), "normal": ("X", "Y", "Z"), "depth": ("Z",), "samples": ("Y",), "error": ("Y",)}
# How passes are written (`--passes-as`): layers of the --hdr EXR, or files beside the image.
LAYOUTS = ("layers", "files")
# Camera rays a pixel for the traced passes: enough that a pixel's albedo and normal hold the
# anti-aliased mean a denoiser wants (each ray's values are exact; only edges and what is seen
# through glass vary among them).
AUX_SAMPLES = 16


def _listing() -> str:
    return ", ".join(PASS_NAMES[:-1]) + " and " + PASS_NAMES[-1]


def parse_passes(names: Union[None, str, Iterable[str]]) -> tuple[str, ...]:
    """The passes asked for, in PASS_NAMES' order, each once: `names` is a comma-separated list
    ("albedo,normal") or an iterable of names. ValueError, one sentence with a did-you-mean, for
    an unknown or empty one."""
    from scenefmt.diagnostics import did_you_mean, quote_text

    if names is None:
        return ()
    if isinstance(names, str):
        names = names.split(",")
    wanted = []
    for name in names:
        if not isinstance(name, str):
            raise ValueError(f"a pass is named by a string, not {type(name).__name__}; the passes are {_listing()}")
        name = name.strip()
        if name not in PASS_NAMES:
            if not name:
                raise ValueError(f"an empty pass name; the passes are {_listing()}")
            raise ValueError(f"unknown pass {quote_text(name[:64])} (the passes are {_listing()})"
                             f"{did_you_mean(name.lower(), PASS_NAMES)}")
        wanted.append(name)
    return tuple(name for name in PASS_NAMES if name in wanted)


def layout_of(passes_as: Optional[str], hdr: Optional[Path]) -> str:
    """How the passes are written: `passes_as` if given, else layers when --hdr is an EXR, files
    otherwise. ValueError (one sentence) for an unknown layout, or layers without an EXR."""
    from scenefmt.diagnostics import did_you_mean, quote_text

    if passes_as is not None and passes_as not in LAYOUTS:
        raise ValueError(f"--passes-as {quote_text(str(passes_as)[:64])}: expected layers or files"
                         f"{did_you_mean(str(passes_as), LAYOUTS)}")
    exr = hdr is not None and Path(hdr).suffix.lower() == ".exr"
    if passes_as == "layers" and not exr:
        raise ValueError("--passes-as layers writes the passes into the --hdr OpenEXR image: give --hdr NAME.exr, "
                         "or write them as files with --passes-as files")
    return passes_as or ("layers" if exr else "files")


def pass_files(image: Path, passes: Iterable[str], hdr: Optional[Path]) -> list[tuple[str, Path]]:
    """(pass, file) for passes written as files: `NAME.<pass>.exr` beside the image `NAME.png`
    when --hdr is an EXR, else `.pfm` (which needs no optional library)."""
    suffix = ".exr" if hdr is not None and Path(hdr).suffix.lower() == ".exr" else ".pfm"
    return [(name, image.with_name(f"{image.stem}.{name}{suffix}")) for name in passes]


def compute_passes(names: Iterable[str], flat, film: "Film", *, seed: int = 0, samples: int = AUX_SAMPLES,
                   notify: Optional[Callable[[str], None]] = None) -> dict[str, "np.ndarray"]:
    """The passes `names` (PASS_NAMES) of a render of the flat scene `flat` whose film is `film`:
    name -> float32 array, (H, W, 3) for albedo and normal, (H, W) for the others, all finite.
    The traced ones use `samples` camera rays a pixel seeded by `seed` (the render's own seed:
    their rays are their own, so the image is untouched). `notify` hears, once per installation,
    that their kernel is being compiled."""
    import numpy as np

    names = parse_passes(names)
    out: dict[str, np.ndarray] = {}
    if any(name in TRACED for name in names):
        from renderer.tracing.aux_passes import render_aux
        from renderer.variants import GENERAL, is_compiled, mark_compiled

        if notify is not None and not is_compiled(GENERAL, "aux"):
            notify("passes: compiling their kernel first (about a minute on 2 cores, once per installation)")
        traced = render_aux(flat, film.width, film.height, samples=samples, seed=seed)
        mark_compiled(GENERAL, "aux")
        out.update({name: traced[name] for name in TRACED if name in names})
    if "samples" in names:
        out["samples"] = film.counts.astype(np.float32)
    if "error" in names:
        from renderer.film import estimate_noise

        error = estimate_noise(film).error
        # Not estimated (fewer than 2 samples): inf in the estimate, the largest float32 in a file.
        out["error"] = np.nan_to_num(error, nan=np.finfo(np.float32).max, posinf=np.finfo(np.float32).max).astype(np.float32)
    return {name: out[name] for name in names}


def exr_layers(passes: dict) -> dict:
    """The passes as EXR channels: "albedo.R" -> (H, W) array, and so on (CHANNELS)."""
    layers = {}
    for name, values in passes.items():
        for k, channel in enumerate(CHANNELS[name]):
            layers[f"{name}.{channel}"] = values[..., k] if values.ndim == 3 else values
    return layers


def write_pass_file(path: Path, name: str, values: "np.ndarray") -> None:
    """One pass as a file of its own, atomically: .pfm (colour for albedo and normal, grey for
    the others) or .exr (channels R, G, B, or Y for a grey pass, as tools without layers read them)."""
    from renderer.film import write_exr_channels, write_pfm

    if Path(path).suffix.lower() == ".exr":
        if values.ndim == 3:
            write_exr_channels(path, {"R": values[..., 0], "G": values[..., 1], "B": values[..., 2]})
        else:
            write_exr_channels(path, {"Y": values})
    else:
        write_pfm(path, values)
