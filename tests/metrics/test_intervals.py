"""Wilson, Newcombe and Fisher against textbook values and independent computations."""

from __future__ import annotations

import math
import random

import pytest
from scipy.stats import fisher_exact as scipy_fisher
from scipy.stats import norm

from openral_data.metrics import intervals


def _wilson_by_roots(k: int, n: int, z: float) -> tuple[float, float]:
    """The Wilson interval as the set {p : |k/n - p| <= z sqrt(p(1-p)/n)}: roots of a quadratic in p."""
    ph = k / n
    a = 1 + z * z / n
    b = -(2 * ph + z * z / n)
    c = ph * ph
    disc = math.sqrt(b * b - 4 * a * c)
    return (-b - disc) / (2 * a), (-b + disc) / (2 * a)


def test_z_is_the_normal_quantile() -> None:
    assert norm.ppf(0.975) == pytest.approx(intervals.Z95, abs=1e-12)


@pytest.mark.parametrize(("k", "n"), [(0, 1), (1, 1), (0, 10), (10, 10), (3, 7), (81, 263), (15, 148), (500, 1000)])
def test_wilson_matches_quadratic_roots(k: int, n: int) -> None:
    ci = intervals.wilson(k, n)
    lo, hi = _wilson_by_roots(k, n, intervals.Z95)
    assert ci.low == pytest.approx(max(lo, 0.0), abs=1e-12)
    assert ci.high == pytest.approx(min(hi, 1.0), abs=1e-12)
    assert ci.low <= k / n <= ci.high


def test_wilson_textbook_values() -> None:
    # Newcombe (1998), "Two-sided confidence intervals for the single proportion", Table I, score method
    ci = intervals.wilson(81, 263)
    assert (round(ci.low, 4), round(ci.high, 4)) == (0.2553, 0.3662)
    ci = intervals.wilson(15, 148)
    assert (round(ci.low, 4), round(ci.high, 4)) == (0.0624, 0.1605)
    ci = intervals.wilson(0, 20)
    assert (round(ci.low, 4), round(ci.high, 4)) == (0.0, 0.1611)


def test_newcombe_textbook_values() -> None:
    # Newcombe (1998), "Interval estimation for the difference between independent proportions", method 10
    ci = intervals.newcombe(56, 70, 48, 80)
    assert (round(ci.low, 4), round(ci.high, 4)) == (0.0524, 0.3339)
    ci = intervals.newcombe(9, 10, 3, 10)
    assert (round(ci.low, 4), round(ci.high, 4)) == (0.1705, 0.8090)


def test_newcombe_is_the_hybrid_of_two_wilson_intervals() -> None:
    rng = random.Random(1)
    for _ in range(200):
        n1, n2 = rng.randint(1, 60), rng.randint(1, 60)
        k1, k2 = rng.randint(0, n1), rng.randint(0, n2)
        l1, u1 = _wilson_by_roots(k1, n1, intervals.Z95)
        l2, u2 = _wilson_by_roots(k2, n2, intervals.Z95)
        p1, p2 = k1 / n1, k2 / n2
        ci = intervals.newcombe(k1, n1, k2, n2)
        assert ci.low == pytest.approx(max(-1.0, p1 - p2 - math.hypot(p1 - l1, u2 - p2)), abs=1e-9)
        assert ci.high == pytest.approx(min(1.0, p1 - p2 + math.hypot(u1 - p1, p2 - l2)), abs=1e-9)


def test_fisher_matches_scipy() -> None:
    rng = random.Random(7)
    cases = [(3, 3, 0, 3), (1, 10, 9, 10), (0, 5, 0, 5), (5, 5, 5, 5), (7, 12, 2, 9)]
    for _ in range(300):
        n1, n2 = rng.randint(1, 40), rng.randint(1, 40)
        cases.append((rng.randint(0, n1), n1, rng.randint(0, n2), n2))
    for k1, n1, k2, n2 in cases:
        expected = scipy_fisher([[k1, n1 - k1], [k2, n2 - k2]], alternative="two-sided").pvalue
        assert intervals.fisher_exact(k1, n1, k2, n2) == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_invalid_counts_are_rejected() -> None:
    with pytest.raises(ValueError):
        intervals.wilson(5, 4)
    with pytest.raises(ValueError):
        intervals.fisher_exact(3, 2, 0, 1)
