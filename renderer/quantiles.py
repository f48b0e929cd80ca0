"""Quantiles of the chi-square and F distributions, for the error estimate's confidence bounds.

Plain Python over `math` (the renderer does not depend on scipy): the regularised incomplete gamma
and beta functions by their series and continued fractions (the classical Lentz evaluation), and a
quantile by bisection of the distribution function on a log scale. Degrees of freedom may be any
positive real (the error estimate's are effective counts, Satterthwaite style). Each call costs
well under a millisecond; the estimate asks for a handful per image.
"""

from __future__ import annotations

import math
from functools import lru_cache

# Degrees of freedom above this are treated as this many: the distributions are then so narrow
# that the bounds move by under a part in a thousand, and the continued fractions stay short.
MAX_DOF = 1e6
_TINY = 1e-300
_EPS = 1e-14


def _gamma_pq(a: float, x: float) -> tuple[float, float]:
    """The regularised incomplete gamma functions (P(a, x), Q(a, x)), P + Q = 1: the one its
    expansion converges for is computed directly (the series for P below x = a + 1, the continued
    fraction for Q above, evaluated by Lentz's method), so it keeps its precision far into its
    tail (a chi-square test's p-value of 1e-30), and the other is its complement."""
    if x <= 0.0:
        return 0.0, 1.0
    log_front = -x + a * math.log(x) - math.lgamma(a)
    if x < a + 1.0:  # the series converges fast here
        term = total = 1.0 / a
        ap = a
        for _ in range(100_000):
            ap += 1.0
            term *= x / ap
            total += term
            if abs(term) < abs(total) * _EPS:
                break
        lower = min(1.0, total * math.exp(log_front))
        return lower, max(0.0, 1.0 - lower)
    b = x + 1.0 - a
    c = 1.0 / _TINY
    d = 1.0 / b
    h = d
    for i in range(1, 100_000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = _TINY if abs(d) < _TINY else d
        c = b + an / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        step = d * c
        h *= step
        if abs(step - 1.0) < _EPS:
            break
    upper = min(1.0, math.exp(log_front) * h)
    return max(0.0, 1.0 - upper), upper


def _gamma_p(a: float, x: float) -> float:
    """Regularised lower incomplete gamma P(a, x)."""
    return _gamma_pq(a, x)[0]


def gamma_q(a: float, x: float) -> float:
    """Regularised upper incomplete gamma Q(a, x) = 1 - P(a, x), precise in its own tail."""
    return _gamma_pq(a, x)[1]


def _beta_fraction(a: float, b: float, x: float) -> float:
    """The continued fraction of the incomplete beta function (converges for x < (a+1)/(a+b+2))."""
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c = 1.0
    d = 1.0 - qab * x / qap
    d = _TINY if abs(d) < _TINY else d
    d = 1.0 / d
    h = d
    for m in range(1, 200_000):
        m2 = 2 * m
        aa = m * (b - m) * x / ((qam + m2) * (a + m2))
        d = 1.0 + aa * d
        d = _TINY if abs(d) < _TINY else d
        c = 1.0 + aa / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        h *= d * c
        aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))
        d = 1.0 + aa * d
        d = _TINY if abs(d) < _TINY else d
        c = 1.0 + aa / c
        c = _TINY if abs(c) < _TINY else c
        d = 1.0 / d
        step = d * c
        h *= step
        if abs(step - 1.0) < _EPS:
            break
    return h


