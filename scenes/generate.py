"""Build the books' randomly generated scenes in Python and write them as scene files.

    python scenes/generate.py           # rewrite weekend_cover.yaml, bouncing_spheres.yaml, final_scene.yaml
    python scenes/generate.py --check   # exit 1 if a committed file differs from what would be written

Each scene is built from the scenefmt models with its own seeded `random.Random`, drawing
numbers in the same order as the book's C++ (choose_mat, the two centre jitters, then the
material's draws), so a given seed always gives the same file. The books never fix a seed
or a generator, so no seed reproduces their images exactly. Random values are rounded to
4 decimal places to keep the files readable.
"""

from __future__ import annotations

import argparse
import math
import random
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
try:
    import scenefmt  # noqa: F401
except ImportError:  # run from a checkout without the package installed
    sys.path.insert(0, str(HERE.parent))

from scenefmt.models import (  # noqa: E402
    Box,
    Camera,
    CheckerTexture,
    ConstantMedium,
    Dielectric,
    DiffuseLight,
    Group,
    Image,
    ImageTexture,
    Instance,
    Lambertian,
    Metal,
    MovingSphere,
    NoiseTexture,
    Quad,
    RotateStep,
    Rotation,
    Scene,
    SkyBackground,
    Sphere,
    TranslateStep,
)
from scenefmt.writing import dump, dumps  # noqa: E402

SCHEMA_URL = "../schemas/scene.schema.json"
PLACES = 4  # decimal places kept of each random value

SEEDS = {
    "weekend_cover.yaml": 2016,
    "bouncing_spheres.yaml": 2020,
    "final_scene.yaml": 2025,
}

SKY_BLUE = (0.70, 0.80, 1.00)  # The Next Week's background for the scenes without lights
BLACK = (0.0, 0.0, 0.0)


class BookRandom:
    """The books' random helpers, drawn from one seeded `random.Random`."""

    def __init__(self, seed: int) -> None:
        self._rng = random.Random(seed)

    def double(self, lo: float = 0.0, hi: float = 1.0) -> float:
        """random_double(lo, hi): uniform in [lo, hi)."""
        return lo + (hi - lo) * self._rng.random()

    def vec(self, lo: float = 0.0, hi: float = 1.0) -> tuple[float, float, float]:
        """vec3::random(lo, hi) (also color::random and point3::random): x, then y, then z."""
        return (self.double(lo, hi), self.double(lo, hi), self.double(lo, hi))


def rounded(value):
    """A random number or vector rounded for the file."""
    if isinstance(value, tuple):
        return tuple(round(x, PLACES) for x in value)
    return round(value, PLACES)


def distance(p, q) -> float:
    return math.dist(p, q)


def add(p, q):
    return tuple(a + b for a, b in zip(p, q))


def mul(p, q):
    return tuple(a * b for a, b in zip(p, q))


def y_rotate_then_move(degrees: float, offset) -> list:
    """The books' translate(rotate_y(object, degrees), offset), as transform steps."""
    return [RotateStep(rotate=Rotation(axis="y", degrees=degrees)), TranslateStep(translate=offset)]


# ----------------------------------------------------------------------------------------------
# The cover scene of both books: a field of small random spheres around three big ones.

BIG_THREE_MATERIALS = {
    "glass": Dielectric(ior=1.5),
    "brown": Lambertian(albedo=(0.4, 0.2, 0.1)),
    "mirror": Metal(albedo=(0.7, 0.6, 0.5), fuzz=0.0),
}

BIG_THREE = [
    Sphere(center=(0, 1, 0), radius=1.0, material="glass"),
    Sphere(center=(-4, 1, 0), radius=1.0, material="brown"),
    Sphere(center=(4, 1, 0), radius=1.0, material="mirror"),
]


def small_metal(rnd: BookRandom, center) -> Sphere:
    """A small metal sphere, as both books draw it: three albedo channels in [0.5, 1), then a fuzz
    in [0, 0.5) (the old book's 0.5*(1 + drand48()) and 0.5*drand48(); v4's color::random(0.5, 1)
    and random_double(0, 0.5))."""
    albedo = rnd.vec(0.5, 1)
    fuzz = rnd.double(0, 0.5)
    return Sphere(center=rounded(center), radius=0.2, material=Metal(albedo=rounded(albedo), fuzz=rounded(fuzz)))


