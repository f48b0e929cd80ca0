"""Chi-square of sampled directions over the whole sphere against a density, for lobes that
both reflect and transmit (tests/renderer/stats.py does the test itself).

The sphere is cut into NT x NP cells of (theta, phi) in a local frame; a cell's probability is
the integral of the density times sin theta over it. Lobes of refraction have edges (the
density jumps to 0 where no microfacet reaches, past a critical angle), and a fixed midpoint
rule converges only linearly across a jump: at 64 points per cell its error was 1% of a cell
next to the horizon, which a million samples see. So the integral is refined per cell until
it stops changing (`cell_probabilities`). Samples a lobe loses (no direction) get a bin of
their own, with probability 1 - the density's integral.
"""

from __future__ import annotations

import math

import numpy as np

from tests.renderer.stats import chi2_test

NT, NP = 40, 80
# Sub-grids of every cell, then of the cells whose integral still changed by more than TOLERANCE.
LEVELS = ((8, 8), (32, 32), (128, 64), (512, 128), (2048, 128))
TOLERANCE = 1e-7


def cell_masses(density, cells, kt, kp):
    """Midpoint-rule integrals of `density` (a function of (n, 3) unit directions) times sin theta
    over the given (theta row, phi column) cells, each on a kt x kp sub-grid."""
    n = len(cells)
    a = (np.arange(kt) + 0.5) / kt
    b = (np.arange(kp) + 0.5) / kp
    theta = np.broadcast_to((cells[:, 0, None, None] + a[None, :, None]) * (math.pi / NT), (n, kt, kp))
    phi = np.broadcast_to(-math.pi + (cells[:, 1, None, None] + b[None, None, :]) * (2 * math.pi / NP), (n, kt, kp))
    s = np.sin(theta)
    dirs = np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], -1).reshape(-1, 3)
    values = np.asarray(density(dirs)).reshape(n, kt * kp)
    return (values * s.reshape(n, kt * kp)).sum(axis=1) * (math.pi / NT / kt) * (2 * math.pi / NP / kp)


def cell_probabilities(density):
    """(NT, NP) probabilities of the cells: each cell's integral refined through LEVELS until it
    changes by at most TOLERANCE (an absolute probability)."""
    cells = np.array([(i, j) for i in range(NT) for j in range(NP)])
    kt, kp = LEVELS[0]
    mass = cell_masses(density, cells, kt, kp)
    todo = np.arange(len(cells))
    for kt, kp in LEVELS[1:]:
        finer = cell_masses(density, cells[todo], kt, kp)
        change = np.abs(finer - mass[todo])
        mass[todo] = finer
        todo = todo[change > TOLERANCE]
        if len(todo) == 0:
            break
    return mass.reshape(NT, NP)


def cell_counts(wi):
    """Counts of unit directions wi (n, 3) in the (theta, phi) cells, flattened."""
    theta = np.arccos(np.clip(wi[:, 2], -1.0, 1.0))
    phi = np.arctan2(wi[:, 1], wi[:, 0])
    it = np.clip((theta / math.pi * NT).astype(int), 0, NT - 1)
    ip = np.clip(((phi + math.pi) / (2 * math.pi) * NP).astype(int), 0, NP - 1)
    return np.bincount(it * NP + ip, minlength=NT * NP)


def sphere_p_value(wi, lost, probabilities):
    """(p-value, dof, integral): chi-square of directions wi and `lost` samples without one against
    cell `probabilities` (from `cell_probabilities`), the lost samples' bin 1 - their sum."""
    integral = float(probabilities.sum())
    assert integral <= 1.0 + 1e-6, f"the density integrates to {integral} > 1"
    probs = np.append(probabilities.ravel(), max(0.0, 1.0 - integral))
    counts = np.append(cell_counts(wi), lost)
    p, dof = chi2_test(counts, probs / probs.sum())
    return p, dof, integral
