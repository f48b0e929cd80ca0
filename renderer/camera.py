"""The camera: its table, its flattening from the scene, and the rays it casts.

The second book's thin-lens camera: rays leave a point of the lens disk (a pinhole when the
lens radius is 0) towards a point of the pixel on the focus plane, at a time in the shutter
interval.
"""

import math


from scenefmt import affine

from . import target
from .columns import Column, Layout
from .kernel_flags import DEFOCUS, MOTION
from .motion import map_point, map_vector, maps_at
from .numerics.rng import DIM_LENS_RETRY, DIM_LENS_X, DIM_LENS_Y, DIM_PIXEL_X, DIM_PIXEL_Y, DIM_TIME, uniform
from .target import uint64

CAMERA = Layout("camera", "float64", [
    Column("origin", 3, "centre of the lens"),
    Column("pixel00", 3, "centre of the top-left pixel on the focus plane"),
    Column("du", 3, "one pixel to the right on the focus plane"),
    Column("dv", 3, "one pixel down on the focus plane"),
    Column("lens_u", 3, "the lens disk's horizontal radius vector"),
    Column("lens_v", 3, "the lens disk's vertical radius vector"),
    Column("lens_radius", 1, "0 for a pinhole: no defocus"),
    Column("open", 1, "shutter open time"),
    Column("close", 1, "shutter close time"),
    Column("first_key", 1, "a moving camera: row of its first keyframe in motion_f (motion.py); -1 for one that stands still"),
    Column("keys", 1, "a moving camera: how many keyframes; 0 for one that stands still. A moving camera's origin, "
                      "pixel00, du, dv, lens_u and lens_v are in its own space (x right, y up, looking down -z), "
                      "placed in the world by its keyframes at the ray's time"),
])
CAM_ORIGIN, CAM_PIXEL00, CAM_DU, CAM_DV = CAMERA.offsets("origin", "pixel00", "du", "dv")
CAM_LENS_U, CAM_LENS_V, CAM_LENS_RADIUS = CAMERA.offsets("lens_u", "lens_v", "lens_radius")
CAM_OPEN, CAM_CLOSE = CAMERA.offsets("open", "close")
CAM_FIRST_KEY, CAM_KEYS = CAMERA.offsets("first_key", "keys")


def _frame(look_from, look_at, up):
    """The camera's axes (u right, v up, w backwards) and centre."""
    center = tuple(float(x) for x in look_from)
    w = affine.unit(affine.sub(center, look_at))
    u = affine.unit(affine.cross(up, w))
    v = affine.cross(w, u)
    return u, v, w, center


def camera_keys(graph) -> tuple[list, list]:
    """The times and world_from_camera maps of a moving camera's keyframes (the shutter open:
    else none); empty lists for a camera that stands still."""
    cam = graph.camera
    if not cam.moves or not graph.shutter.close > graph.shutter.open:
        return [], []
    times, maps = [], []
    for key in cam.motion:
        u, v, w, c = _frame(*cam.frame_at_key(key))
        times.append(float(key.time))
        maps.append(tuple((u[r], v[r], w[r], c[r]) for r in range(3)))
    return times, maps


def with_camera_keys(motion_f, graph):
    """motion_f with a moving camera's keyframe rows appended (camera_row names them)."""
    import numpy as np

    from .motion import keyframe_rows

    times, maps = camera_keys(graph)
    if not times:
        return np.ascontiguousarray(motion_f)
    return np.ascontiguousarray(np.concatenate([motion_f, keyframe_rows(times, maps)]))


def _still_frame(cam):
    """(look_from, look_at, up) of a camera that stands still: its keyframes' if they all agree
    (or the shutter never opens: its first keyframe's), else its own."""
    if cam.motion:
        return cam.frame_at_key(cam.motion[0])
    return cam.look_from, cam.look_at, cam.up