def small_spheres(rnd: BookRandom, make_diffuse) -> list:
    """The 22 x 22 grid of candidate spheres, a and b in [-11, 11).

    Per cell: choose_mat, then the x and z jitter of the centre; a sphere too close to the
    big metal one at (4, 1, 0) is skipped (and draws nothing more). 80% diffuse, 15% metal,
    5% glass.
    """
    shapes = []
    for a in range(-11, 11):
        for b in range(-11, 11):
            choose_mat = rnd.double()
            center = (a + 0.9 * rnd.double(), 0.2, b + 0.9 * rnd.double())
            if distance(center, (4, 0.2, 0)) <= 0.9:
                continue
            if choose_mat < 0.8:
                shapes.append(make_diffuse(rnd, center))
            elif choose_mat < 0.95:
                shapes.append(small_metal(rnd, center))
            else:
                shapes.append(Sphere(center=rounded(center), radius=0.2, material="glass"))
    return shapes


def weekend_cover() -> Scene:
    """Ray Tracing in One Weekend (2016 edition), chapter 12: random_scene(), all spheres static."""
    rnd = BookRandom(SEEDS["weekend_cover.yaml"])

    def diffuse(rnd, center):
        # lambertian(vec3(drand48()*drand48(), drand48()*drand48(), drand48()*drand48()))
        albedo = tuple(rnd.double() * rnd.double() for _ in "rgb")
        return Sphere(center=rounded(center), radius=0.2, material=Lambertian(albedo=rounded(albedo)))

    shapes = [Sphere(center=(0, -1000, 0), radius=1000, material="ground")]
    shapes += small_spheres(rnd, diffuse)
    shapes += BIG_THREE
    return Scene(
        description=(
            "Ray Tracing in One Weekend (2016 edition), chapter 12: the cover, random_scene(). Written by "
            f"scenes/generate.py (seed {SEEDS['weekend_cover.yaml']}; random values rounded to {PLACES} places). "
            "The book gives no camera for it; we use the classic one: (13,2,3) looking at the origin, vfov 20, "
            "aperture 0.1, focus distance 10, 1200 x 800, 10 samples per pixel. The background is the book's "
            "sky gradient (the default, so it is not written out)."
        ),
        camera=Camera(look_from=(13, 2, 3), look_at=(0, 0, 0), vfov=20, aperture=0.1, focus_distance=10),
        image=Image(width=1200, height=800, samples_per_pixel=10, max_depth=50),
        background=SkyBackground(),
        materials={"ground": Lambertian(albedo=(0.5, 0.5, 0.5)), **BIG_THREE_MATERIALS},
        shapes=shapes,
    )


def bouncing_spheres() -> Scene:
    """The Next Week (v4.0.2), chapter 2, Image 2: the cover scene with bouncing diffuse spheres."""
    rnd = BookRandom(SEEDS["bouncing_spheres.yaml"])

    def diffuse(rnd, center):
        # albedo = color::random() * color::random(); center2 = center + vec3(0, random_double(0,.5), 0)
        albedo = mul(rnd.vec(), rnd.vec())
        center2 = add(center, (0, rnd.double(0, 0.5), 0))
        return MovingSphere(
            center0=rounded(center), center1=rounded(center2), radius=0.2, material=Lambertian(albedo=rounded(albedo))
        )

    shapes = [Sphere(center=(0, -1000, 0), radius=1000, material="ground")]
    shapes += small_spheres(rnd, diffuse)
    shapes += BIG_THREE
    return Scene(
        description=(
            "Ray Tracing: The Next Week (v4.0.2), chapter 2: bouncing spheres on the checkered ground (Image 2; "
            "listing 26 and the reference code use the checker, listing 27 shows grey again). Each diffuse sphere "
            "rises by U(0, 0.5) while the shutter is open. Written by scenes/generate.py (seed "
            f"{SEEDS['bouncing_spheres.yaml']}; random values rounded to {PLACES} places). max_depth is 50 as in "
            "listing 6 (listing 58 later lowers it to 20); background (0.70, 0.80, 1.00) from listing 58."
        ),
        camera=Camera(look_from=(13, 2, 3), look_at=(0, 0, 0), vfov=20, defocus_angle=0.6, focus_distance=10),
        image=Image(width=400, aspect_ratio="16:9", samples_per_pixel=100, max_depth=50),
        background=SKY_BLUE,
        textures={"checker": CheckerTexture(scale=0.32, even=(0.2, 0.3, 0.1), odd=(0.9, 0.9, 0.9))},
        materials={"ground": Lambertian(albedo="checker"), **BIG_THREE_MATERIALS},
        shapes=shapes,
    )


# ----------------------------------------------------------------------------------------------
# The Next Week's final scene.


