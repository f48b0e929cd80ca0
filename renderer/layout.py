"""Type codes and row layouts of the flat scene tables, shared by the compiler and the kernels.

Primitive rows hold 16 float64 values:

- SPHERE:        center 0:3, radius 3, object_from_world rotation 4:13 (for uv)
- MOVING_SPHERE: center at time 0 (extrapolated) 0:3, radius 3, velocity 4:7, rotation 7:16
- QUAD, TRIANGLE, DISK (planar): corner or centre Q 0:3, unit normal 3:6, plane offset D 6,
  A = v x w 7:10 and B = w x u 10:13 with w = n / (n . n), n = u x v, so that the plane
  coordinates of a point P are alpha = (P - Q) . A and beta = (P - Q) . B (disk: u and v are
  radius-long axes, and the disk is alpha^2 + beta^2 <= 1)
- MEDIUM:        -1/density 0, first boundary row 1, number of boundary rows 2, serial number 3
- BOX:           an axis-aligned box of the tree's space, lo 0:3, hi 3:6. A box shape becomes
  one when its transform keeps it axis-aligned, it has thickness in every axis and its material
  does not read (u, v); otherwise it is six QUAD rows. One slab test replaces six quad tests.
"""

PRIM_WIDTH = 16

SPHERE = 0
MOVING_SPHERE = 1
QUAD = 2
TRIANGLE = 3
DISK = 4
MEDIUM = 5
BOX = 6

# Materials: kind, texture index, whether that texture reads (u, v) (an image, or a checker
# over one: the kernels compute (u, v) only then), and up to two parameters (metal fuzz,
# dielectric ior).
LAMBERTIAN = 0
METAL = 1
DIELECTRIC = 2
DIFFUSE_LIGHT = 3
ISOTROPIC = 4

# Textures: kind, colour, parameters, children.
TEX_SOLID = 0
TEX_CHECKER = 1  # param 0: 1/scale; children: even, odd
TEX_IMAGE = 2  # param 0: texel offset, 1: width, 2: height
TEX_NOISE = 3  # param 0: scale, 1: form, 2: octaves, 3: table index

NOISE_PLAIN = 0
NOISE_TURBULENCE = 1
NOISE_MARBLE = 2

BACKGROUND_SOLID = 0
BACKGROUND_SKY = 1
