"""Which optional paths the kernels compile in.

Numba freezes module globals into the machine code as constants, and its dead-branch pass
drops `if FLAG and ...:` blocks whose FLAG is False before they are even type-checked. So a
path behind a False flag costs neither time at render nor time at compile.

This module, as shipped, turns every path on: `renderer.kernels` is the general kernel that
renders any scene. `renderer.variants` loads further copies of this package with this module
replaced, one per feature set a scene needs (a flag is only ever off where the flat scene
cannot reach that path, so the image is the same bit for bit).
"""

MOTION = True  # time sampling and moving sphere centres
DEFOCUS = True  # sampling the lens disk
MEDIA = True  # constant-density media in the trees and scattering inside them
INSTANCES = True  # the top-level tree and per-instance transforms
CHECKER = True  # checker textures
IMAGE = True  # image textures
NOISE = True  # Perlin noise textures
EMITTERS = True  # diffuse lights
DIELECTRICS = True  # refraction
SKY = True  # the sky-gradient background
LIGHTS = True  # light sampling: shadow rays to points on emitters, weighted with the path's own hits
ENVIRONMENT = True  # an image background: its lookup, and with `integrator: mis` its sampling as a light
MESHES = True  # triangle meshes: the ray's sheared frame and the watertight triangle test

NAMES = ("MOTION", "DEFOCUS", "MEDIA", "INSTANCES", "CHECKER", "IMAGE", "NOISE", "EMITTERS", "DIELECTRICS", "SKY", "LIGHTS", "ENVIRONMENT",
         "MESHES")