def _beta_i(a: float, b: float, x: float) -> float:
    """Regularised incomplete beta I_x(a, b)."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    log_front = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    if x < (a + 1.0) / (a + b + 2.0):
        return min(1.0, math.exp(log_front) * _beta_fraction(a, b, x) / a)
    return max(0.0, 1.0 - math.exp(log_front) * _beta_fraction(b, a, 1.0 - x) / b)


def chi2_cdf(x: float, dof: float) -> float:
    """P(X <= x) for X chi-square distributed with `dof` degrees of freedom."""
    return _gamma_p(0.5 * min(dof, MAX_DOF), 0.5 * x)


def f_cdf(x: float, dof1: float, dof2: float) -> float:
    """P(X <= x) for X F-distributed with (dof1, dof2) degrees of freedom."""
    if x <= 0.0:
        return 0.0
    d1, d2 = min(dof1, MAX_DOF), min(dof2, MAX_DOF)
    return _beta_i(0.5 * d1, 0.5 * d2, d1 * x / (d1 * x + d2))


def _invert(cdf, p: float, guess: float) -> float:
    """The x > 0 with cdf(x) = p: bracket it by factors of 4 from `guess`, then regula falsi on
    log x with the Illinois step (the distribution functions are smooth and monotone: a handful of
    evaluations, where bisection would take forty)."""
    lo = hi = guess
    f_lo = f_hi = cdf(guess) - p
    while f_lo > 0 and lo > 1e-300:
        hi, f_hi = lo, f_lo
        lo *= 0.25
        f_lo = cdf(lo) - p
    while f_hi < 0 and hi < 1e300:
        lo, f_lo = hi, f_hi
        hi *= 4.0
        f_hi = cdf(hi) - p
    if f_lo == 0:
        return lo
    if f_hi == 0 or lo == hi:
        return hi
    a, b = math.log(lo), math.log(hi)
    side = 0
    for _ in range(200):
        c = (a * f_hi - b * f_lo) / (f_hi - f_lo)
        f_c = cdf(math.exp(c)) - p
        if f_c == 0 or abs(b - a) < 1e-11:
            return math.exp(c)
        if (f_c < 0) == (f_lo < 0):
            a, f_lo = c, f_c
            if side == -1:
                f_hi *= 0.5
            side = -1
        else:
            b, f_hi = c, f_c
            if side == 1:
                f_lo *= 0.5
            side = 1
        if abs(f_c) < 1e-13:
            return math.exp(c)
    return math.exp(0.5 * (a + b))


def normal_quantile(p: float) -> float:
    """The standard normal p-quantile (Acklam's rational approximation, relative error < 1.2e-9)."""
    a = (-3.969683028665376e01, 2.209460984245205e02, -2.759285104469687e02, 1.383577518672690e02,
         -3.066479806614716e01, 2.506628277459239e00)
    b = (-5.447609879822406e01, 1.615858368580409e02, -1.556989798598866e02, 6.680131188771972e01, -1.328068155288572e01)
    c = (-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e00, -2.549732539343734e00,
         4.374664141464968e00, 2.938163982698783e00)
    d = (7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e00, 3.754408661907416e00)
    if p < 0.02425:
        q = math.sqrt(-2 * math.log(p))
        return (((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]) / ((((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1)
    if p > 1 - 0.02425:
        return -normal_quantile(1 - p)
    q = p - 0.5
    r = q * q
    return (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q / (((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1)


@lru_cache(maxsize=256)
def chi2_quantile(p: float, dof: float) -> float:
    """The p-quantile of the chi-square distribution with `dof` (> 0) degrees of freedom: by
    inverting its distribution function, and past MAX_DOF by Wilson and Hilferty's cube-root
    normal approximation (its error falls as dof^-1.5: nothing at such counts)."""
    if not 0.0 < p < 1.0 or not dof > 0:
        raise ValueError(f"chi2_quantile needs 0 < p < 1 and dof > 0, got p={p}, dof={dof}")
    if dof > MAX_DOF:
        z = normal_quantile(p)
        return dof * max(0.0, 1 - 2 / (9 * dof) + z * math.sqrt(2 / (9 * dof))) ** 3
    return _invert(lambda x: chi2_cdf(x, dof), p, max(dof, 1e-3))


@lru_cache(maxsize=256)
def f_quantile(p: float, dof1: float, dof2: float) -> float:
    """The p-quantile of the F distribution with (dof1, dof2) (> 0) degrees of freedom."""
    if not 0.0 < p < 1.0 or not (dof1 > 0 and dof2 > 0):
        raise ValueError(f"f_quantile needs 0 < p < 1 and positive dof, got p={p}, dof=({dof1}, {dof2})")
    return _invert(lambda x: f_cdf(x, dof1, dof2), p, 1.0)
