"""Tuning constants of the renderer, in one place (never changed at run time)."""

# BVH construction
BVH_BINS = 16  # SAH bins per split
BVH_MAX_LEAF = 4  # most primitives in a leaf
BVH_STACK = 64  # traversal stack depth (a binned SAH tree over 10^7 primitives stays far below)
# A four-wide tree is no deeper than the binary one it comes from, and each level leaves at most
# three of a node's children on the stack while visiting the fourth.
BVH_WIDE_STACK = 3 * BVH_STACK + 4
# Media a ray meets in one tree that are set aside to test after its surfaces (more are tested at once).
MEDIA_DEFERRED = 8

# Ray origins of scattered rays are pushed off the surface by this fraction of the magnitude of
# the coordinates involved: float64 rounding of a hit point is ~1e-16 of that magnitude, so
# 1e-9 leaves seven orders of margin while staying far below any feature a scene can resolve.
SPAWN_OFFSET = 1e-9

# Interleaved batches: sample s of a pixel belongs to batch s % BATCHES. The batches are independent
# estimates of the pixel (with the Sobol sampler each is its own scrambled sequence), so the spread of
# their means measures the error honestly even where samples within a batch are stratified.
BATCHES = 8