def camera_row(graph, first_key: int = -1) -> list[float]:
    """The CAMERA row of a scene graph's camera, image size and shutter. A moving camera's
    keyframes are rows first_key.. of motion_f (with_camera_keys puts them there), and its
    vectors are in its own space."""
    cam, image = graph.camera, graph.image
    width, height = image.width, image.pixel_height
    times, _ = camera_keys(graph)
    if times:
        u, v, w, center = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, 0.0)
    elif cam.moves:
        # A shutter that never opens sees the camera where its keyframes put it at that time.
        from .motion import keyframe_rows, map_at_numpy

        keys = [_frame(*cam.frame_at_key(key)) for key in cam.motion]
        rows = keyframe_rows([key.time for key in cam.motion], [tuple((f[0][r], f[1][r], f[2][r], f[3][r]) for r in range(3)) for f in keys])
        m = map_at_numpy(rows, float(graph.shutter.open))
        u, v, w, center = (tuple(float(x) for x in m[:, k]) for k in range(4))
    else:
        u, v, w, center = _frame(*_still_frame(cam))
    focus = cam.focus
    viewport_h = 2.0 * math.tan(math.radians(cam.vfov) / 2.0) * focus
    viewport_w = viewport_h * (width / height)
    du = tuple(viewport_w * u[k] / width for k in range(3))
    dv = tuple(-viewport_h * v[k] / height for k in range(3))
    upper_left = tuple(center[k] - focus * w[k] - viewport_w * u[k] / 2 + viewport_h * v[k] / 2 for k in range(3))
    pixel00 = tuple(upper_left[k] + 0.5 * (du[k] + dv[k]) for k in range(3))
    radius = cam.lens_radius
    return CAMERA.row(origin=center, pixel00=pixel00, du=du, dv=dv, lens_u=affine.scale(u, radius),
                      lens_v=affine.scale(v, radius), lens_radius=float(radius),
                      open=float(graph.shutter.open), close=float(graph.shutter.close),
                      first_key=float(first_key if times else -1), keys=float(len(times)))


@target.device
def lens_point(key):
    """A uniform point (x, y) of the unit disk for the path with `key`.

    Points of the square [-1, 1]^2 are drawn until one falls inside (pi/4 of them do), which
    costs no sine or cosine: those took 6% of a defocused render. Each try uses dimensions of
    its own, so a kept point is exactly uniform. After eight misses (a chance of 5e-6) the
    polar form, r = sqrt(U) and an angle, gives the point from two more fresh dimensions.
    """
    for k in range(8):
        if k == 0:
            x = 2.0 * uniform(key, DIM_LENS_X) - 1.0
            y = 2.0 * uniform(key, DIM_LENS_Y) - 1.0
        else:
            x = 2.0 * uniform(key, DIM_LENS_RETRY + uint64(2 * k)) - 1.0
            y = 2.0 * uniform(key, DIM_LENS_RETRY + uint64(2 * k + 1)) - 1.0
        if x * x + y * y < 1.0:
            return x, y
    r = math.sqrt(uniform(key, DIM_LENS_RETRY + uint64(16)))
    phi = 2.0 * math.pi * uniform(key, DIM_LENS_RETRY + uint64(17))
    return r * math.cos(phi), r * math.sin(phi)


@target.device
def camera_ray(cam, i, j, key):
    """Origin, direction and time of the camera ray through pixel (i, j) for the path with `key`."""
    ox = uniform(key, DIM_PIXEL_X) - 0.5
    oy = uniform(key, DIM_PIXEL_Y) - 0.5
    p0, du, dv = CAM_PIXEL00, CAM_DU, CAM_DV
    aim = (
        cam[p0] + (i + ox) * cam[du] + (j + oy) * cam[dv],
        cam[p0 + 1] + (i + ox) * cam[du + 1] + (j + oy) * cam[dv + 1],
        cam[p0 + 2] + (i + ox) * cam[du + 2] + (j + oy) * cam[dv + 2],
    )
    c = CAM_ORIGIN
    origin = (cam[c], cam[c + 1], cam[c + 2])
    if DEFOCUS and cam[CAM_LENS_RADIUS] > 0.0:
        lx, ly = lens_point(key)
        a, b = CAM_LENS_U, CAM_LENS_V
        origin = (
            cam[c] + lx * cam[a] + ly * cam[b],
            cam[c + 1] + lx * cam[a + 1] + ly * cam[b + 1],
            cam[c + 2] + lx * cam[a + 2] + ly * cam[b + 2],
        )
    into_shutter = 0.0
    if MOTION:
        into_shutter = uniform(key, DIM_TIME) * (cam[CAM_CLOSE] - cam[CAM_OPEN])
    time = cam[CAM_OPEN] + into_shutter
    return origin, (aim[0] - origin[0], aim[1] - origin[1], aim[2] - origin[2]), time


