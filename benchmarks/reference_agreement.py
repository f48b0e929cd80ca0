"""Whether two converged references of one scene, made by independent estimators (mis and
caustics: tests/renderer/converged.py --integrator), agree as well as their own errors say.

Each reference keeps the difference of its two renders, whose squares estimate its own noise
without trusting the samples' spread (which rare bright paths make too small): the variance of a
pixel of `mean` (the average of two renders) is E[difference^2] / 4. The two references are
independent, so the expected squared difference of their means is the sum of the two.

- `rms`: the relative RMS of the difference of the two means over the pixels given, and
  `expected_rms` what the references' own errors predict for it (a ratio near 1: they agree; well
  above 1: one of them is biased, or its noise is heavier than its two renders showed);
- `z`: the difference of the two images' means over those pixels in standard errors (pixels are
  independent, so the variance of an image mean is the sum of its pixels' variances over the
  count squared), with the larger of the two variance estimates (difference or spread).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class Agreement(NamedTuple):
    rms: float  # relative RMS of mean_a - mean_b
    expected_rms: float  # what the two references' own errors predict for it
    z: float  # (image mean of a - image mean of b) / its standard error
    relative_mean_difference: float  # (image mean of a - image mean of b) / image mean of b


def agreement(a, b) -> Agreement:
    """How references `a` and `b` (converged.Reference, over the same pixels) agree (see above)."""
    signal = float(np.sum(np.square(b.mean)))
    squared = float(np.sum(np.square(a.mean - b.mean)))
    expected = (float(np.sum(np.square(a.difference))) + float(np.sum(np.square(b.difference)))) / 4.0
    n = a.mean.size
    var_from_difference = expected / n**2
    var_from_spread = (float(np.sum(a.var)) + float(np.sum(b.var))) / n**2
    gap = float(np.mean(a.mean)) - float(np.mean(b.mean))
    spread = math.sqrt(max(var_from_difference, var_from_spread))
    return Agreement(math.sqrt(squared / signal), math.sqrt(expected / signal), gap / spread if spread > 0 else math.inf,
                     gap / float(np.mean(b.mean)))
