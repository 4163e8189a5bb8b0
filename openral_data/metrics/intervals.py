"""Binomial intervals and tests: Wilson score interval, Newcombe's difference interval, Fisher's exact test.

References: Wilson (1927); Newcombe, "Interval estimation for the difference between independent
proportions" (Stat. Med. 1998), method 10 (hybrid score); Fisher's exact test, two-sided by summing the
probabilities of all tables no more likely than the observed one (the convention of R and scipy).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

Z95 = 1.959963984540054  # the 0.975 quantile of the standard normal


@dataclass(frozen=True)
class Interval:
    low: float
    high: float


def wilson(successes: int, n: int, z: float = Z95) -> Interval:
    """Wilson score interval for a binomial proportion; (0, 1) when n == 0."""
    if n < 0 or not 0 <= successes <= n:
        raise ValueError(f"need 0 <= successes <= n, got {successes}/{n}")
    if n == 0:
        return Interval(0.0, 1.0)
    p = successes / n
    z2 = z * z
    denom = 1.0 + z2 / n
    center = (p + z2 / (2 * n)) / denom
    half = z / denom * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n))
    low = 0.0 if successes == 0 else max(0.0, center - half)  # exact at the bounds, not 1 - 1e-16
    high = 1.0 if successes == n else min(1.0, center + half)
    return Interval(low, high)


def newcombe(k1: int, n1: int, k2: int, n2: int, z: float = Z95) -> Interval:
    """Interval for p1 - p2 from the two Wilson intervals (Newcombe's hybrid score method 10)."""
    if n1 == 0 or n2 == 0:
        return Interval(-1.0, 1.0)
    p1, p2 = k1 / n1, k2 / n2
    a, b = wilson(k1, n1, z), wilson(k2, n2, z)
    d = p1 - p2
    low = d - math.sqrt((p1 - a.low) ** 2 + (b.high - p2) ** 2)
    high = d + math.sqrt((a.high - p1) ** 2 + (p2 - b.low) ** 2)
    return Interval(max(-1.0, low), min(1.0, high))


def _log_hypergeom(x: int, k_total: int, n1: int, n2: int) -> float:
    """log P(X = x) where X = successes of group 1, given the margins (k_total successes overall)."""

    def log_comb(n: int, k: int) -> float:
        return math.lgamma(n + 1) - math.lgamma(k + 1) - math.lgamma(n - k + 1)

    return log_comb(n1, x) + log_comb(n2, k_total - x) - log_comb(n1 + n2, k_total)


def fisher_exact(k1: int, n1: int, k2: int, n2: int) -> float:
    """Two-sided p-value of Fisher's exact test for the 2x2 table [[k1, n1-k1], [k2, n2-k2]]."""
    if not (0 <= k1 <= n1 and 0 <= k2 <= n2):
        raise ValueError(f"invalid table {k1}/{n1}, {k2}/{n2}")
    k = k1 + k2
    lo, hi = max(0, k - n2), min(k, n1)
    observed = _log_hypergeom(k1, k, n1, n2)
    tol = 1e-7  # relative tolerance for ties, as R and scipy use
    total = 0.0
    for x in range(lo, hi + 1):
        lp = _log_hypergeom(x, k, n1, n2)
        if lp <= observed + math.log1p(tol):
            total += math.exp(lp)
    return min(1.0, total)
