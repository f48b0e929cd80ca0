"""Scenes built in Python, written as YAML or JSON, load back to the same models."""

from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from scenefmt import models as m
from scenefmt.base import MIN_MAGNITUDE, vec_cross, vec_length
from scenefmt.validation import load, loads
from scenefmt.writing import dump, dumps

SCENES = Path(__file__).resolve().parents[2] / "scenes"


def _moderate(x: float) -> float:
    """A scene's numbers are 0 or of magnitude 1e-50 to 1e50 (scenefmt.base.MIN_MAGNITUDE)."""
    return 0.0 if abs(x) < MIN_MAGNITUDE else x


num = st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False).map(_moderate)
positive = st.floats(1e-3, 1e4, allow_nan=False, allow_infinity=False)
vec = st.tuples(num, num, num)
color = st.tuples(*[st.floats(0, 1, allow_nan=False).map(_moderate)] * 3)  # reflectances are at most 1 (scenefmt.bounds)
names = st.from_regex(r"[A-Za-z_][A-Za-z0-9_.\-]{0,12}", fullmatch=True)


@st.composite
def nonzero_vec(draw):
    v = draw(vec)
    assume(vec_length(v) > 1e-3)
    return v


@st.composite
def textures(draw, known: list[str], depth: int = 0):
    kind = draw(st.sampled_from(["solid", "checker", "noise"] if depth < 2 else ["solid", "noise"]))
    if kind == "solid":
        return m.SolidTexture(color=draw(color))
    if kind == "noise":
        return m.NoiseTexture(scale=draw(positive), form=draw(st.sampled_from(["plain", "turbulence", "marble"])),
                              octaves=draw(st.integers(1, 16)), seed=draw(st.integers(0, 1000)))
    return m.CheckerTexture(scale=draw(positive), even=draw(slots(known, depth + 1)), odd=draw(slots(known, depth + 1)))


def slots(known: list[str], depth: int = 0):
    options = [color, textures(known, depth)]
    if known:
        options.append(st.sampled_from(known))
    return st.one_of(*options)


@st.composite
def materials(draw, textures_known):
    kind = draw(st.sampled_from(["lambertian", "metal", "dielectric", "diffuse_light", "isotropic"]))
    if kind == "lambertian":
        return m.Lambertian(albedo=draw(slots(textures_known)))
    if kind == "metal":
        return m.Metal(albedo=draw(slots(textures_known)), fuzz=draw(st.floats(0, 1).map(_moderate)))
    if kind == "dielectric":
        return m.Dielectric(ior=draw(positive))
    if kind == "diffuse_light":
        return m.DiffuseLight(emit=draw(slots(textures_known)))
    return m.Isotropic(albedo=draw(slots(textures_known)))


@st.composite
def steps(draw):
    kind = draw(st.sampled_from(["translate", "rotate", "scale", "matrix"]))
    if kind == "translate":
        return m.TranslateStep(translate=draw(vec))
    if kind == "rotate":
        axis = draw(st.one_of(st.sampled_from(["x", "y", "z"]), nonzero_vec()))
        return m.RotateStep(rotate=m.Rotation(axis=axis, degrees=draw(st.floats(-720, 720).map(_moderate))))
    if kind == "scale":
        factor = st.one_of(st.floats(0.01, 100), st.floats(-100, -0.01))
        return m.ScaleStep(scale=draw(st.one_of(factor, st.tuples(factor, factor, factor))))
    t = draw(vec)
    return m.MatrixStep(matrix=[[1, 0, 0, t[0]], [0, 1, 0, t[1]], [0, 0, 1, t[2]]])


@st.composite
def shapes(draw, mats: list[str], media: list[str], groups: list[str]):
    kinds = ["sphere", "moving_sphere", "quad", "triangle", "disk", "box"] + (["instance"] if groups else [])
    kind = draw(st.sampled_from(kinds))
    transform = draw(st.lists(steps(), max_size=3))
    if kind == "instance":
        return m.Instance(group=draw(st.sampled_from(groups)), transform=transform)
    material = draw(st.sampled_from(mats)) if mats else draw(materials([]))
    common = dict(material=material, transform=transform)
    closed = dict(common, interior=draw(st.sampled_from(media)) if media and draw(st.booleans()) else None)
    if kind == "sphere":
        return m.Sphere(center=draw(vec), radius=draw(positive), **closed)
    if kind == "moving_sphere":
        return m.MovingSphere(center0=draw(vec), center1=draw(vec), radius=draw(positive), **closed)
    if kind == "box":
        lo = draw(vec)
        size = draw(st.tuples(positive, positive, positive))
        return m.Box(min=lo, max=tuple(a + b for a, b in zip(lo, size)), **closed)
    if kind == "disk":
        return m.Disk(center=draw(vec), normal=draw(nonzero_vec()), radius=draw(positive), **common)
    u, v = draw(nonzero_vec()), draw(nonzero_vec())
    assume(vec_length(vec_cross(u, v)) > 1e-3 * vec_length(u) * vec_length(v))
    if kind == "quad":
        return m.Quad(q=draw(vec), u=u, v=v, **common)
    p0 = draw(vec)
    return m.Triangle(vertices=(p0, tuple(a + b for a, b in zip(p0, u)), tuple(a + b for a, b in zip(p0, v))), **common)