@target.device
def camera_ray_at(cam, motion_f, i, j, key):
    """`camera_ray` of a camera that may move: a moving one's ray, cast in its own space, is
    placed in the world by its keyframes at the ray's time."""
    o, d, time = camera_ray(cam, i, j, key)
    if MOTION and cam[CAM_KEYS] > 0.0:
        world, _ = maps_at(motion_f, int(cam[CAM_FIRST_KEY]), int(cam[CAM_KEYS]), time)
        return map_point(world, o), map_vector(world, d), time
    return o, d, time


@target.device
def camera_importance(cam, width, height, x, key):
    """Where point x (world) shows on the film, for light tracing (tracing/caustics.py): (ok,
    pixel column, pixel row, the lens point the connection ends at, the factor K that turns the
    radiance x leaves towards that point into the pixel's value).

    A pixel's value is the mean over its area (1 in pixel units) and the lens of the radiance
    along the ray through it. For one lens point l, a pixel's area maps to dA = |du| |dv| on the
    focus plane, at distance D from the lens along the axis, and a patch of the focus plane seen at
    angle theta from the axis spans D^2 / cos^3(theta) of it per steradian. So
    pixel value = integral of L(x -> l) D^2 / (|du| |dv| cos^3 theta) d omega, and with
    d omega = cos(x's normal, l - x) dA_x / |x - l|^2 (the caller's BSDF cosine and distance) the
    factor is K = D^2 / (|du| |dv| cos^3 theta). Not ok behind the lens or off the film.
    """
    c = CAM_ORIGIN
    origin = (cam[c], cam[c + 1], cam[c + 2])
    if DEFOCUS and cam[CAM_LENS_RADIUS] > 0.0:
        lx, ly = lens_point(key)
        a, b = CAM_LENS_U, CAM_LENS_V
        origin = (cam[c] + lx * cam[a] + ly * cam[b], cam[c + 1] + lx * cam[a + 1] + ly * cam[b + 1],
                  cam[c + 2] + lx * cam[a + 2] + ly * cam[b + 2])
    du = (cam[CAM_DU], cam[CAM_DU + 1], cam[CAM_DU + 2])
    dv = (cam[CAM_DV], cam[CAM_DV + 1], cam[CAM_DV + 2])
    p00 = (cam[CAM_PIXEL00], cam[CAM_PIXEL00 + 1], cam[CAM_PIXEL00 + 2])
    # The focus plane's normal, towards the scene.
    nx = du[1] * dv[2] - du[2] * dv[1]
    ny = du[2] * dv[0] - du[0] * dv[2]
    nz = du[0] * dv[1] - du[1] * dv[0]
    nn = math.sqrt(nx * nx + ny * ny + nz * nz)
    if not nn > 0.0:
        return False, 0, 0, origin, 0.0
    nx, ny, nz = nx / nn, ny / nn, nz / nn
    depth = (p00[0] - origin[0]) * nx + (p00[1] - origin[1]) * ny + (p00[2] - origin[2]) * nz
    if depth < 0.0:
        nx, ny, nz, depth = -nx, -ny, -nz, -depth
    tx, ty, tz = x[0] - origin[0], x[1] - origin[1], x[2] - origin[2]
    ahead = tx * nx + ty * ny + tz * nz
    if not ahead > 0.0 or not depth > 0.0:
        return False, 0, 0, origin, 0.0
    s = depth / ahead
    px = origin[0] + s * tx - p00[0]
    py = origin[1] + s * ty - p00[1]
    pz = origin[2] + s * tz - p00[2]
    du2 = du[0] * du[0] + du[1] * du[1] + du[2] * du[2]
    dv2 = dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]
    fx = (px * du[0] + py * du[1] + pz * du[2]) / du2 + 0.5
    fy = (px * dv[0] + py * dv[1] + pz * dv[2]) / dv2 + 0.5
    if not (0.0 <= fx < width and 0.0 <= fy < height):
        return False, 0, 0, origin, 0.0
    dist = math.sqrt(tx * tx + ty * ty + tz * tz)
    cos_t = ahead / dist
    k = depth * depth / (math.sqrt(du2 * dv2) * cos_t * cos_t * cos_t)
    return True, int(fx), int(fy), origin, k
