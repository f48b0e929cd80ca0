"""Building the guide in numpy from a training iteration's records (guide_training.py).

Skeleton: `build_guide` keeps the contract's signature and builds no guide yet (every vertex
then samples its BSDF alone: a guided render is mis's image); the spatial tree and the
directional quadtrees replace it.
"""

from __future__ import annotations

from .guiding import empty_guide


def build_guide(positions, directions, weights, lo, hi, **settings) -> dict:
    """The guide tables (guide_f, guide_i) learned from records: positions (N, 3), unit
    directions (N, 3), weights (N,) >= 0 (radiance luminance over the direction's density), inside
    the box lo..hi."""
    return empty_guide()