@st.composite
def scenes(draw):
    tex_names = draw(st.lists(names, max_size=3, unique=True))
    tex = {}
    for i, name in enumerate(tex_names):
        tex[name] = draw(textures(tex_names[:i]))  # only earlier names: no cycles
    mat = {name: draw(materials(tex_names)) for name in draw(st.lists(names, max_size=3, unique=True))}
    med = {
        name: m.ConstantMedium(density=draw(positive), albedo=draw(slots(tex_names)))
        for name in draw(st.lists(names, max_size=2, unique=True))
    }
    grp = {}
    for name in draw(st.lists(names, max_size=2, unique=True)):
        grp[name] = m.Group(shapes=draw(st.lists(shapes(list(mat), list(med), list(grp)), min_size=1, max_size=3)))
    look_from = draw(vec)
    look_at = draw(vec)
    assume(vec_length(tuple(a - b for a, b in zip(look_at, look_from))) > 1e-3)
    view = tuple(a - b for a, b in zip(look_at, look_from))
    assume(vec_length(vec_cross(view, (0, 1, 0))) > 1e-6 * vec_length(view))
    camera = m.Camera(look_from=look_from, look_at=look_at, vfov=draw(st.floats(1, 179)),
                      defocus_angle=draw(st.sampled_from([0.0, 0.6, 10.0])))
    image = m.Image(width=draw(st.integers(1, 2000)), aspect_ratio=draw(st.sampled_from([None, 1.5, "16:9"])),
                    samples_per_pixel=draw(st.integers(1, 1000)), max_depth=draw(st.integers(1, 100)),
                    seed=draw(st.integers(0, 2**40)))
    background = draw(st.one_of(color, st.just(m.SkyBackground()), st.builds(m.SolidBackground, color=color)))
    return m.Scene(
        description=draw(st.text(st.characters(codec="ascii", exclude_categories=["Cc"]), max_size=40)),
        camera=camera, image=image, shutter=m.Shutter(open=0, close=draw(st.floats(0, 5).map(_moderate))),
        background=background, textures=tex, materials=mat, media=med, groups=grp,
        shapes=draw(st.lists(shapes(list(mat), list(med), list(grp)), max_size=6)),
    )


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(scenes(), st.sampled_from(["yaml", "json"]))
def test_load_of_dump_reproduces_the_scene(scene, syntax):
    assert loads(dumps(scene, syntax), syntax=syntax).scene == scene


@pytest.mark.parametrize("text", ["0E0", "1e5", "-2E-3", ".5", "0o17", "0x1F", "true", "NULL", "~", "", ".inf", "12"])
def test_a_description_that_reads_as_a_number_or_keyword_keeps_its_quotes(text):
    """YAML 1.2 reads `0E0` as a number where YAML 1.1 does not: the writer must quote it."""
    scene = m.Scene(description=text)
    assert loads(dumps(scene, "yaml")).scene.description == text


@pytest.mark.parametrize("path", sorted(p.name for p in SCENES.glob("*.yaml")) + sorted(p.name for p in SCENES.glob("*.json")))
def test_book_scenes_survive_a_round_trip_through_both_syntaxes(path, tmp_path):
    original = load(SCENES / path).scene
    for suffix in (".yaml", ".json"):
        out = tmp_path / f"copy{suffix}"
        dump(original, out)
        # Relative image, map, mesh and grid paths resolve against the copy's folder: copy the files along.
        for img in [*SCENES.glob("*.png"), *SCENES.glob("*.pfm"), *SCENES.glob("*.ply"), *SCENES.glob("*.npz"),
                    *SCENES.glob("*_assets/*")]:
            (tmp_path / img.relative_to(SCENES)).parent.mkdir(exist_ok=True)
            (tmp_path / img.relative_to(SCENES)).write_bytes(img.read_bytes())
        assert load(out).scene == original
