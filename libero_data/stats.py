"""Binomial statistics for success rates: intervals, how many successes to expect, and tests
of paired outcomes (with Holm's adjustment for a family of them).

Pure functions of counts (no NumPy or SciPy needed). Used by the expert tests, which derive
their margins from the committed expert table, and by anything that reports a rate over a
handful of episodes.
"""

from __future__ import annotations

import math
from collections.abc import Sequence


def wilson_interval(successes: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """The Wilson score interval of a rate (95% by default); ``(0, 1)`` for ``n == 0``."""
    if not 0 <= successes <= n:
        raise ValueError(f"successes must be in 0..n, got {successes} of {n}")
    if n == 0:
        return 0.0, 1.0
    p = successes / n
    denominator = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denominator
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denominator
    return max(0.0, centre - half), min(1.0, centre + half)


def binomial_cdf(k: int, n: int, p: float) -> float:
    """P(X <= k) for X ~ Binomial(n, p)."""
    if k < 0:
        return 0.0
    return min(1.0, sum(math.comb(n, i) * p**i * (1 - p) ** (n - i) for i in range(min(k, n) + 1)))


def least_successes(n: int, p: float, alpha: float) -> int:
    """The most successes ``k`` such that fewer than ``k`` of ``n`` has probability <= ``alpha``
    at rate ``p``: asserting at least ``k`` fails a working expert with probability <= ``alpha``."""
    k = 0
    while k < n and binomial_cdf(k, n, p) <= alpha:
        k += 1
    return k


def starts_needed(p: float, alpha: float, most: int = 50) -> int:
    """The fewest episodes at rate ``p`` for which 'none succeeded' has probability <= ``alpha``
    (so that asserting one success means something), at most ``most``."""
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    if p >= 1:
        return 1
    if p <= 0:
        return most
    # (the small margin keeps an exact integer, e.g. 3 for p = 0.9 and alpha = 0.001, from rounding up)
    return min(most, max(1, math.ceil(math.log(alpha) / math.log(1 - p) - 1e-9)))


def mcnemar_exact(only_a: int, only_b: int) -> float:
    """Two-sided exact McNemar test of paired outcomes: the p-value that two methods succeed
    equally often, from the pairs where only A (``only_a``) or only B (``only_b``) succeeded.
    Concordant pairs carry no information; with no discordant pair the p-value is 1."""
    if only_a < 0 or only_b < 0:
        raise ValueError(f"counts must not be negative, got {only_a} and {only_b}")
    n = only_a + only_b
    if n == 0:
        return 1.0
    return min(1.0, 2.0 * binomial_cdf(min(only_a, only_b), n, 0.5))


def fisher_exact(a: int, n: int, b: int, m: int) -> float:
    """Two-sided Fisher exact test of two independent rates: the p-value that ``a`` successes of
    ``n`` and ``b`` of ``m`` come from one rate (the tables as or less likely than the observed one,
    given both margins)."""
    if not (0 <= a <= n and 0 <= b <= m):
        raise ValueError(f"need 0 <= successes <= trials, got {a}/{n} and {b}/{m}")
    total, k = n + m, a + b

    def p(x: int) -> float:
        return math.comb(n, x) * math.comb(m, k - x) / math.comb(total, k)

    observed = p(a)
    probs = [p(x) for x in range(max(0, k - m), min(k, n) + 1)]
    return float(min(1.0, sum(q for q in probs if q <= observed * (1 + 1e-9))))


def holm_adjusted(p_values: Sequence[float]) -> list[float]:
    """Holm's step-down adjustment of a family of p-values, in their given order: a hypothesis
    is rejected at level alpha when its adjusted p-value is below alpha, which keeps the chance
    of any false rejection in the family under alpha (no assumption about their dependence)."""
    order = sorted(range(len(p_values)), key=lambda i: p_values[i])
    adjusted = [1.0] * len(p_values)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p_values) - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted
