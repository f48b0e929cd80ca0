"""Statistical checks shared by the robustness, furnace and sampling tests (no scipy needed).

Every check is a test at a stated significance: with the suite's fixed seeds the outcome is
deterministic, and a correct renderer fails a check with probability below its `alpha`.
"""

from __future__ import annotations

import math

import numpy as np

from renderer.quantiles import gamma_q

ALPHA = 1e-3  # significance of every check unless a test says otherwise


def chi2_sf(x: float, dof: int) -> float:
    """P(X >= x) for X chi-square distributed with `dof` degrees of freedom."""
    return gamma_q(0.5 * dof, 0.5 * x)


def chi2_test(counts, probs, min_expected: float = 5.0) -> tuple[float, int]:
    """(p-value, degrees of freedom) of observed bin `counts` against bin probabilities `probs`.

    Bins expected to hold fewer than `min_expected` samples are pooled into one (as Mitsuba's
    chi2 test does), so the chi-square approximation of the statistic holds.
    """
    counts = np.asarray(counts, dtype=np.float64).ravel()
    probs = np.asarray(probs, dtype=np.float64).ravel()
    assert counts.shape == probs.shape
    assert abs(probs.sum() - 1.0) < 1e-9, probs.sum()
    n = counts.sum()
    expected = probs * n
    small = expected < min_expected
    obs = list(counts[~small])
    exp = list(expected[~small])
    if small.any():
        obs.append(counts[small].sum())
        exp.append(expected[small].sum())
    obs, exp = np.array(obs), np.array(exp)
    if (exp == 0).any():
        # A pooled bin of zero probability must be empty.
        if obs[exp == 0].sum() > 0:
            return 0.0, len(exp) - 1
        obs, exp = obs[exp > 0], exp[exp > 0]
    stat = float(((obs - exp) ** 2 / exp).sum())
    dof = len(exp) - 1
    return chi2_sf(stat, dof), dof


def binomial_p_value(k: int, n: int, p: float) -> float:
    """Two-sided exact p-value of k successes in n trials of probability p: 2 min(P(X<=k), P(X>=k)).

    The sums run over a window of +-40 standard deviations (plus 60 terms) around the mean,
    outside of which the mass is far below double precision.
    """
    if p <= 0.0:
        return 1.0 if k == 0 else 0.0
    if p >= 1.0:
        return 1.0 if k == n else 0.0
    mean = n * p
    sd = math.sqrt(n * p * (1.0 - p))
    lo = max(0, int(mean - 40 * sd) - 60)
    hi = min(n, int(mean + 40 * sd) + 60)
    if not lo <= k <= hi:
        return 0.0
    lp, lq = math.log(p), math.log1p(-p)
    base = math.lgamma(n + 1)
    pmf = np.array([math.exp(base - math.lgamma(j + 1) - math.lgamma(n - j + 1) + j * lp + (n - j) * lq)
                    for j in range(lo, hi + 1)])
    at_most = pmf[: k - lo + 1].sum()
    at_least = pmf[k - lo:].sum()
    return float(min(1.0, 2.0 * min(at_most, at_least)))


def pixel_mean_and_se(film, channel: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Per-pixel mean and standard error of the mean (unbiased sample variance) of one channel."""
    n = film.samples
    mean = film.total[..., channel] / n
    var = np.maximum(film.total_sq[..., channel] - film.total[..., channel] * mean, 0.0) / (n - 1)
    return mean, np.sqrt(var / n)


def film_mean_and_se(film, pooled: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard error of the mean of all the film's samples, per channel over every
    pixel; with `pooled`, one mean over the channels as well (each channel's value a sample)."""
    axis = None if pooled else (0, 1)
    n = film.samples * (film.total.size if pooled else film.total[..., 0].size)
    mean = film.total.sum(axis=axis) / n
    var = film.total_sq.sum(axis=axis) / n - mean * mean
    return mean, np.sqrt(var / n)


def z_limit(tests: int, alpha: float = ALPHA) -> float:
    """|z| bound for `tests` two-sided normal tests at family-wise level alpha (Bonferroni)."""
    # Inverse of the normal tail by bisection on erfc (no scipy).
    target = alpha / tests
    lo, hi = 0.0, 40.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if math.erfc(mid / math.sqrt(2.0)) > target:
            lo = mid
        else:
            hi = mid
    return hi


def block_sums(film, block: int):
    """Per block of block x block pixels: (sum, sum of squares, number of samples), per channel."""
    h, w, _ = film.total.shape
    hb, wb = h // block, w // block
    s = film.total[: hb * block, : wb * block].reshape(hb, block, wb, block, 3).sum(axis=(1, 3))
    s2 = film.total_sq[: hb * block, : wb * block].reshape(hb, block, wb, block, 3).sum(axis=(1, 3))
    return s, s2, block * block * film.samples


def block_z(film_a, film_b, block: int = 4) -> np.ndarray:
    """Two-sample z-score of each block's mean (per channel) between two independent renders."""
    sa, sa2, na = block_sums(film_a, block)
    sb, sb2, nb = block_sums(film_b, block)
    ma, mb = sa / na, sb / nb
    va = np.maximum(sa2 - sa * ma, 0.0) / (na - 1)
    vb = np.maximum(sb2 - sb * mb, 0.0) / (nb - 1)
    se = np.sqrt(va / na + vb / nb)
    diff = ma - mb
    exact = se == 0.0
    return np.where(exact, np.where(np.abs(diff) <= 1e-12 * np.maximum(1.0, np.abs(ma)), 0.0, np.inf),
                    diff / np.where(exact, 1.0, se))
