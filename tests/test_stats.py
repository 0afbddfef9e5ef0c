"""Binomial statistics against hand-computed values."""

from __future__ import annotations

import pytest

from libero_data.stats import binomial_cdf, fisher_exact, least_successes, starts_needed, wilson_interval


def test_wilson_interval() -> None:
    # 8 of 10: centre (0.8 + 1.92/10) / 1.384 = 0.7168, half 1.96 sqrt(0.016 + 0.00096) / 1.384 = 0.1844
    low, high = wilson_interval(8, 10)
    assert low == pytest.approx(0.4902, abs=1e-4) and high == pytest.approx(0.9433, abs=1e-4)
    assert wilson_interval(50, 50)[1] == 1.0 and wilson_interval(50, 50)[0] == pytest.approx(0.9287, abs=1e-4)
    assert wilson_interval(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError, match=r"successes must be in 0\.\.n"):
        wilson_interval(3, 2)


def test_binomial_tail_and_thresholds() -> None:
    assert binomial_cdf(0, 3, 0.9) == pytest.approx(0.001)
    assert binomial_cdf(1, 3, 0.9) == pytest.approx(0.001 + 3 * 0.9 * 0.01)
    assert binomial_cdf(-1, 3, 0.9) == 0.0 and binomial_cdf(3, 3, 0.9) == pytest.approx(1.0)
    assert least_successes(3, 0.9, 0.001) == 1  # P(0 of 3) = 0.001, P(<= 1 of 3) = 0.028
    assert least_successes(3, 0.9, 0.05) == 2
    assert least_successes(3, 0.5, 0.001) == 0  # nothing can be asserted
    assert starts_needed(0.9, 0.001) == 3 and starts_needed(0.5, 0.001) == 10
    assert starts_needed(1.0, 0.001) == 1 and starts_needed(0.0, 0.001, most=7) == 7


def test_holm_adjusted_steps_down_and_keeps_order() -> None:
    from libero_data.stats import holm_adjusted

    # sorted: 0.01*3 = 0.03, 0.02*2 = 0.04, 0.04*1 = 0.04; then back in the given order
    assert holm_adjusted([0.04, 0.01, 0.02]) == pytest.approx([0.04, 0.03, 0.04])
    # never above 1, and monotone in the sorted order even where k*p would fall
    assert holm_adjusted([0.5, 0.6]) == pytest.approx([1.0, 1.0])
    assert holm_adjusted([0.001, 0.3, 0.02]) == pytest.approx([0.003, 0.3, 0.04])
    assert holm_adjusted([]) == []


def test_fisher_exact_two_sided() -> None:
    # Fisher's tea tasting: 3 of 4 against 1 of 4, two-sided p = 17/35
    assert fisher_exact(3, 4, 1, 4) == pytest.approx(17 / 35)
    # 42 of 50 against 50 of 50 (libero_spatial/7 before and after issue 74), as SciPy gives it
    assert fisher_exact(42, 50, 50, 50) == pytest.approx(0.005770162019615051)
    assert fisher_exact(34, 50, 26, 50) == pytest.approx(fisher_exact(26, 50, 34, 50))
    assert fisher_exact(20, 50, 20, 50) == 1.0
    with pytest.raises(ValueError):
        fisher_exact(6, 5, 1, 5)