def final_scene() -> Scene:
    """The Next Week (v4.0.2), chapter 10, Image 23: a scene testing all the new features."""
    rnd = BookRandom(SEEDS["final_scene.yaml"])

    # 20 x 20 ground boxes of side 100 and random height U(1, 101).
    ground_boxes = []
    boxes_per_side = 20
    for i in range(boxes_per_side):
        for j in range(boxes_per_side):
            w = 100.0
            x0 = -1000.0 + i * w
            z0 = -1000.0 + j * w
            y0 = 0.0
            x1 = x0 + w
            y1 = rnd.double(1, 101)
            z1 = z0 + w
            ground_boxes.append(Box(min=(x0, y0, z0), max=(x1, rounded(y1), z1), material="ground"))

    # 1000 white spheres of radius 10 at point3::random(0, 165), placed as one rotated, moved group.
    cluster = Group(shapes=[Sphere(center=rounded(rnd.vec(0, 165)), radius=10, material="white") for _ in range(1000)])

    center1 = (400, 400, 200)
    center2 = add(center1, (30, 0, 0))
    shapes = [
        *ground_boxes,
        Quad(q=(123, 554, 147), u=(300, 0, 0), v=(0, 0, 265), material="light"),
        MovingSphere(center0=center1, center1=center2, radius=50, material="orange"),
        Sphere(center=(260, 150, 45), radius=50, material="glass"),
        Sphere(center=(0, 150, 145), radius=50, material="fuzzy_metal"),
        # Subsurface scattering: a glass sphere filled with a blue medium.
        Sphere(center=(360, 150, 145), radius=70, material="glass", interior="subsurface"),
        # The global mist: an invisible boundary (no surface) that the camera sits inside.
        Sphere(center=(0, 0, 0), radius=5000, interior="mist"),
        Sphere(center=(400, 200, 400), radius=100, material="earth"),
        Sphere(center=(220, 280, 300), radius=80, material="marble"),
        Instance(group="cluster", transform=y_rotate_then_move(15, (-100, 270, 395))),
    ]
    return Scene(
        description=(
            "Ray Tracing: The Next Week (v4.0.2), chapter 10, Image 23: the final scene. Written by "
            f"scenes/generate.py (seed {SEEDS['final_scene.yaml']}; random values rounded to {PLACES} places). "
            "The image uses the book's default quick settings, final_scene(400, 250, 4); the book's full render is "
            "final_scene(800, 10000, 40): 800 x 800, 10000 samples per pixel, max depth 40. The book builds the "
            "Perlin tables from the same random stream between the boxes and the sphere cluster; here the noise "
            "texture has its own seed. The image is earthmap.png in place of the book's earthmap.jpg."
        ),
        camera=Camera(look_from=(478, 278, -600), look_at=(278, 278, 0), vfov=40),
        image=Image(width=400, aspect_ratio=1, samples_per_pixel=250, max_depth=4),
        background=BLACK,
        textures={
            "earthmap": ImageTexture(file="earthmap.png"),
            "pertext": NoiseTexture(scale=0.2, form="marble"),
        },
        materials={
            "ground": Lambertian(albedo=(0.48, 0.83, 0.53)),
            "light": DiffuseLight(emit=(7, 7, 7)),
            "orange": Lambertian(albedo=(0.7, 0.3, 0.1)),
            "glass": Dielectric(ior=1.5),
            "fuzzy_metal": Metal(albedo=(0.8, 0.8, 0.9), fuzz=1.0),
            "earth": Lambertian(albedo="earthmap"),
            "marble": Lambertian(albedo="pertext"),
            "white": Lambertian(albedo=(0.73, 0.73, 0.73)),
        },
        media={
            "subsurface": ConstantMedium(density=0.2, albedo=(0.2, 0.4, 0.9)),
            "mist": ConstantMedium(density=0.0001, albedo=(1, 1, 1)),
        },
        groups={"cluster": cluster},
        shapes=shapes,
    )


SCENES = {
    "weekend_cover.yaml": weekend_cover,
    "bouncing_spheres.yaml": bouncing_spheres,
    "final_scene.yaml": final_scene,
}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a file is not up to date")
    args = parser.parse_args(argv)

    stale = []
    for name, build in SCENES.items():
        path = HERE / name
        if args.check:
            expected = dumps(build(), "yaml", schema_url=SCHEMA_URL)
            if not path.is_file() or path.read_text(encoding="utf-8") != expected:
                stale.append(name)
        else:
            dump(build(), path, schema_url=SCHEMA_URL)
            print(f"wrote {path}")
    if stale:
        for name in stale:
            print(f"{name} differs from what scenes/generate.py writes; run python scenes/generate.py", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
